//! The options of a hardware-in-the-loop run: where the firmware runs ([`HilTarget`]) and
//! how the lock-step exchange behaves ([`HilOptions`]), read by
//! [`crate::tether::endpoint::TetherEndpoint`] and `host-sim hil`.

use crate::tether::link::{Endpoint, NoiseSpec};
use std::path::PathBuf;
use std::time::Duration;

/// Where the firmware runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HilTarget {
    /// Start QEMU `netduinoplus2` with this ELF (the firmware's `qemu` image).
    Qemu {
        /// The ELF.
        elf: PathBuf,
    },
    /// A board (or an already running emulator) at an endpoint; it must run the lock-step
    /// firmware.
    Board(Endpoint),
    /// The firmware library's `App` in this process, behind an in-memory serial port: the
    /// same frames and the same code as on the board, without an emulator.
    InProcess,
}

/// The longest wait for one reply in a lock-step exchange ([`HilOptions::reply_timeout`]).
pub const MAX_REPLY_WAIT: Duration = Duration::from_secs(1);

/// Default of [`HilOptions::nav_ready_limit_s`]: a launch point known to a few metres is
/// ready after the first USBL fixes, well within this.
pub const DEFAULT_NAV_READY_LIMIT_S: f64 = 120.0;

/// Options of a HIL run.
#[derive(Debug, Clone)]
pub struct HilOptions {
    /// Where the firmware runs.
    pub target: HilTarget,
    /// Stop sending heartbeats from this simulated time on (link-loss test).
    pub heartbeat_stop_s: Option<f64>,
    /// Noise injected on the link (from arming on; the set-up is on a clean link).
    pub noise: Option<NoiseSpec>,
    /// Run this long instead of the scenario's duration.
    pub duration_s: Option<f64>,
    /// Wall-clock time to wait for a reply before sending again; each resend of the same
    /// step waits twice as long as the one before, up to [`MAX_REPLY_WAIT`] (an emulator
    /// starved for a moment by a loaded machine is not a lost link, and a resend storm only
    /// deepens the backlog).
    pub reply_timeout: Duration,
    /// Sends of one `NavState` before the run is declared lost.
    pub max_tries: u32,
    /// Apply the thrust of the reported pulse widths (true, what the ESCs see) or the
    /// reported thrust commands (false).
    pub apply_pulses: bool,
    /// The QEMU binary.
    pub qemu: String,
    /// On QEMU: count instructions (`-icount`), so that the report's control iteration is
    /// in instructions; otherwise the board runs on the host's clock, faster
    /// ([`crate::tether::qemu::QemuClock`]).
    pub count_instructions: bool,
    /// Wall-clock limit of the whole run.
    pub wall_limit: Duration,
    /// Keep the per-step log (CSV, plots).
    pub record: bool,
    /// With `--qemu`: save the emulated SRAM here at the end of the run (stack high-water).
    pub ram_dump: Option<PathBuf>,
    /// Keep a telemetry row per step (`telemetry.csv`, the failsafe checks); a long run that
    /// needs none (the identification's flights) keeps none.
    pub telemetry_rows: bool,
    /// With the estimator on board and a mode that needs a position (`Track`, `Hold`,
    /// AUTO): the longest simulated time to wait, armed and neutral, for the vehicle's
    /// estimate to be ready (an unknown start) before the run fails (s).
    pub nav_ready_limit_s: f64,
    /// In process and on the emulated board: the DVL's fixes reach the firmware as the DVL's
    /// serial reports on its DVL port (true), or as `DvlFix` commands over the tether (false).
    pub dvl_on_uart: bool,
    /// Write the raw tether log (`rov-topside`'s format) here.
    pub tether_log: Option<PathBuf>,
}

impl HilOptions {
    /// Defaults for a target.
    pub fn new(target: HilTarget) -> Self {
        Self {
            target,
            heartbeat_stop_s: None,
            noise: None,
            duration_s: None,
            reply_timeout: Duration::from_millis(100),
            max_tries: 20,
            apply_pulses: true,
            qemu: "qemu-system-arm".into(),
            count_instructions: false,
            wall_limit: Duration::from_secs(600),
            record: true,
            ram_dump: None,
            telemetry_rows: true,
            nav_ready_limit_s: DEFAULT_NAV_READY_LIMIT_S,
            dvl_on_uart: true,
            tether_log: None,
        }
    }
}
