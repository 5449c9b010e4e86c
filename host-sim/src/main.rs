//! `host-sim`: run scenarios, list them, Monte Carlo.
//!
//! ```text
//! host-sim                                   # every built-in scenario -> out/<scenario>/
//! host-sim all [--out DIR]                   # the same, into DIR
//! host-sim run <name-or-path.toml> [--controller paper|tracking] [--out DIR]
//! host-sim list
//! host-sim monte-carlo <scenario> --runs N [--seed S] [--perturb FRACTION] [--out DIR]
//! host-sim hil <scenario> [--qemu ELF | --serial DEVICE --baud N | --tcp HOST:PORT]
//! host-sim link --serial DEVICE [--baud N] | --tcp HOST:PORT | --qemu ELF [--script CMDS]
//! ```
//! New subcommands (e.g. `hil`, `link`) are one more variant in [`Command`] and one more arm
//! in `main`'s `match`.
//!
//! Exit codes (the README's table): 0 as expected; 1 a run that diverged, went non-finite,
//! lost control or missed its `[expect]` targets, or (the main job) a built-in whose result
//! differs from its file; 2 an input refused before any work; 3 work that could not complete.

use anyhow::{anyhow, bail, Result};
use clap::{Parser, Subcommand};
use host_sim::checks::{is_refused, refused};
use host_sim::monte_carlo::{
    check_campaign, merge_shards, parse_shard, run_batch, write_batch, McConfig,
};
use host_sim::output::write_run;
use host_sim::plots::compare_plot;
use host_sim::runner::{run, RunOptions, RunOutput};
use host_sim::scenario::{ControllerKind, ExpectSpec, Scenario, BUILT_IN};
use host_sim::sim_loop::verdict_word;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Exit codes (the README's table): 0 done and as expected; 1 a result that is not what was
/// expected (a target missed, a divergence, a built-in scenario that differs from its file);
/// 2 an input refused before any work started (clap's usage errors are 2 too); 3 work that
/// could not be completed (a file that could not be written, a link or board that failed).
const EXIT_REFUSED: u8 = 2;
/// See [`EXIT_REFUSED`].
const EXIT_NOT_AS_EXPECTED: u8 = 1;
/// See [`EXIT_REFUSED`].
const EXIT_FAILED: u8 = 3;

#[derive(Parser, Debug)]
#[command(
    name = "host-sim",
    version,
    about = "ROV Observer desktop simulator: scenarios, paper figures, Monte Carlo"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run every built-in scenario (what `host-sim` with no arguments does).
    All {
        /// Output folder; each scenario goes to DIR/<scenario>/.
        #[arg(long, default_value = "out")]
        out: PathBuf,
    },
    /// Run one scenario: a built-in name or a path to a .toml file.
    Run {
        /// Built-in name (see `list`) or path to a scenario file.
        scenario: String,
        /// Override the scenario's controller: "paper" or "tracking".
        #[arg(long)]
        controller: Option<String>,
        /// Output folder (default out/<scenario>[-<controller>]).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// List the built-in scenarios.
    List,
    /// Many runs of one scenario with perturbed plant parameters and random current direction.
    MonteCarlo {
        /// Built-in name or path to a scenario file.
        scenario: String,
        /// Number of runs.
        #[arg(long)]
        runs: usize,
        /// Master seed (the batch is reproducible for a seed).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Largest relative parameter perturbation (0.2 = +-20 %).
        #[arg(long, default_value_t = 0.2)]
        perturb: f64,
        /// Run only the I-th of N slices of the campaign (0-based), e.g. `--shard 3/16`;
        /// join the slices' folders with `host-sim merge`.
        #[arg(long, value_name = "I/N")]
        shard: Option<String>,
        /// Output folder (default out/monte-carlo-<scenario>[-shard-I-of-N]).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Join the folders of `monte-carlo --shard` runs into the campaign's summary, table and
    /// histogram (the same bytes as one run of the whole campaign).
    Merge {
        /// The shard folders (each holds a runs.json).
        #[arg(required = true)]
        dirs: Vec<PathBuf>,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Currents from every direction: the built-in paths in 0.1-0.3 m/s from 12 directions,
    /// the RMS tracking error as heat maps (issue 14's measurement).
    CurrentSweep {
        /// Output folder.
        #[arg(long, default_value = "out/current-sweep")]
        out: PathBuf,
    },
    /// Hardware in the loop: the firmware (QEMU or a board) closes the loop, lock-step.
    Hil(host_sim::hil::HilArgs),
    /// Topside console: arm, disarm, mode, reference; telemetry to CSV with a status line.
    Link(host_sim::link::LinkArgs),
    /// The surface side: MAVLink 2 to QGroundControl / MAVProxy / pymavlink, the tether to the vehicle (`--sim SCENARIO`: simulated, with the firmware library in process)
    Topside(host_sim::topside::TopsideArgs),
    /// Draw the figures of a run from a recorded dive (.tlog)
    Replay(host_sim::replay::ReplayArgs),
    /// The topside layout against the onboard one (issue 25): tracking, latency, delay
    /// margin, a cut and byte corruption of the node link
    Deployment(host_sim::deployment::DeploymentArgs),
}

fn print_table(rows: &[&RunOutput]) {
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

/// Exit code of the main job: 1 when a built-in differs from its file.
fn all_code(as_expected: bool) -> ExitCode {
    if as_expected {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_NOT_AS_EXPECTED)
    }
}

fn run_one(sc: &Scenario, dir: &Path) -> Result<RunOutput> {
    let out = run(
        sc,
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )?;
    write_run(dir, &out)?;
    Ok(out)
}

/// Every built-in scenario; `Ok(false)` when one's result differs from what its file
/// expects.
fn run_all(out_dir: &Path) -> Result<bool> {
    // Every built-in, plus the tracking law on the paper's saturated scenarios for the
    // side-by-side figures.
    let mut jobs: Vec<(String, Result<Scenario>)> = BUILT_IN
        .iter()
        .map(|b| (b.name.to_string(), Scenario::load(b.name)))
        .collect();
    for p in ["xz", "xy"] {
        let name = format!("paper-{p}-saturated");
        let sc = Scenario::load(&name).map(|mut s| {
            s.controller = ControllerKind::Tracking;
            s.name = format!("{name}-tracking");
            // The file's targets are the paper law's; issue 3's for the tracking law on the
            // paper's scenarios with the limits: final <= 1 cm, max <= 5 cm after 10 s.
            s.expect = Some(ExpectSpec {
                final_m: Some(0.01),
                max_m: Some(0.05),
                ..ExpectSpec::default()
            });
            s
        });
        jobs.push((format!("{name}-tracking"), sc));
    }
    let results: Vec<(String, Result<RunOutput>)> = jobs
        .into_par_iter()
        .map(|(name, sc)| {
            let r = sc.and_then(|sc| run_one(&sc, &out_dir.join(&sc.name)));
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

/// Exit code of a run: 1 when it diverged, went non-finite or missed its targets.
fn run_code(o: &RunOutput) -> ExitCode {
    let s = &o.summary;
    if s.diverged || s.nan_detected || s.targets.as_ref().is_some_and(|t| !t.met) {
        ExitCode::from(EXIT_NOT_AS_EXPECTED)
    } else {
        ExitCode::SUCCESS
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(if is_refused(&e) {
                EXIT_REFUSED
            } else {
                EXIT_FAILED
            })
        }
    }
}

/// Run the command; `Ok` carries the exit code of a command that ran to its end.
fn dispatch(cli: Cli) -> Result<ExitCode> {
    let done = |r: Result<()>| r.map(|()| ExitCode::SUCCESS);
    match cli.command {
        Some(Command::Hil(a)) => host_sim::hil::main(a).map(|o| run_code(&o.run)),
        Some(Command::Link(a)) => done(host_sim::link::main(a)),
        Some(Command::Topside(a)) => done(host_sim::topside::main(a)),
        Some(Command::Replay(a)) => done(host_sim::replay::main(a)),
        Some(Command::Deployment(a)) => host_sim::deployment::main(a).map(|met| {
            if met {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(EXIT_NOT_AS_EXPECTED)
            }
        }),
        Some(Command::CurrentSweep { out }) => {
            let cells = host_sim::current_sweep::sweep()?;
            host_sim::current_sweep::write(&out, &cells)?;
            println!("wrote {}", out.display());
            Ok(ExitCode::SUCCESS)
        }
        None => run_all(Path::new("out")).map(all_code),
        Some(Command::All { out }) => run_all(&out).map(all_code),
        Some(Command::Merge { dirs, out }) => {
            let (summary, runs) = merge_shards(&dirs)?;
            write_batch(&out, &summary, &runs)?;
            println!("{}", serde_json::to_string_pretty(&summary)?);
            println!("merged {} shard folders into {}", dirs.len(), out.display());
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::List) => {
            for b in BUILT_IN {
                match Scenario::load(b.name) {
                    Ok(s) => println!(
                        "{:<22} {:<3} {:<9} {:>7.0} s  {}",
                        b.name,
                        s.plane.as_str(),
                        s.controller.as_str(),
                        s.duration_s,
                        s.description
                    ),
                    Err(e) => println!("{:<22} (invalid: {e:#})", b.name),
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::Run {
            scenario,
            controller,
            out,
        }) => {
            let mut sc = Scenario::load(&scenario).map_err(refused)?;
            if let Some(c) = controller {
                let kind = ControllerKind::parse(&c).map_err(refused)?;
                if kind != sc.controller {
                    sc.controller = kind;
                    sc.name = format!("{}-{}", sc.name, kind.as_str());
                    // The file's targets are for its own law.
                    sc.expect = None;
                }
                sc.validate().map_err(refused)?;
            }
            let dir = out.unwrap_or_else(|| PathBuf::from("out").join(&sc.name));
            let o = run_one(&sc, &dir)?;
            print_table(&[&o]);
            println!("outputs in {}", dir.display());
            Ok(run_code(&o))
        }
        Some(Command::MonteCarlo {
            scenario,
            runs,
            seed,
            perturb,
            shard,
            out,
        }) => {
            let shard = shard
                .as_deref()
                .map(parse_shard)
                .transpose()
                .map_err(refused)?;
            check_campaign(runs, shard.unwrap_or((0, 1))).map_err(refused)?;
            if !(0.0..1.0).contains(&perturb) {
                return Err(refused(anyhow!(
                    "--perturb must be in [0, 1) (got {perturb})"
                )));
            }
            let sc = Scenario::load(&scenario).map_err(refused)?;
            let cfg = McConfig {
                runs,
                seed,
                perturb,
                progress: true,
            };
            let (summary, rs) = run_batch(&sc, &cfg, shard.unwrap_or((0, 1)))?;
            let dir = out.unwrap_or_else(|| {
                let suffix = shard.map_or(String::new(), |(i, n)| format!("-shard-{i}-of-{n}"));
                PathBuf::from("out").join(format!("monte-carlo-{}{suffix}", sc.name))
            });
            write_batch(&dir, &summary, &rs)?;
            println!("{}", serde_json::to_string_pretty(&summary)?);
            println!("outputs in {}", dir.display());
            Ok(ExitCode::SUCCESS)
        }
    }
}
