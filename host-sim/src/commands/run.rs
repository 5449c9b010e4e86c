//! `host-sim run`: one scenario (a built-in name or a file), its outputs and its verdict.

use crate::checks::refused;
use crate::closed_loop::runner::{run, RunOptions, RunOutput};
use crate::closed_loop::verdict_word;
use crate::commands::run_code;
use crate::output::{write_run_with, Outputs};
use crate::tether::topside_layout::run_layout;
use anyhow::Result;
use sim_scenario::deployment::Control;
use sim_scenario::setup::RunSetup;
use sim_scenario::{ControllerKind, Scenario};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Arguments of `host-sim run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Built-in name (see `list`) or path to a scenario file.
    pub scenario: String,
    /// Override the scenario's controller: "paper" or "tracking".
    #[arg(long)]
    pub controller: Option<String>,
    /// Output folder (default out/<scenario>[-<controller>]).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Which files besides summary.json.
    #[command(flatten)]
    pub outputs: OutputArgs,
}

/// The files a run writes besides `summary.json` (campaigns of many runs may want neither).
#[derive(Debug, Clone, Copy, Default, clap::Args)]
pub struct OutputArgs {
    /// Write no timeseries.csv (the summary and its figures are the same).
    #[arg(long)]
    pub no_timeseries: bool,
    /// Write no PNG figures.
    #[arg(long)]
    pub no_plots: bool,
}

impl OutputArgs {
    /// The files to write.
    pub fn outputs(self) -> Outputs {
        Outputs {
            timeseries: !self.no_timeseries,
            plots: !self.no_plots,
        }
    }
}

/// The table of finished runs (one line each, then each verdict).
pub fn print_table(rows: &[&RunOutput]) {
    println!(
        "{:<34} {:>6} {:>9} {:>10} {:>10} {:>10} {:>10} {:>10} {:>9} {:>7}  {:<12}",
        "scenario",
        "plane",
        "law",
        "final m",
        "max m",
        "max>10s m",
        "rms m",
        "tail rms m",
        "max |F| N",
        "sat %",
        "verdict"
    );
    for o in rows {
        let s = &o.summary;
        // Against the scenario's own targets (`[expect]`); `-` without any.
        let status = verdict_word(s);
        println!(
            "{:<34} {:>6} {:>9} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>10.4} {:>9.2} {:>7.1}  {:<12}",
            s.scenario,
            s.plane,
            s.controller,
            s.final_position_error_m,
            s.max_position_error_m,
            s.max_position_error_after_10s_m,
            s.rms_position_error_m,
            s.rms_position_error_tail_m,
            s.max_abs_thruster_force_n,
            100.0 * s.saturated_fraction,
            status
        );
    }
    for o in rows {
        println!("  {:<32} {}", o.summary.scenario, o.summary.verdict);
    }
}

/// A recorded software run of `sc`, its outputs written to `dir`: the core in process, or
/// with `[deployment] control = "topside"` the topside layout (`layout.json`
/// beside the run's outputs holds the node link's figures).
/// Only the files of `outputs` besides `summary.json` are written; with neither the
/// time series nor the figures, no per-tick log is kept.
pub fn run_one(sc: &RunSetup, dir: &Path, outputs: Outputs) -> Result<RunOutput> {
    let opts = RunOptions {
        record: outputs.need_log(),
        ..RunOptions::default()
    };
    if sc.deployment.control == Control::Topside {
        let o = run_layout(sc, &opts)?;
        write_run_with(dir, &o.run, outputs)?;
        std::fs::write(
            dir.join("layout.json"),
            serde_json::to_string_pretty(&o.report)? + "\n",
        )?;
        return Ok(o.run);
    }
    let out = run(sc, &opts)?;
    write_run_with(dir, &out, outputs)?;
    Ok(out)
}

/// Run `host-sim run`; 1 when the run diverged, went non-finite or missed its targets.
pub fn main(a: RunArgs) -> Result<ExitCode> {
    // Checked once: the file as it is, or (with --controller) the file, then the scenario
    // with the other law.
    let sc = match a.controller {
        None => Scenario::load_setup(&a.scenario).map_err(refused)?,
        Some(c) => {
            let mut sc = Scenario::load(&a.scenario).map_err(refused)?;
            let kind = ControllerKind::parse(&c).map_err(refused)?;
            if kind != sc.controller {
                sc.controller = kind;
                sc.name = format!("{}-{}", sc.name, kind.as_str());
                // The file's targets are for its own law.
                sc.expect = None;
            }
            sc.resolve().map_err(refused)?
        }
    };
    let dir = a.out.unwrap_or_else(|| PathBuf::from("out").join(&sc.name));
    let o = run_one(&sc, &dir, a.outputs.outputs())?;
    print_table(&[&o]);
    println!("outputs in {}", dir.display());
    Ok(run_code(&o))
}
