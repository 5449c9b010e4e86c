//! What a run with the firmware at the other end of the tether reports: the firmware's
//! telemetry per step, the link's statistics and failsafe timings, the run's output.

use crate::closed_loop::RunOutput;
use crate::tether::link::HostLinkStats;
use firmware::protocol::Telemetry;
use serde::Serialize;

/// What the firmware reported in one step: its [`Telemetry`] (read through: `row.armed`,
/// `row.pulse_us`, ...), stamped with the simulated time, the thrust the plant got and the
/// firmware's link counters.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct TelemetryRow {
    /// Simulated time of the step (s).
    pub t_s: f64,
    /// The step's telemetry as the firmware sent it.
    pub telemetry: Telemetry,
    /// Thrust applied to the plant (N).
    pub applied_n: [f64; 3],
    /// Frames the firmware accepted so far.
    pub fw_rx_frames: u32,
    /// Frames the firmware dropped so far.
    pub fw_dropped: u32,
}

impl std::ops::Deref for TelemetryRow {
    type Target = Telemetry;

    fn deref(&self) -> &Telemetry {
        &self.telemetry
    }
}

/// Link and timing figures of a HIL run (the `hil` object of `summary.json`).
#[derive(Debug, Clone, Default, Serialize)]
pub struct HilReport {
    /// `qemu` or the endpoint.
    pub target: String,
    /// Board named in `Hello`.
    pub board: String,
    /// Host-side counters.
    pub host: HostLinkStats,
    /// Frames the firmware accepted.
    pub firmware_rx_frames: u32,
    /// Frames the firmware dropped (all reasons).
    pub firmware_dropped_frames: u32,
    /// Frames the firmware sent.
    pub firmware_tx_frames: u32,
    /// Nacks the firmware sent.
    pub firmware_nacks: u32,
    /// Lock-step exchanges done.
    pub steps: u64,
    /// Steps whose `NavState` had to be sent more than once.
    pub steps_resent: u64,
    /// Mean control iteration on the board (instructions under `-icount shift=0`).
    pub loop_ticks_mean: f64,
    /// Largest control iteration on the board.
    pub loop_ticks_max: u32,
    /// Steps in which the firmware was not armed (after arming).
    pub steps_disarmed: u64,
    /// Steps in which the firmware reported a link or navigation failsafe.
    pub steps_failsafe: u64,
    /// Heartbeats stopped at this simulated time (s).
    pub heartbeat_stop_s: Option<f64>,
    /// First time after the stop at which all outputs were neutral with the heartbeat
    /// failsafe flagged, minus the stop (s).
    pub neutral_after_s: Option<f64>,
    /// First time after the stop at which the firmware was disarmed, minus the stop (s).
    pub disarmed_after_s: Option<f64>,
    /// The firmware ran the estimator on board (the scenario's `source = "estimator"`): the
    /// host sent it sensor readings and fixes, not states.
    pub onboard_estimator: bool,
    /// Measurements the firmware's estimator refused (answered by a `Nack`).
    pub measurements_refused: u64,
    /// The on-board estimator's counters at the end of the run.
    pub nav_health: Option<controller_core::nav::NavHealth>,
    /// When the scenario's mode needed a position and the firmware estimates: the simulated
    /// time at which the vehicle took the mode (its estimate ready); until then it was armed
    /// and neutral (s).
    pub mode_set_at_s: Option<f64>,
    /// With `[calibration]`: how the compass calibration turn ended (the firmware's
    /// `Status`), and the simulated time it ended (s).
    pub compass_swing: Option<firmware::compass_swing::SwingOutcome>,
    /// See [`Self::compass_swing`].
    pub calibration_end_s: Option<f64>,
    /// The compass calibration in force on the vehicle at the end of the run.
    pub compass_cal: Option<controller_core::nav::compass_cal::CompassCalibration>,
    /// The identification manoeuvre as the firmware's `Status` reported it at the end of
    /// the run (`None` flown since boot, flown to its end, stopped and why).
    pub ident: Option<firmware::protocol::IdentOutcome>,
}

/// The result of a HIL run.
#[derive(Debug, Clone, Default)]
pub struct HilOutput {
    /// Same as `host-sim run`.
    pub run: RunOutput,
    /// Link statistics and failsafe timings.
    pub report: HilReport,
    /// The firmware's telemetry, one row per step.
    pub telemetry: Vec<TelemetryRow>,
}
