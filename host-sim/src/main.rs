//! `host-sim`: run scenarios, list them, Monte Carlo.
//!
//! ```text
//! host-sim                                   # every built-in scenario -> out/<scenario>/
//! host-sim all [--out DIR]                   # the same, into DIR
//! host-sim run <name-or-path.toml> [--controller paper|tracking] [--out DIR]
//! host-sim list
//! host-sim monte-carlo <scenario> --runs N [--seed S] [--perturb FRACTION] [--out DIR]
//! host-sim hil <scenario> [--qemu ELF | --serial DEVICE --baud N | --tcp HOST:PORT]
//! host-sim vehicle <scenario> --listen tcp:HOST:PORT [--speedup N] [--duration S] [--out DIR]
//! ```
//! Each command lives in its own file under `host_sim::commands` (`commands/<name>.rs`, its
//! arguments as a `clap::Args` struct); a new one is one more variant in [`Command`] and one
//! more arm in `dispatch`.
//!
//! Exit codes (the README's table): 0 as expected; 1 a run that diverged, went non-finite,
//! lost control or missed its `[expect]` targets, or (the main job) a built-in whose result
//! differs from its file; 2 an input refused before any work; 3 work that could not complete.

use anyhow::Result;
use clap::{Parser, Subcommand};
use host_sim::checks::is_refused;
use host_sim::commands::{self, run_code, EXIT_FAILED, EXIT_REFUSED};
use std::path::Path;
use std::process::ExitCode;

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
    All(commands::all::AllArgs),
    /// Run one scenario: a built-in name or a path to a .toml file.
    Run(commands::run::RunArgs),
    /// List the built-in scenarios.
    List,
    /// Many runs of one scenario with perturbed plant parameters and random current direction.
    MonteCarlo(commands::monte_carlo::McArgs),
    /// Join the folders of `monte-carlo --shard` runs into the campaign's summary, table and
    /// histogram (the same bytes as one run of the whole campaign).
    Merge(commands::merge::MergeArgs),
    /// Currents from every direction: the built-in paths in 0.1-0.3 m/s from 12 directions,
    /// the RMS tracking error as heat maps (the measurement).
    CurrentSweep(commands::current_sweep::CurrentSweepArgs),
    /// Hardware in the loop: the firmware (QEMU or a board) closes the loop, lock-step.
    Hil(commands::hil::HilArgs),
    /// Serve a simulated vehicle's tether on a TCP port, in real time (SITL): for `rov-topside
    /// --tcp HOST:PORT`
    Vehicle(commands::vehicle::VehicleArgs),
    /// Draw the figures of a run from a recorded dive (.tlog)
    Replay(commands::replay::ReplayArgs),
    /// Fit a vehicle's model from a run's timeseries.csv and write its vehicle file
    Identify(commands::identify::IdentifyArgs),
    /// The topside layout against the onboard one: tracking, latency, delay
    /// margin, a cut and byte corruption of the node link
    Deployment(commands::deployment::DeploymentArgs),
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
        None => commands::all::main(Path::new("out")),
        Some(Command::All(a)) => commands::all::main_with(&a),
        Some(Command::Run(a)) => commands::run::main(a),
        Some(Command::List) => {
            commands::list::main();
            Ok(ExitCode::SUCCESS)
        }
        Some(Command::MonteCarlo(a)) => done(commands::monte_carlo::main(a)),
        Some(Command::Merge(a)) => done(commands::merge::main(a)),
        Some(Command::CurrentSweep(a)) => done(commands::current_sweep::main(a)),
        Some(Command::Hil(a)) => commands::hil::main(a).map(|o| run_code(&o.run)),
        Some(Command::Vehicle(a)) => commands::vehicle::main(a),
        Some(Command::Replay(a)) => done(commands::replay::main(a)),
        Some(Command::Identify(a)) => done(commands::identify::main(a)),
        Some(Command::Deployment(a)) => commands::deployment::main(a).map(|met| {
            if met {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(commands::EXIT_NOT_AS_EXPECTED)
            }
        }),
    }
}
