//! The vehicle's state machine: arming, modes, failsafes and the control step, with no I/O.
//!
//! [`Autopilot::handle`] applies one command (validated first; on a refusal nothing changes)
//! and [`Autopilot::step`] computes the thruster commands at time `now_us`. Time is passed
//! in, so the same code runs on the board's clock (fixed-rate) or on the host's time
//! (lock-step), and the tests drive it exactly.
//!
//! Failsafes (the table in `docs/firmware.md`), evaluated at every step:
//!
//! | condition | action |
//! | --- | --- |
//! | disarmed, or mode `Idle` | neutral pulses |
//! | no heartbeat for `heartbeat_neutral_us` (0.5 s) | neutral, `HEARTBEAT_LOST` |
//! | no heartbeat for `heartbeat_disarm_us` (1 s) | disarm, `LINK_DISARMED` until re-armed |
//! | tracking / hold and `NavState` older than `nav_stale_us` (0.2 s) | neutral, `NAV_STALE` |
//! | manual, stabilize or depth hold and `ManualThrust` older than `manual_stale_us` (0.5 s) | neutral, `MANUAL_STALE` |
//! | stabilize or depth hold and no fresh navigation | neutral, `NAV_STALE` |
//! | on-board estimator: IMU or pressure quiet past its timeout (0.1 s / 0.5 s) | `SENSOR_LOST`; neutral when tracking / holding |
//!
//! Navigation has two sources: the surface's `Nav` (external, as in hardware in the loop on
//! the truth), or the on-board estimator ([`OnboardNav`], started by `StartNav`) fed by the
//! vehicle's IMU and pressure sensor and by the fixes that come down the tether.

mod arming;
mod guided;
mod health;
mod ident;
mod ident_flight;
mod mission;
mod motor_test;
mod onboard;
mod output;
mod swing;

/// Largest stick deflection that counts as centred (fraction of full scale), when arming in a
/// stick mode (ArduSub refuses to arm with the throttle off neutral, `AP_Arming_Sub`) and for
/// the stick gate.
pub const STICK_CENTRED: f32 = 0.05;

pub use ident_flight::{IdentAbort, IdentFlight, IdentOutcome, IDENT_DURATION_S};

use crate::compass_swing::{SwingFlight, SwingOutcome};
use crate::health::HealthMonitor;
pub use crate::protocol::Failsafe;
use crate::protocol::{fault, Command, ManualThrust, Mode, MotorTest, NackReason, NavSample};
use controller_core::alloc::Allocation;
use controller_core::controller::{ControlMode, Controller};
use controller_core::law::pilot::Sticks;
use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::OnboardNav;
use controller_core::params::VehicleParams;
use controller_core::reference::mission::{MissionPath, MAX_WAYPOINTS};
use controller_core::reference::{Bounds, Reference};
use controller_core::state::{BodyForces, NavState, TrackingErrors};

/// The number the vehicle's own readings are handled under (`App::read_sensors`,
/// `App::read_dvl`): never a tether command's.
pub const OWN_READING: u16 = 0;

/// The mission limits are wire facts the surface checks too: one list, in the protocol crate.
pub use protocol::limits::{MAX_MISSION_DEPTH_M, MAX_MISSION_RANGE_M, MAX_MISSION_SPEED_M_S};
/// Radius of the turns that join a mission's legs (m).
pub const MISSION_TURN_RADIUS_M: f32 = 1.5;

/// Waypoints in the local NED frame and the speed to fly them.
#[derive(Debug, Clone, Default)]
struct Mission {
    waypoints: heapless::Vec<[f32; 3], MAX_WAYPOINTS>,
    speed_m_s: f32,
}

/// A motor test in force (`motor_test.rs`): the request, its end and the mode it started in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct MotorTestRun {
    test: MotorTest,
    until_us: u64,
    mode: Mode,
}

/// Where the SURFACE mode is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
enum SurfacePhase {
    /// Going up.
    #[default]
    Ascent,
    /// At the top, holding the depth it arrived at (`SURFACE_END` hold).
    Holding,
}

/// Largest magnitudes accepted in a `NavState` (anything beyond is a broken estimator).
pub mod nav_limits {
    /// Position, metres from the origin.
    pub const POSITION_M: f32 = 1.0e5;
    /// Angle (yaw may be unwrapped), radians.
    pub const ANGLE_RAD: f32 = 1.0e3;
    /// Linear speed, m/s.
    pub const SPEED_M_S: f32 = 20.0;
    /// Angular rate, rad/s.
    pub const RATE_RAD_S: f32 = 50.0;
}

/// Check a navigation state: every field finite and within [`nav_limits`].
pub fn check_nav(s: &NavState) -> Result<(), NackReason> {
    use nav_limits::*;
    let groups = [
        ([s.x_m, s.y_m, s.z_m], POSITION_M),
        ([s.roll_rad, s.pitch_rad, s.yaw_rad], ANGLE_RAD),
        ([s.u_m_s, s.v_m_s, s.w_m_s], SPEED_M_S),
        ([s.p_rad_s, s.q_rad_s, s.r_rad_s], RATE_RAD_S),
    ];
    if !s.is_finite() {
        Err(NackReason::NonFinite)
    } else if groups
        .iter()
        .any(|(v, lim)| v.iter().any(|x| x.abs() > *lim))
    {
        Err(NackReason::OutOfRange)
    } else {
        Ok(())
    }
}

/// Seconds from `start_us` to `now_us` (0 before the start).
fn seconds_since(now_us: u64, start_us: u64) -> f32 {
    now_us.saturating_sub(start_us) as f32 * 1e-6
}

/// What one step commands.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StepOutput {
    /// Forces asked for (law or manual); zero when neutral.
    pub requested: BodyForces,
    /// Thrusts `[F1x, F2x, F3z]` (within the limits) and the forces they make.
    pub allocation: Allocation,
    /// Pulse widths for the three ESCs, microseconds.
    pub pulse_us: [f32; 3],
    /// Tracking errors (zero when no law ran).
    pub errors: TrackingErrors,
    /// Fault flags of this step ([`fault`]).
    pub faults: u16,
    /// True when a control law ran.
    pub law_ran: bool,
}

/// The latest navigation state and when it arrived.
#[derive(Debug, Clone, Copy, PartialEq)]
struct NavRx {
    rx_us: u64,
    seq: u16,
    sample: NavSample,
}

/// Arming, modes, references, failsafes and the controller.
#[derive(Debug, Clone)]
pub struct Autopilot {
    controller: Controller,
    failsafe: Failsafe,
    armed: bool,
    mode: Mode,
    reference: Option<(Reference, u64)>,
    hold: Option<(Reference, u64)>,
    last_heartbeat_us: Option<u64>,
    nav: Option<NavRx>,
    manual: Option<(u64, ManualThrust)>,
    sticky: u16,
    last_step_us: Option<u64>,
    onboard: Option<OnboardNav>,
    /// Sequence number of the latest command that fed or stepped the on-board estimator.
    onboard_seq: u16,
    /// Thrust commanded by the latest step `[F1x, F2x, F3z]` (N): the estimator's input.
    thrust_cmd_n: [f32; 3],
    /// The latest sound DVL velocity the on-board estimator was given, as measured.
    last_dvl: crate::protocol::DvlReport,
    /// The mission in use (waypoints, speed), the one being uploaded, and the path AUTO flies
    /// with its start time.
    mission: Mission,
    upload: Mission,
    auto: Option<(MissionPath, u64)>,
    /// Time of the latest arming or change of mode: no reference's `t = 0` is earlier, so
    /// nothing set before it is resumed part-way.
    engaged_us: u64,
    /// A new surface session began: the next `Nav` is not ordered after the previous
    /// session's (a restarted topside's clock starts again).
    nav_order_reset: bool,
    /// The compass's deviation (`COMPASS_DEV_*`, `SetCompassCal`), handed to every
    /// on-board estimator started.
    compass_cal: CompassCalibration,
    /// A compass calibration turn in flight (in `Hold`).
    swing: Option<SwingFlight>,
    /// How the latest calibration turn ended, or that one is flying.
    swing_outcome: SwingOutcome,
    /// An identification manoeuvre in flight (in `Hold`), and how the latest one ended.
    ident: Option<IdentFlight>,
    ident_outcome: IdentOutcome,
    /// The pilot's sticks were seen at centre since the latest arming, change of mode or
    /// restart: until then they count as centred.
    sticks_seen_centred: bool,
    /// The health checks (battery, leak, enclosure, depth limit).
    health: HealthMonitor,
    /// Where the SURFACE mode is.
    surface: SurfacePhase,
    /// The motor test in force (`MotorTest`), if any.
    motor_test: Option<MotorTestRun>,
    /// Control steps run.
    pub steps: u32,
}

impl Autopilot {
    /// Boots disarmed, `Idle`, no reference.
    pub fn new(controller: Controller, failsafe: Failsafe) -> Self {
        Self {
            controller,
            failsafe,
            armed: false,
            mode: Mode::Idle,
            reference: None,
            hold: None,
            last_heartbeat_us: None,
            nav: None,
            manual: None,
            sticky: 0,
            last_step_us: None,
            onboard: None,
            onboard_seq: 0,
            thrust_cmd_n: [0.0; 3],
            last_dvl: crate::protocol::DvlReport {
                t_us: 0,
                velocity_m_s: [0.0; 2],
            },
            mission: Mission::default(),
            upload: Mission::default(),
            auto: None,
            engaged_us: 0,
            nav_order_reset: false,
            compass_cal: CompassCalibration::NONE,
            swing: None,
            swing_outcome: SwingOutcome::None,
            ident: None,
            ident_outcome: IdentOutcome::None,
            sticks_seen_centred: false,
            health: HealthMonitor::with_defaults(),
            surface: SurfacePhase::Ascent,
            motor_test: None,
            steps: 0,
        }
    }

    /// Armed?
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The controller (gains, limits, PWM map).
    pub fn controller(&self) -> &Controller {
        &self.controller
    }

    /// Failsafe timeouts.
    pub fn failsafe(&self) -> &Failsafe {
        &self.failsafe
    }

    /// Sequence number and time stamp of the latest accepted `NavState` (with the on-board
    /// estimator: of the latest command that fed or stepped it, and the estimator's time).
    pub fn latest_nav(&self) -> Option<(u16, u64)> {
        match &self.onboard {
            Some(o) => Some((self.onboard_seq, o.estimator().time_us())),
            None => self.nav.map(|n| (n.seq, n.sample.t_us)),
        }
    }

    /// The on-board estimator, when it runs.
    pub fn onboard_nav(&self) -> Option<&OnboardNav> {
        self.onboard.as_ref()
    }

    /// The latest navigation state, fresh or not (zeros before the first).
    pub fn nav_state(&self) -> NavState {
        match &self.onboard {
            Some(o) => o.estimator().state(),
            None => self.nav.map(|n| n.sample.state).unwrap_or_default(),
        }
    }

    /// Sticky fault flags (cleared by arming).
    pub fn sticky_faults(&self) -> u16 {
        self.sticky
    }

    fn age(now_us: u64, then: Option<u64>) -> u64 {
        then.map_or(u64::MAX, |t| now_us.saturating_sub(t))
    }

    fn nav_fresh(&self, now_us: u64) -> bool {
        match &self.onboard {
            Some(o) => o.sensors_fresh(now_us),
            None => Self::age(now_us, self.nav.map(|n| n.rx_us)) <= self.failsafe.nav_stale_us,
        }
    }

    /// A new surface's session began (the App's handshake; a surface restarted, or another
    /// one): its `Nav` time stamps start a new order, a motor test ends, and the pilot's
    /// input of the session before no longer acts: thrust in a stick mode waits for the new
    /// session's sticks, seen at centre first (the stick gate, as after an arming).
    pub fn new_session(&mut self) {
        self.session_renewed();
        self.manual = None;
        self.sticks_seen_centred = false;
    }

    /// The surface in force renewed its session (its numbers near their end): its `Nav` time
    /// stamps start a new order and a motor test ends; its pilot's input keeps acting.
    pub fn session_renewed(&mut self) {
        self.nav_order_reset = true;
        self.motor_test = None;
    }

    /// Apply one command received at `now_us` with sequence number `seq`. On `Err` nothing
    /// changed.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn handle(&mut self, now_us: u64, seq: u16, cmd: &Command) -> Result<(), NackReason> {
        self.apply(now_us, seq, cmd)?;
        self.after_command(cmd);
        Ok(())
    }

    fn apply(&mut self, now_us: u64, seq: u16, cmd: &Command) -> Result<(), NackReason> {
        match cmd {
            Command::Heartbeat { .. } => {
                self.last_heartbeat_us = Some(now_us);
                Ok(())
            }
            Command::Arm => {
                if Self::age(now_us, self.last_heartbeat_us) >= self.failsafe.heartbeat_neutral_us {
                    return Err(NackReason::NoHeartbeat);
                }
                if !self.nav_fresh(now_us) {
                    return Err(NackReason::NavStale);
                }
                if self.armed {
                    return Ok(());
                }
                self.check_health_for_arming()?;
                self.arm(now_us)
            }
            Command::Disarm => {
                self.disarm();
                Ok(())
            }
            Command::SetMode(mode) => self.set_mode(now_us, *mode),
            Command::SetReference {
                reference,
                start_us,
            } => {
                reference
                    .check_bounds(&Bounds::VEHICLE)
                    .map_err(NackReason::from)?;
                self.check_reference_depth(reference)?;
                self.reference = Some((*reference, start_us.unwrap_or(now_us)));
                Ok(())
            }
            Command::SetPaperGains { xz, xy } => {
                let mut g = *self.controller.gains();
                g.paper_xz = *xz;
                g.paper_xy = *xy;
                self.controller.set_gains(g).map_err(NackReason::from)
            }
            Command::SetTrackingGains(t) => {
                let mut g = *self.controller.gains();
                g.tracking = *t;
                self.controller.set_gains(g).map_err(NackReason::from)
            }
            Command::StartNav { .. }
            | Command::Imu(_)
            | Command::Pressure { .. }
            | Command::UsblFix(_)
            | Command::DvlFix(_)
            | Command::Compass(_)
            | Command::SetCompassCal(_) => Err(NackReason::Unsupported),
            // The App's (sessions are a link matter).
            Command::OpenSession { .. } => Err(NackReason::Unsupported),
            Command::StopNav => {
                self.onboard = None;
                self.abort_swing();
                self.abort_ident(IdentAbort::ModeChange);
                Ok(())
            }
            Command::StartCompassCal {
                yaw_rate_rad_s,
                time_limit_s,
            } => self.start_swing(now_us, *yaw_rate_rad_s, *time_limit_s),
            Command::StartIdent {
                radius_m,
                depth_band_m,
            } => self.start_ident(now_us, *radius_m, *depth_band_m),
            Command::GuidedTarget { pos_m } => self.guided_target(now_us, *pos_m),
            Command::MissionItem {
                index,
                count,
                pos_m,
                speed_m_s,
            } => self.mission_item(*index, *count, *pos_m, *speed_m_s),
            Command::MissionClear => {
                if self.mode == Mode::Auto {
                    return Err(NackReason::Unsupported);
                }
                self.mission = Mission::default();
                self.upload = Mission::default();
                Ok(())
            }
            Command::Step { .. } => {
                if self.onboard.is_some() {
                    self.onboard_seq = seq;
                }
                Ok(())
            }
            Command::Nav(sample) => {
                if self.onboard.is_some() {
                    return Err(NackReason::NavSource);
                }
                check_nav(&sample.state)?;
                let ordered = !self.nav_order_reset;
                if ordered && self.nav.is_some_and(|prev| sample.t_us < prev.sample.t_us) {
                    return Err(NackReason::OutOfRange);
                }
                self.nav_order_reset = false;
                self.nav = Some(NavRx {
                    rx_us: now_us,
                    seq,
                    sample: *sample,
                });
                Ok(())
            }
            Command::MotorTest(test) => self.start_motor_test(now_us, test),
            Command::SetVehicle(params) => self.set_vehicle(params),
            Command::SetHealth(params) => self.set_health(params),
            Command::SetFailsafe(f) => {
                // Timeouts are not changed mid-dive (relaxing one would weaken a failsafe
                // that is protecting the vehicle now).
                if self.armed {
                    return Err(NackReason::Armed);
                }
                f.validate()?;
                self.failsafe = *f;
                Ok(())
            }
            Command::ManualThrust(m) => {
                if !m.is_valid() {
                    return Err(if [m.surge, m.yaw, m.heave].iter().all(|v| v.is_finite()) {
                        NackReason::OutOfRange
                    } else {
                        NackReason::NonFinite
                    });
                }
                self.ident_sticks(m);
                self.take_sticks(now_us, m);
                self.guided_sticks(now_us, m);
                Ok(())
            }
        }
    }

    /// A new vehicle description: only disarmed and without the on-board estimator (which
    /// runs on the old model). Out of line, so that its frame (a derived vehicle model) is
    /// not part of every command's.
    #[inline(never)]
    fn set_vehicle(&mut self, params: &VehicleParams) -> Result<(), NackReason> {
        if self.armed {
            return Err(NackReason::Armed);
        }
        if self.onboard.is_some() {
            return Err(NackReason::NavSource);
        }
        let vehicle = params.validate()?;
        vehicle.check_flyable()?;
        self.controller.set_vehicle(vehicle);
        Ok(())
    }

    /// Compute the thruster commands at `now_us`, applying every failsafe. No panic path,
    /// including the controller-core law and allocation it calls (link-time proof with the
    /// `no-panic` feature, docs/firmware.md).
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn step(&mut self, now_us: u64) -> StepOutput {
        let mut out = self.step_inner(now_us);
        out = self.limit_depth(out, now_us);
        out.faults |= self.health.latest().faults;
        self.thrust_cmd_n = out.allocation.thrust_n;
        out
    }

    fn step_inner(&mut self, now_us: u64) -> StepOutput {
        let fs = self.failsafe;
        let dt_s = match self.last_step_us {
            Some(t) => seconds_since(now_us, t).clamp(1e-4, 0.2),
            None => 0.02,
        };
        self.last_step_us = Some(now_us);
        self.steps = self.steps.wrapping_add(1);

        let hb_age = Self::age(now_us, self.last_heartbeat_us);
        let mut faults = 0u16;
        if self.armed && hb_age >= fs.heartbeat_disarm_us {
            self.disarm();
            self.sticky |= fault::LINK_DISARMED;
        }
        if hb_age >= fs.heartbeat_neutral_us {
            faults |= fault::HEARTBEAT_LOST;
        }
        faults |= self.sticky;
        let nav_fresh = self.nav_fresh(now_us);
        if self.onboard.is_some() && !nav_fresh {
            faults |= fault::SENSOR_LOST;
        }
        if !self.armed || faults & fault::HEARTBEAT_LOST != 0 {
            self.motor_test = None;
            return self.neutral(faults);
        }
        if let Some(out) = self.motor_test_step(now_us, faults) {
            return out;
        }
        // A calibration turn (in `Hold`): its surge and yaw, the depth held by the law on the
        // hold point; when it ends, the hold point is where it started.
        let swing_forces = if self.swing.is_some() && self.mode == Mode::Hold && nav_fresh {
            let nav = self.nav_state();
            self.swing_step(now_us, &nav, dt_s)
        } else {
            None
        };
        // The identification manoeuvre (in `Hold`): its forces; the law holds the depth
        // where it gives no heave.
        let ident_forces = self.ident_step(now_us, nav_fresh, faults, dt_s);
        let (sample, cm) = match (self.mode, &self.reference, &self.hold) {
            (Mode::Idle, ..) => return self.neutral(faults),
            (Mode::Surface, ..) => return self.surface_step(nav_fresh, dt_s, faults),
            (Mode::Manual | Mode::Stabilize | Mode::DepthHold, ..) => {
                let m = match self.manual {
                    Some((t, m)) if now_us.saturating_sub(t) < fs.manual_stale_us => {
                        self.sticks_may_act(m)
                    }
                    _ => return self.neutral(faults | fault::MANUAL_STALE),
                };
                if self.mode == Mode::Manual {
                    return self.manual_output(&m, faults);
                }
                if !nav_fresh {
                    return self.neutral(faults | fault::NAV_STALE);
                }
                let nav = self.nav_state();
                let sticks = Sticks {
                    surge: m.surge,
                    yaw: m.yaw,
                    heave: m.heave,
                };
                let hold_depth = self.mode == Mode::DepthHold;
                let law = self.controller.pilot_step(&nav, &sticks, hold_depth, dt_s);
                return self.law_output(&law, faults);
            }
            (Mode::Track { plane, law }, Some((r, start)), _) => match law.in_plane(plane) {
                // Never from before the arming or the mode's entry.
                Some(cm) => (
                    r.sample(seconds_since(now_us, (*start).max(self.engaged_us))),
                    cm,
                ),
                None => return self.neutral(faults),
            },
            (Mode::Hold | Mode::Guided, _, Some((r, start))) => (
                r.sample(seconds_since(now_us, *start)),
                ControlMode::Tracking3d,
            ),
            (Mode::Auto, ..) => match &self.auto {
                Some((path, start)) => (
                    path.sample(seconds_since(now_us, *start)),
                    ControlMode::Tracking3d,
                ),
                None => return self.neutral(faults),
            },
            _ => return self.neutral(faults),
        };
        if !nav_fresh {
            return self.neutral(faults | fault::NAV_STALE);
        }
        let nav = self.nav_state();
        let law = self.controller.step(cm, &nav, &sample, dt_s);
        if let Some((surge_n, yaw_n_m, heave_n)) = ident_forces {
            let requested = BodyForces {
                surge_n,
                yaw_n_m,
                heave_n: heave_n.unwrap_or(law.requested.heave_n),
            };
            return self.forces_output(requested, law.errors, faults);
        }
        if let Some([surge_n, yaw_n_m]) = swing_forces {
            let requested = BodyForces {
                surge_n,
                yaw_n_m,
                heave_n: law.requested.heave_n,
            };
            return self.forces_output(requested, law.errors, faults);
        }
        self.law_output(&law, faults)
    }
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_dvl;
#[cfg(test)]
mod tests_guided;
#[cfg(test)]
mod tests_health;
#[cfg(test)]
mod tests_motor_test;
#[cfg(test)]
mod tests_sticks;
