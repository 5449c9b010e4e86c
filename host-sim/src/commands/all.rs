//! `host-sim all` (and `host-sim` with no command): every built-in scenario, plus the
//! tracking law on the paper's saturated scenarios for the side-by-side figures.

use crate::closed_loop::runner::RunOutput;
use crate::commands::run::{print_table, run_one, OutputArgs};
use crate::commands::EXIT_NOT_AS_EXPECTED;
use crate::output::plots::compare_plot;
use crate::output::Outputs;
use anyhow::{bail, Result};
use rayon::prelude::*;
use sim_scenario::setup::RunSetup;
use sim_scenario::{ControllerKind, ExpectSpec, Scenario, BUILT_IN};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Arguments of `host-sim all`.
#[derive(Debug, clap::Args)]
pub struct AllArgs {
    /// Output folder; each scenario goes to DIR/<scenario>/.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    /// Which files besides each summary.json.
    #[command(flatten)]
    pub outputs: OutputArgs,
}

/// Run `host-sim all` into `out_dir` with every output: 1 when a built-in's result differs
/// from what its file expects.
pub fn main(out_dir: &Path) -> Result<ExitCode> {
    main_with(&AllArgs {
        out: out_dir.to_path_buf(),
        outputs: OutputArgs::default(),
    })
}

/// Run `host-sim all` with its arguments: 1 when a built-in's result differs from what its
/// file expects.
pub fn main_with(a: &AllArgs) -> Result<ExitCode> {
    Ok(if run_all(&a.out, a.outputs.outputs())? {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_NOT_AS_EXPECTED)
    })
}

/// Every built-in scenario; `Ok(false)` when one's result differs from what its file
/// expects.
fn run_all(out_dir: &Path, outputs: Outputs) -> Result<bool> {
    // Every built-in, plus the tracking law on the paper's saturated scenarios for the
    // side-by-side figures.
    let mut jobs: Vec<(String, Result<RunSetup>)> = BUILT_IN
        .iter()
        .map(|b| (b.name.to_string(), Scenario::load_setup(b.name)))
        .collect();
    for p in ["xz", "xy"] {
        let name = format!("paper-{p}-saturated");
        let sc = Scenario::load_setup(&name).and_then(|s| {
            let mut s = s.into_scenario();
            s.controller = ControllerKind::Tracking;
            s.name = format!("{name}-tracking");
            // The file's targets are the paper law's; the for the tracking law on the
            // paper's scenarios with the limits: final <= 1 cm, max <= 5 cm after 10 s.
            s.expect = Some(ExpectSpec {
                final_m: Some(0.01),
                max_m: Some(0.05),
                ..ExpectSpec::default()
            });
            s.resolve()
        });
        jobs.push((format!("{name}-tracking"), sc));
    }
    let results: Vec<(String, Result<RunOutput>)> = jobs
        .into_par_iter()
        .map(|(name, sc)| {
            let r = sc.and_then(|sc| run_one(&sc, &out_dir.join(&sc.name), outputs));
            (name, r)
        })
        .collect();
    let mut ok = Vec::new();
    let mut failed = 0;
    for (name, r) in &results {
        match r {
            Ok(o) => ok.push(o),
            Err(e) => {
                failed += 1;
                eprintln!("{name}: error: {e:#}");
            }
        }
    }
    for p in ["xz", "xy"] {
        let find = |n: &str| ok.iter().find(|o| o.summary.scenario == n).copied();
        if !outputs.plots {
            break;
        }
        if let (Some(a), Some(b)) = (
            find(&format!("paper-{p}-saturated")),
            find(&format!("paper-{p}-saturated-tracking")),
        ) {
            let path = out_dir.join(format!("compare-{p}.png"));
            compare_plot(&path, a, b)?;
            println!("wrote {}", path.display());
        }
    }
    print_table(&ok);
    println!("outputs in {}/<scenario>/", out_dir.display());
    if failed > 0 {
        bail!("{failed} scenario(s) failed");
    }
    let differ: Vec<&str> = ok
        .iter()
        .filter(|o| o.summary.targets.as_ref().is_some_and(|t| !t.met))
        .map(|o| o.summary.scenario.as_str())
        .collect();
    if !differ.is_empty() {
        eprintln!(
            "{} scenario(s) differ from what their files expect: {}",
            differ.len(),
            differ.join(", ")
        );
    }
    Ok(differ.is_empty())
}
