//! The tether's messages: what the topside sends ([`Command`]) and what the ROV answers
//! ([`Reply`]), with the types they carry. Serialized by postcard (varints, `f32` as four
//! little-endian bytes, enums by variant index) inside an [`Envelope`](crate::Envelope).
//! `docs/protocol.md` has the table.

use crate::decoder::DropCounters;
use crate::health::{BatteryStatus, HealthParams};
pub use crate::nack::NackReason;
use controller_core::controller::ControlMode;
use controller_core::law::paper_xy::PaperXyGains;
use controller_core::law::paper_xz::PaperXzGains;
use controller_core::law::tracking::TrackingGains;
use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration};
use controller_core::nav::onboard::OnboardConfig;
use controller_core::nav::{DvlFix, HeadingFix, ImuSample, NavHealth, PositionFix};
use controller_core::params::VehicleParams;
use controller_core::reference::Reference;
use controller_core::state::{BodyForces, NavState, TrackingErrors};
use serde::{Deserialize, Serialize};

/// Plane of a tracking mode.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Plane {
    /// Vertical plane (surge and heave; x and depth).
    Xz,
    /// Horizontal plane (surge and yaw; x and y).
    Xy,
    /// 3-D: horizontal plane plus depth.
    ThreeD,
}

/// Which control law tracks.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Law {
    /// The paper's backstepping laws (XZ and XY only).
    Paper,
    /// The tracking laws.
    Tracking,
}

/// Operating mode of the vehicle.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Mode {
    /// No thrust (neutral pulses), armed or not.
    #[default]
    Idle,
    /// Open-loop thrust from [`Command::ManualThrust`].
    Manual,
    /// Follow the reference set by [`Command::SetReference`].
    Track {
        /// Plane.
        plane: Plane,
        /// Law.
        law: Law,
    },
    /// Hold the position of the latest `NavState` when the mode was entered
    /// (3-D tracking law on a fixed point).
    Hold,
    /// The pilot's `ManualThrust` with the heading held while the yaw stick is centred
    /// (ArduSub's STABILIZE; version 4).
    Stabilize,
    /// [`Mode::Stabilize`] with the depth held while the heave stick is centred (ArduSub's
    /// ALT_HOLD; version 4).
    DepthHold,
    /// Fly the uploaded mission from where the vehicle is, with the 3-D tracking law, and hold
    /// the last waypoint (ArduSub's AUTO; version 4).
    Auto,
    /// Go up (ArduSub's SURFACE; version 7): horizontal thrusters neutral, the vertical
    /// thruster up until the vehicle is within 0.3 m of the surface, then hold that depth
    /// or disarm (`SURFACE_END`). The battery and leak failsafes switch to it.
    Surface,
    /// Go to a point and hold it (ArduSub's GUIDED; version 8): the 3-D tracking law holds
    /// where the vehicle was when the mode was entered (or the vehicle armed) until a
    /// [`Command::GuidedTarget`] arrives, then flies to that point and holds it. A stick off
    /// centre stops the go-to where the vehicle is.
    Guided,
}

/// The one map between the tether's tracking modes and the core's laws: a law in a plane is
/// the core's [`ControlMode`], or `None` for the paper law in 3-D (the paper has none).
impl Law {
    /// The core's law this law flies in `plane`.
    pub const fn in_plane(self, plane: Plane) -> Option<ControlMode> {
        match (self, plane) {
            (Law::Paper, Plane::Xz) => Some(ControlMode::PaperXz),
            (Law::Paper, Plane::Xy) => Some(ControlMode::PaperXy),
            (Law::Paper, Plane::ThreeD) => None,
            (Law::Tracking, Plane::Xz) => Some(ControlMode::TrackingXz),
            (Law::Tracking, Plane::Xy) => Some(ControlMode::TrackingXy),
            (Law::Tracking, Plane::ThreeD) => Some(ControlMode::Tracking3d),
        }
    }
}

/// The tracking mode that flies a core law (the inverse of [`Law::in_plane`]).
impl From<ControlMode> for Mode {
    fn from(m: ControlMode) -> Self {
        let (plane, law) = match m {
            ControlMode::PaperXz => (Plane::Xz, Law::Paper),
            ControlMode::PaperXy => (Plane::Xy, Law::Paper),
            ControlMode::TrackingXz => (Plane::Xz, Law::Tracking),
            ControlMode::TrackingXy => (Plane::Xy, Law::Tracking),
            ControlMode::Tracking3d => (Plane::ThreeD, Law::Tracking),
        };
        Mode::Track { plane, law }
    }
}

/// A time-stamped navigation state (the state estimate sent by the topside or the plant).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct NavSample {
    /// Time of the estimate on the sender's clock, microseconds. In lock-step mode this is
    /// the firmware's clock.
    pub t_us: u64,
    /// The state.
    pub state: NavState,
}

/// Open-loop thrust, each component normalized to `[-1, 1]` of what the vehicle can make.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ManualThrust {
    /// Surge force, fraction of the largest surge force.
    pub surge: f32,
    /// Yaw moment, fraction of the largest yaw moment.
    pub yaw: f32,
    /// Heave force, fraction of the largest heave force (positive down).
    pub heave: f32,
}

impl ManualThrust {
    /// True when every component is finite and within `[-1, 1]`.
    pub fn is_valid(&self) -> bool {
        [self.surge, self.yaw, self.heave]
            .iter()
            .all(|v| v.is_finite() && (-1.0..=1.0).contains(v))
    }
}

/// Topside -> ROV messages.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Command {
    /// Keep-alive. `t_us` is the sender's clock (used as the firmware's clock in lock-step).
    Heartbeat {
        /// Sender's time, microseconds.
        t_us: u64,
    },
    /// Arm the thrusters (needs a fresh heartbeat and a fresh `NavState`).
    Arm,
    /// Disarm: neutral pulses at once.
    Disarm,
    /// Change the mode (resets the laws' integrators).
    SetMode(Mode),
    /// Set the reference to track.
    SetReference {
        /// The reference (validated by the core).
        reference: Reference,
        /// Firmware time at which the reference's `t = 0` is, microseconds; `None` = now.
        start_us: Option<u64>,
    },
    /// Replace both paper laws' gains (validated with the rest of the set; unchanged on
    /// error). Version 2: the gains travel as two messages, so that the largest `Command`
    /// (what every move of a decoded command copies) is 80 bytes, not 144.
    SetPaperGains {
        /// Paper XZ law.
        xz: PaperXzGains,
        /// Paper XY law.
        xy: PaperXyGains,
    },
    /// A navigation state. In lock-step mode it runs one control step and is answered by
    /// `Telemetry`.
    Nav(NavSample),
    /// Open-loop thrust for `Mode::Manual`.
    ManualThrust(ManualThrust),
    /// Replace the tracking laws' gains (validated with the rest of the set; unchanged on
    /// error).
    SetTrackingGains(TrackingGains),
    /// Start (or restart) the on-board estimator at the launch point `initial`, sensor time
    /// `t_us`: from then on the laws fly on its estimate, and a `Nav` is refused (version 4).
    StartNav {
        /// Sensor time of `initial`, microseconds.
        t_us: u64,
        /// The launch point and attitude, as the surface knows them.
        initial: NavState,
        /// The filters' noise, pressure to depth, the sensor timeouts (validated).
        config: OnboardConfig,
    },
    /// Stop the on-board estimator: the surface's `Nav` is the source again.
    StopNav,
    /// An IMU sample. Emulated board only: a real board reads its own IMU.
    Imu(ImuSample),
    /// A pressure reading. Emulated board only: a real board reads its own sensor.
    Pressure {
        /// Time of the reading, microseconds.
        t_us: u64,
        /// Absolute pressure, pascals.
        pressure_pa: f32,
    },
    /// An acoustic (USBL) position fix, with its time of validity and accuracy.
    UsblFix(PositionFix),
    /// A DVL velocity over the bottom, with its time of validity and accuracy.
    DvlFix(DvlFix),
    /// A heading from a compass at the surface's end (when the vehicle's is not used).
    Compass(HeadingFix),
    /// Waypoint `index` (from 0) of a mission of `count` (at most 32), local NED frame; the
    /// mission in use is replaced when the last one arrives (version 4); refused while AUTO
    /// flies a mission (`Unsupported`).
    MissionItem {
        /// This waypoint's place in the mission.
        index: u16,
        /// Waypoints in the mission.
        count: u16,
        /// `[north, east, down]` (m), depth 0..100 m, within 1 km of the origin.
        pos_m: [f32; 3],
        /// Speed along the path (m/s, at most 1); the last item's is used.
        speed_m_s: f32,
    },
    /// Forget the mission (refused while AUTO flies it).
    MissionClear,
    /// Lock-step with the on-board estimator: run one control step at `t_us` on the latest
    /// estimate; answered by `Telemetry` (what `Nav` does with an external source).
    Step {
        /// Host time, microseconds.
        t_us: u64,
    },
    /// Replace the vehicle's description (version 5): validated, then checked flyable
    /// (`Vehicle::check_flyable`); refused while armed or while the on-board estimator runs
    /// on the old one. Tracking gains derived from the old description follow the new one
    /// (`Controller::set_vehicle`); gains set by an operator stay.
    SetVehicle(VehicleParams),
    /// Replace the failsafe timeouts (version 5, [`Failsafe::validate`]); refused while
    /// armed (version 6: a failsafe is not relaxed mid-dive).
    SetFailsafe(Failsafe),
    /// Open a surface session (version 6): the only command taken outside a session. The
    /// vehicle answers `Reply::Session` with `nonce` and the session's number, which every
    /// later frame carries in its envelope; within the session, sequence numbers must rise
    /// (a frame not newer than the last one taken is refused `Replayed`). Opening a session
    /// ends the previous one (a restarted topside is welcome at once; the old one's frames
    /// are refused `NoSession`).
    OpenSession {
        /// The surface's random number, echoed in the answer.
        nonce: u32,
    },
    /// Replace the compass calibration (the ground station's `COMPASS_DEV_SIN` /
    /// `COMPASS_DEV_COS`, or a calibration turn's result): the deviation the on-board
    /// estimator takes off every heading. Refused while armed (`Armed`) and when not finite
    /// or beyond 30 degrees (`CompassCal`); the calibration in force then stays.
    SetCompassCal(CompassCalibration),
    /// Fly the compass calibration turn (the ground station's
    /// `MAV_CMD_DO_START_MAG_CAL`): armed in `Hold` with the on-board estimate ready, a full
    /// circle in place at `yaw_rate_rad_s` (0.05-0.6 rad/s, either sign), refused as
    /// `NotFullTurn` if not done within `time_limit_s` (at most 600 s). The outcome is in
    /// [`Status::compass_swing`]; an accepted fit is the calibration in force.
    StartCompassCal {
        /// Yaw rate of the turn (rad/s).
        yaw_rate_rad_s: f32,
        /// Time limit of the turn (s).
        time_limit_s: f32,
    },
    /// Replace the health parameters (version 7, [`HealthParams::validate`]): battery scales
    /// and thresholds, the leak and enclosure limits, the depth limit, the end of SURFACE.
    /// Refused while armed (`Armed`), except a depth limit made shallower or switched on,
    /// which is taken at any time; the parameters in force then stay.
    SetHealth(HealthParams),
    /// Fly the identification manoeuvre (docs/identification.md): armed in `Hold` with the
    /// on-board estimate ready, force steps on every axis for under three minutes, stopped
    /// by a stick, a change of mode, a failsafe or the vehicle leaving its room:
    /// `radius_m` around the start (3-100 m) and `depth_band_m` either side of the start
    /// depth (0.5-20 m, the start deeper than the band).
    StartIdent {
        /// Radius of the room around the start point (m).
        radius_m: f32,
        /// Half-height of the depth band around the start depth (m).
        depth_band_m: f32,
    },
    /// The point GUIDED goes to and holds (version 8): `[north, east, down]` (m), local NED
    /// frame, checked as a mission's waypoint ([`limits`](crate::limits)) and against the
    /// depth limit. Taken only armed (`NotArmed`) in [`Mode::Guided`] (`NotInGuided`): a
    /// target given before is never flown.
    GuidedTarget {
        /// `[north, east, down]` (m).
        pos_m: [f32; 3],
    },
    /// Spin one thruster at a set pulse for a short window (version 8,
    /// [`MotorTest`](crate::MotorTest)): armed only (`NotArmed`); ends at its window's end
    /// (then the vehicle disarms), on any other command, a lost heartbeat or a disarm.
    MotorTest(crate::motor_test::MotorTest),
}

/// What the vehicle sends back for a command it takes; a refused command is answered by
/// `Nack` whatever it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Response {
    /// `Reply::Ack` with the command's sequence number.
    Ack,
    /// `Reply::Status` naming the heartbeat (`Status::heartbeat_seq`).
    Status,
    /// `Reply::Session` with the command's nonce.
    Session,
    /// `Reply::Telemetry` in lock-step (`Telemetry::nav_seq`); nothing at a fixed rate.
    TelemetryInLockStep,
    /// Nothing: a high-rate input (the pilot's sticks, a sensor reading).
    Nothing,
}

impl Command {
    /// The navigation inputs: the commands the vehicle's on-board navigation takes (the
    /// estimator's start, its sensor readings and fixes, the compass calibration).
    pub const fn is_nav_input(&self) -> bool {
        matches!(
            self,
            Command::StartNav { .. }
                | Command::Imu(_)
                | Command::Pressure { .. }
                | Command::UsblFix(_)
                | Command::DvlFix(_)
                | Command::Compass(_)
                | Command::SetCompassCal(_)
        )
    }

    /// What the vehicle answers when it takes this command.
    pub const fn response(&self) -> Response {
        match self {
            Command::Heartbeat { .. } => Response::Status,
            Command::OpenSession { .. } => Response::Session,
            Command::Nav(_) | Command::Step { .. } => Response::TelemetryInLockStep,
            Command::ManualThrust(_) | Command::Imu(_) | Command::Pressure { .. } => {
                Response::Nothing
            }
            _ => Response::Ack,
        }
    }
}

/// Failsafe timeouts, microseconds of the firmware's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Failsafe {
    /// Heartbeat age at which thrust goes neutral.
    pub heartbeat_neutral_us: u64,
    /// Heartbeat age at which the vehicle disarms.
    pub heartbeat_disarm_us: u64,
    /// `NavState` age at which tracking stops (neutral) and arming is refused.
    pub nav_stale_us: u64,
    /// `ManualThrust` age at which manual thrust goes neutral.
    pub manual_stale_us: u64,
}

impl Failsafe {
    /// The specified timeouts: 0.5 s, 1 s, 0.2 s, 0.5 s.
    pub const DEFAULT: Self = Self {
        heartbeat_neutral_us: 500_000,
        heartbeat_disarm_us: 1_000_000,
        nav_stale_us: 200_000,
        manual_stale_us: 500_000,
    };

    /// Shortest timeout accepted: two control periods of the 50 Hz loop (a shorter one trips
    /// on one late frame).
    pub const MIN_US: u64 = 40_000;
    /// Longest heartbeat-to-neutral and pilot-input timeout: 2 s of thrust on a lost link.
    pub const MAX_NEUTRAL_US: u64 = 2_000_000;
    /// Longest heartbeat-to-disarm timeout.
    pub const MAX_DISARM_US: u64 = 10_000_000;
    /// Longest navigation age flown on: 1 s of dead reckoning by the laws.
    pub const MAX_NAV_STALE_US: u64 = 1_000_000;

    /// Every timeout from [`Self::MIN_US`] to its maximum, and neutral before disarm.
    pub fn validate(&self) -> Result<(), NackReason> {
        let within = |v: u64, max: u64| (Self::MIN_US..=max).contains(&v);
        if within(self.heartbeat_neutral_us, Self::MAX_NEUTRAL_US)
            && within(self.heartbeat_disarm_us, Self::MAX_DISARM_US)
            && within(self.nav_stale_us, Self::MAX_NAV_STALE_US)
            && within(self.manual_stale_us, Self::MAX_NEUTRAL_US)
            && self.heartbeat_neutral_us <= self.heartbeat_disarm_us
        {
            Ok(())
        } else {
            Err(NackReason::OutOfRange)
        }
    }
}

impl Default for Failsafe {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Fault flags in [`Telemetry::faults`] (a bit set).
pub mod fault {
    /// No heartbeat for the neutral timeout: thrust is neutral.
    pub const HEARTBEAT_LOST: u16 = 1 << 0;
    /// No heartbeat for the disarm timeout: the vehicle disarmed itself (sticky until armed).
    pub const LINK_DISARMED: u16 = 1 << 1;
    /// `NavState` too old while tracking or holding: thrust is neutral.
    pub const NAV_STALE: u16 = 1 << 2;
    /// Manual command too old: thrust is neutral.
    pub const MANUAL_STALE: u16 = 1 << 3;
    /// A PWM output reported an error.
    pub const PWM_ERROR: u16 = 1 << 4;
    /// The serial port reported an error.
    pub const SERIAL_ERROR: u16 = 1 << 5;
    /// The allocation saturated at least one thruster in the latest step.
    pub const SATURATED: u16 = 1 << 6;
    /// A control period was missed (fixed-rate mode).
    pub const OVERRUN: u16 = 1 << 7;
    /// The on-board IMU or pressure sensor stopped answering (or answers only refused
    /// values): thrust is neutral in the modes that need navigation.
    pub const SENSOR_LOST: u16 = 1 << 8;
    /// The battery is low (under `BATT_LOW_VOLT` for `BATT_LOW_TIMER`, or less than
    /// `BATT_LOW_MAH` left); latched until reboot. Its action is `BATT_FS_LOW_ACT`.
    pub const BATTERY_LOW: u16 = 1 << 9;
    /// The battery is critical (`BATT_CRT_VOLT`, `BATT_CRT_MAH`); latched until reboot. Its
    /// action is `BATT_FS_CRT_ACT`.
    pub const BATTERY_CRITICAL: u16 = 1 << 10;
    /// A leak probe reads wet (debounced). Its action is `FS_LEAK_ENABLE`.
    pub const LEAK: u16 = 1 << 11;
    /// The enclosure's pressure (`FS_PRESS_MAX`) or temperature (`FS_TEMP_MAX`) is over its
    /// limit: a warning.
    pub const ENCLOSURE: u16 = 1 << 12;
    /// The vehicle is at or below 90 % of the depth limit (`DEPTH_LIMIT_M`): a warning; the
    /// vertical command is capped there.
    pub const DEPTH_LIMIT: u16 = 1 << 13;
    /// The paper's layout (a topside MCU and a node on the vehicle): no valid uplink from the
    /// node for 3 link periods; the estimator predicts only, and from 250 ms neutral is
    /// commanded.
    pub const NODE_LINK_LOST: u16 = 1 << 15;
    /// The paper's layout: the topside is armed but the node is not (latched after a loss of
    /// the link, or its command outlived its time to live): disarm and arm again.
    pub const NODE_NOT_ARMED: u16 = 1 << 14;
}

/// Link statistics, as counted by the firmware.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct LinkStats {
    /// Frames accepted (CRC and decoding good).
    pub rx_frames: u32,
    /// Frames dropped, by reason.
    pub dropped: DropCounters,
    /// Frames queued for sending.
    pub tx_frames: u32,
    /// Nacks sent.
    pub nacks: u32,
    /// Frames not sent because the transmit queue was full (the port is slower than the
    /// replies; version 4).
    pub tx_dropped: u32,
    /// Good frames refused because they were not of the session in force (version 6).
    pub no_session: u32,
    /// Good frames of the session refused as replays: sequence number not newer than the
    /// last one taken (version 6).
    pub replayed: u32,
}

/// What the ROV reports every control step (lock-step: the answer to each `NavState`) or
/// at the telemetry rate (fixed-rate mode). Version 3 keeps here what changes every step;
/// the link counters and other slow figures are in [`Status`], the answer to each
/// heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Telemetry {
    /// Firmware time, microseconds.
    pub t_us: u64,
    /// Mode.
    pub mode: Mode,
    /// Armed.
    pub armed: bool,
    /// Sequence number of the latest `NavState` used (lock-step: the one this answers).
    pub nav_seq: u16,
    /// Tracking errors of the latest control step.
    pub errors: TrackingErrors,
    /// Generalized forces the law (or the manual command) asked for.
    pub requested: BodyForces,
    /// Generalized forces the commanded thrusts make.
    pub achieved: BodyForces,
    /// Thruster forces `[F1x, F2x, F3z]` commanded (zero when neutral).
    pub thrust_n: [f32; 3],
    /// Pulse widths actually written to the three PWM outputs, microseconds (read back from
    /// the duty cycles: what the ESCs see).
    pub pulse_us: [u16; 3],
    /// Fault flags ([`fault`]).
    pub faults: u16,
    /// Work of the latest loop iteration in clock ticks (microseconds on the STM32F4 board;
    /// instructions on the emulated board under `-icount shift=0`): everything since the
    /// previous control step (frames decoded and handled, sensor readings and fixes into the
    /// estimator, telemetry sent) and the step itself; idle polling is not counted.
    pub loop_ticks: u32,
    /// The navigation state the laws saw (the on-board estimate, or the latest `Nav`).
    pub nav: NavState,
    /// Standard deviation of the on-board position estimate `[x, y, z]` (m; zeros with an
    /// external source).
    pub nav_pos_std_m: [f32; 3],
    /// Waypoints of the mission the reference has passed, in AUTO (0 otherwise).
    pub mission_reached: u16,
    /// The latest sound DVL velocity the vehicle took, as measured (version 8).
    pub dvl: crate::measured::DvlReport,
}

/// The slow half of the report: link counters and health, sent as the answer to each
/// accepted `Heartbeat` (so the topside sets its rate, and each one proves a round trip).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Status {
    /// Firmware time, microseconds.
    pub t_us: u64,
    /// Sequence number of the heartbeat this answers.
    pub heartbeat_seq: u16,
    /// Time stamp of the latest accepted `NavState` (0 before the first).
    pub nav_t_us: u64,
    /// Link counters.
    pub link: LinkStats,
    /// Control steps run since boot.
    pub steps: u32,
    /// Largest `Telemetry::loop_ticks` since boot.
    pub loop_ticks_max: u32,
    /// Control periods missed (fixed-rate mode).
    pub overruns: u32,
    /// Largest delay of a control step after its due time, microseconds (fixed-rate mode:
    /// the loop's jitter).
    pub control_late_max_us: u32,
    /// Fault flags now ([`fault`]).
    pub faults: u16,
    /// The on-board estimator's counters (zeros when it does not run).
    pub nav_health: NavHealth,
    /// The compass calibration in force (`COMPASS_DEV_*`, radians).
    pub compass_cal: CompassCalibration,
    /// The latest compass calibration turn: flying, accepted or refused with the reason.
    pub compass_swing: SwingOutcome,
    /// The battery (version 7).
    pub battery: BatteryStatus,
    /// The latest identification manoeuvre: flying, flown to its end or stopped and why
    /// (version 9).
    pub ident: crate::ident::IdentOutcome,
}

/// How the latest compass calibration turn ended (or that one is flying), reported in
/// [`Status`].
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum SwingOutcome {
    /// None flown since boot.
    #[default]
    None,
    /// Turning now: the heading turned so far (rad).
    Turning {
        /// Heading turned (rad, the gyro's).
        turned_rad: f32,
    },
    /// Accepted: the calibration now in force and the fit's RMS residual (rad).
    Accepted {
        /// The fitted deviation, in force.
        cal: CompassCalibration,
        /// RMS residual of the fit (rad).
        residual_rad: f32,
    },
    /// Refused: why; the calibration in force did not change.
    Refused(CalRefusal),
    /// Stopped before its end (disarmed, a mode change, the estimator stopped); the
    /// calibration in force did not change.
    Aborted,
}

/// Which board sent a [`Reply::Hello`].
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Board {
    /// STM32F405 hardware.
    Stm32f4,
    /// QEMU `netduinoplus2`.
    QemuNetduinoPlus2,
    /// Host-side test double.
    Host,
}

/// ROV -> topside messages.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Reply {
    /// Sent once at boot: the host waits for it before sending (the emulated USART drops
    /// bytes that arrive before it is enabled).
    Hello {
        /// [`PROTOCOL_VERSION`](crate::PROTOCOL_VERSION) (also in the envelope).
        protocol: u8,
        /// Which board.
        board: Board,
        /// True when the control step runs on each `NavState` (lock-step).
        lockstep: bool,
        /// Control period (fixed-rate) in microseconds; 0 in lock-step.
        control_period_us: u32,
        /// PWM frequency, hertz.
        pwm_hz: u16,
    },
    /// Telemetry.
    Telemetry(Telemetry),
    /// A command was accepted.
    Ack {
        /// Sequence number of the command.
        seq: u16,
    },
    /// A command was refused; nothing changed.
    Nack {
        /// Sequence number of the command.
        seq: u16,
        /// Why.
        reason: NackReason,
    },
    /// The answer to a `Heartbeat` (version 3).
    Status(Status),
    /// The answer to `OpenSession` (version 6): the session in force from now.
    Session {
        /// The surface's `nonce`.
        nonce: u32,
        /// The session's number (never 0), for every later frame's envelope.
        session: u32,
    },
}
