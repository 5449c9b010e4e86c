//! One file per command of the command line (`host-sim <command>`); `main.rs` parses the
//! arguments and calls these.
//!
//! Exit codes (the README's table): 0 done and as expected; 1 a result that is not what was
//! expected (a target missed, a divergence, a built-in scenario that differs from its file);
//! 2 an input refused before any work started (clap's usage errors are 2 too); 3 work that
//! could not be completed (a file that could not be written, a link or board that failed).

use crate::closed_loop::runner::RunOutput;
use crate::tether::link::Endpoint;
use std::path::PathBuf;
use std::process::ExitCode;

pub mod all;
pub mod current_sweep;
pub mod deployment;
pub mod hil;
pub mod identify;
pub mod list;
pub mod merge;
pub mod monte_carlo;
pub mod replay;
pub mod run;
pub mod vehicle;

/// Exit code of an input refused before any work (see the module's table).
pub const EXIT_REFUSED: u8 = 2;
/// Exit code of a result that is not what was expected (see the module's table).
pub const EXIT_NOT_AS_EXPECTED: u8 = 1;
/// Exit code of work that could not complete (see the module's table).
pub const EXIT_FAILED: u8 = 3;

/// Exit code of a run: 1 when it diverged, went non-finite or missed its targets.
pub fn run_code(o: &RunOutput) -> ExitCode {
    let s = &o.summary;
    if s.diverged || s.nan_detected || s.targets.as_ref().is_some_and(|t| !t.met) {
        ExitCode::from(EXIT_NOT_AS_EXPECTED)
    } else {
        ExitCode::SUCCESS
    }
}

/// Where the firmware is, for the commands that talk to it (`hil`, `link`): a board on a
/// serial device or at HOST:PORT, or a firmware image in QEMU; at most one of them.
#[derive(Debug, clap::Args)]
pub struct FirmwareArgs {
    /// Run this firmware image in QEMU (`hil` without --serial/--tcp/--in-process: the
    /// workspace's `qemu` image, built if needed into `<target>/hil-firmware`).
    #[arg(long, value_name = "ELF", conflicts_with_all = ["serial", "tcp"])]
    pub qemu: Option<PathBuf>,
    /// A board on a serial device (`hil`: the lock-step firmware).
    #[arg(long, value_name = "DEVICE", conflicts_with = "tcp")]
    pub serial: Option<PathBuf>,
    /// Baud rate of `--serial`.
    #[arg(long, default_value_t = 115_200)]
    pub baud: u32,
    /// A board, bridge or emulator at HOST:PORT (`hil`: the lock-step firmware).
    #[arg(long, value_name = "HOST:PORT")]
    pub tcp: Option<String>,
}

impl FirmwareArgs {
    /// The board given by `--serial` or `--tcp`, if one was.
    pub fn board(&self) -> Option<Endpoint> {
        if let Some(device) = &self.serial {
            Some(Endpoint::Serial {
                device: device.clone(),
                baud: self.baud,
            })
        } else {
            self.tcp.clone().map(Endpoint::Tcp)
        }
    }
}
