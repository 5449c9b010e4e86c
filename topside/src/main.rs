//! `rov-topside`: the program at the surface.
//!
//! ```text
//! rov-topside --serial /dev/ttyUSB0[:BAUD] [--mavlink udpout:127.0.0.1:14550] ...   # a real vehicle
//! rov-topside --tcp 127.0.0.1:5760 ...                                             # a simulated one (host-sim vehicle)
//! rov-topside console --serial DEV | --tcp HOST:PORT [--script "arm; mode hold; ..."]
//! ```
//!
//! Exit status: 0 stopped at `--duration` or by the user, 2 an argument or file refused, 3
//! the work could not be done (a port that does not open, a vehicle that never answers).

use clap::{Parser, Subcommand};
use std::process::ExitCode;
use topside::{console, surface, EXIT_FAILED, EXIT_REFUSED};

#[derive(Parser, Debug)]
#[command(
    name = "rov-topside",
    version,
    about = "The ROV's surface program: MAVLink 2 to ground stations, the tether to the vehicle",
    args_conflicts_with_subcommands = true
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
    #[command(flatten)]
    surface: surface::TopsideArgs,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// A line console on the tether: arm, disarm, modes, references; telemetry to CSV.
    Console(console::ConsoleArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { EXIT_REFUSED } else { 0 });
        }
    };
    let result = match cli.command {
        Some(Command::Console(a)) => console::main(a),
        // Without --serial or --tcp: refused, saying so.
        None => surface::main(cli.surface),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(if topside::refusal::is_refused(&e) {
                EXIT_REFUSED
            } else {
                EXIT_FAILED
            })
        }
    }
}
