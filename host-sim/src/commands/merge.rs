//! `host-sim merge`: join the folders of `monte-carlo --shard` runs into the campaign's
//! summary, table and histogram (the same bytes as one run of the whole campaign).

use crate::commands::monte_carlo::{merge_shards, write_batch};
use anyhow::Result;
use std::path::PathBuf;

/// Arguments of `host-sim merge`.
#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shard folders (each holds a runs.json).
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// Run `host-sim merge`.
pub fn main(a: MergeArgs) -> Result<()> {
    let (summary, runs) = merge_shards(&a.dirs)?;
    write_batch(&a.out, &summary, &runs)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    println!(
        "merged {} shard folders into {}",
        a.dirs.len(),
        a.out.display()
    );
    Ok(())
}
