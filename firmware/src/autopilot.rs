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

use crate::compass_swing::{SwingFlight, SwingOutcome};
pub use crate::protocol::Failsafe;
use crate::protocol::{fault, Command, ManualThrust, Mode, NackReason, NavSample};
use controller_core::alloc::{allocate, Allocation, ESC_NEUTRAL_US};
use controller_core::controller::{ControlMode, ControlOutput, Controller};
use controller_core::law::pilot::Sticks;
use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::OnboardNav;
use controller_core::nav::Refusal;
use controller_core::params::VehicleParams;
use controller_core::reference::mission::{MissionPath, MAX_WAYPOINTS};
use controller_core::reference::{Bounds, Reference};
use controller_core::state::{BodyForces, NavState, TrackingErrors};
use heapless::Vec;

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
    /// The mission in use (waypoints, speed), the one being uploaded, and the path AUTO flies
    /// with its start time.
    mission: Mission,
    upload: Mission,
    auto: Option<(MissionPath, u64)>,
    /// Time of the latest arming or change of mode: no reference's `t = 0` is earlier, so
    /// nothing set before it is resumed part-way (issue 22).
    engaged_us: u64,
    /// A new surface session began: the next `Nav` is not ordered after the previous
    /// session's (a restarted topside's clock starts again).
    nav_order_reset: bool,
    /// The compass's deviation (`COMPASS_DEV_*`, `SetCompassCal`), handed to every
    /// on-board estimator started (issue 26).
    compass_cal: CompassCalibration,
    /// A compass calibration turn in flight (in `Hold`; issue 26).
    swing: Option<SwingFlight>,
    /// How the latest calibration turn ended, or that one is flying.
    swing_outcome: SwingOutcome,
    /// Control steps run.
    pub steps: u32,
}

/// Waypoints in the local NED frame and the speed to fly them.
#[derive(Debug, Clone, Default)]
struct Mission {
    waypoints: Vec<[f32; 3], MAX_WAYPOINTS>,
    speed_m_s: f32,
}

/// Deepest waypoint accepted (m): the Observer's 150 m tether, with room for its catenary.
pub const MAX_MISSION_DEPTH_M: f32 = 100.0;
/// Farthest waypoint accepted from the origin, horizontally, each axis (m).
pub const MAX_MISSION_RANGE_M: f32 = 1_000.0;
/// Fastest mission speed accepted (m/s).
pub const MAX_MISSION_SPEED_M_S: f32 = 1.0;
/// Radius of the turns that join a mission's legs (m).
pub const MISSION_TURN_RADIUS_M: f32 = 1.5;
/// Largest stick deflection that counts as centred when arming in a stick mode (fraction of
/// full scale): ArduSub refuses to arm with the throttle off neutral (`AP_Arming_Sub`).
pub const STICK_CENTRED: f32 = 0.05;

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
            mission: Mission::default(),
            upload: Mission::default(),
            auto: None,
            engaged_us: 0,
            nav_order_reset: false,
            compass_cal: CompassCalibration::NONE,
            swing: None,
            swing_outcome: SwingOutcome::None,
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

    /// Apply `f` to the on-board estimator (refused without one), recording `seq`.
    fn feed(
        &mut self,
        seq: u16,
        f: impl FnOnce(&mut OnboardNav, [f32; 3]) -> Result<(), Refusal>,
    ) -> Result<(), NackReason> {
        let thrust = self.thrust_cmd_n;
        let o = self.onboard.as_mut().ok_or(NackReason::NavSource)?;
        f(o, thrust).map_err(NackReason::NavRefused)?;
        self.onboard_seq = seq;
        Ok(())
    }

    /// [`Self::feed`], then, during a calibration turn, the raw value to it: a gyro rate
    /// about `z` at `Some(t_us)`, or (`None`) a compass reading.
    #[inline(never)]
    fn feed_swing(
        &mut self,
        seq: u16,
        raw: f32,
        imu_t_us: Option<u64>,
        f: impl FnOnce(&mut OnboardNav, [f32; 3]) -> Result<(), Refusal>,
    ) -> Result<(), NackReason> {
        self.feed(seq, f)?;
        if let Some(flight) = self.swing.as_mut() {
            match imu_t_us {
                Some(t_us) => flight.imu(raw, t_us),
                None => flight.reading(raw),
            }
        }
        Ok(())
    }

    /// A new surface session began (the App's handshake): its `Nav` time stamps start a
    /// new order.
    pub fn new_session(&mut self) {
        self.nav_order_reset = true;
    }

    /// Disarm now (neutral from the next step). What was commanded before is forgotten: the
    /// pilot's input, the tracking reference, the hold point and AUTO's path (a re-arming
    /// starts clean; issue 22).
    pub fn disarm(&mut self) {
        self.armed = false;
        self.controller.reset();
        self.manual = None;
        self.reference = None;
        self.hold = None;
        self.auto = None;
        self.abort_swing();
    }

    /// Stop a calibration turn in flight (the calibration in force stays).
    fn abort_swing(&mut self) {
        if self.swing.take().is_some() {
            self.swing_outcome = SwingOutcome::Aborted;
        }
    }

    /// How the latest compass calibration turn ended, or that one is flying.
    pub fn swing_outcome(&self) -> SwingOutcome {
        self.swing_outcome
    }

    /// Start the compass calibration turn (`StartCompassCal`, the ground station's
    /// `MAV_CMD_DO_START_MAG_CAL`). Only armed (`NotArmed`), in `Hold` (`NotInHold`: not in
    /// AUTO, `Track` or the pilot modes), with the on-board estimator (`NavSource`), fresh
    /// (`NavStale`) and ready (`NavNotReady`), and a rate and limit in range (`OutOfRange`).
    /// A turn already flying starts again. On `Err` nothing changed.
    #[inline(never)]
    fn start_swing(
        &mut self,
        now_us: u64,
        yaw_rate_rad_s: f32,
        time_limit_s: f32,
    ) -> Result<(), NackReason> {
        if !self.armed {
            return Err(NackReason::NotArmed);
        }
        if self.mode != Mode::Hold {
            return Err(NackReason::NotInHold);
        }
        let o = self.onboard.as_ref().ok_or(NackReason::NavSource)?;
        if !self.nav_fresh(now_us) {
            return Err(NackReason::NavStale);
        }
        o.position_ready().map_err(NackReason::NavNotReady)?;
        let nav = self.nav_state();
        let flight =
            SwingFlight::new(&nav, yaw_rate_rad_s, time_limit_s).ok_or(NackReason::OutOfRange)?;
        self.swing = Some(flight);
        self.swing_outcome = SwingOutcome::Turning { turned_rad: 0.0 };
        Ok(())
    }

    /// One control step of the calibration turn: its sticks, or, when it is over, the fit
    /// applied (accepted: the calibration in force, as `SetCompassCal` would set it; refused:
    /// the old one stays) and `Hold` again at the point where the turn started.
    #[inline(never)]
    fn swing_step(&mut self, now_us: u64, nav: &NavState, dt_s: f32) -> Option<[f32; 2]> {
        let flight = self.swing.as_mut()?;
        let (forces, done) = flight.step(&self.controller.vehicle().xy, nav, dt_s);
        let Some(fit) = done else {
            self.swing_outcome = SwingOutcome::Turning {
                turned_rad: flight.turned_rad(),
            };
            return Some(forces);
        };
        let hold_m = flight.hold_m();
        self.swing = None;
        let applied = fit.and_then(|(cal, residual_rad)| {
            if let Some(o) = self.onboard.as_mut() {
                o.set_compass_calibration(&cal)?;
            }
            self.compass_cal = cal;
            Ok(SwingOutcome::Accepted { cal, residual_rad })
        });
        self.swing_outcome = applied.unwrap_or_else(SwingOutcome::Refused);
        self.controller.reset();
        self.hold = Some((Reference::Hold { pos_m: hold_m }, now_us));
        None
    }

    /// Arm (from disarmed): a clean start in the current mode. A stick mode refuses while
    /// the latest pilot input is fresh and off centre, then forgets it (thrust waits for
    /// input sent after the arming); a tracking mode needs a reference sent since the last
    /// disarm; HOLD holds where the vehicle is and AUTO flies its mission from here, both from
    /// now. Out of line (the mission path's temporaries).
    #[inline(never)]
    fn arm(&mut self, now_us: u64) -> Result<(), NackReason> {
        let stick_mode = matches!(self.mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold);
        if let Some((t, m)) = self.manual {
            let fresh = now_us.saturating_sub(t) < self.failsafe.manual_stale_us;
            let centred = [m.surge, m.yaw, m.heave]
                .iter()
                .all(|v| v.abs() <= STICK_CENTRED);
            if stick_mode && fresh && !centred {
                return Err(NackReason::SticksNotCentred);
            }
        }
        self.enter_mode(now_us, self.mode)?;
        self.manual = None;
        self.engaged_us = now_us;
        self.controller.reset();
        self.armed = true;
        self.sticky = 0;
        Ok(())
    }

    /// Apply one command received at `now_us` with sequence number `seq`. On `Err` nothing
    /// changed.
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn handle(&mut self, now_us: u64, seq: u16, cmd: &Command) -> Result<(), NackReason> {
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
                Ok(())
            }
            Command::StartCompassCal {
                yaw_rate_rad_s,
                time_limit_s,
            } => self.start_swing(now_us, *yaw_rate_rad_s, *time_limit_s),
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
            Command::SetVehicle(params) => self.set_vehicle(params),
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
                self.manual = Some((now_us, *m));
                Ok(())
            }
        }
    }

    /// Apply one of the on-board estimator's commands (`StartNav`, `Imu`, `Pressure`,
    /// `UsblFix`, `DvlFix`, `Compass`); on `Err` nothing changed. Kept out of [`handle`]
    /// (`Self::handle`) because the link-time no-panic proof does not hold through the
    /// estimator: the `heapless` history ring it keeps leaves indexing paths the compiler
    /// cannot remove. Its inputs are fuzzed instead (`tests/tests/fuzz.rs`). Out of line, so
    /// that the temporaries of a new estimator (`StartNav`) are not in every command's frame.
    #[inline(never)]
    pub fn handle_nav(&mut self, now_us: u64, seq: u16, cmd: &Command) -> Result<(), NackReason> {
        match cmd {
            Command::StartNav {
                t_us,
                initial,
                config,
            } => {
                check_nav(initial)?;
                let vehicle = *self.controller.vehicle();
                let mut o = OnboardNav::new(vehicle, *config, initial, *t_us, now_us)?;
                // Checked when it was set.
                o.set_compass_calibration(&self.compass_cal)
                    .map_err(NackReason::CompassCal)?;
                self.onboard = Some(o);
                self.onboard_seq = seq;
                Ok(())
            }
            Command::Imu(s) => {
                let [_, _, raw_r] = s.gyro_rad_s;
                self.feed_swing(seq, raw_r, Some(s.t_us), |o, thrust| {
                    o.imu(now_us, s, thrust)
                })
            }
            Command::Pressure { t_us, pressure_pa } => {
                self.feed(seq, |o, _| o.pressure(now_us, *t_us, *pressure_pa))
            }
            Command::UsblFix(f) => self.feed(seq, |o, _| o.position(f)),
            Command::DvlFix(f) => self.feed(seq, |o, _| o.dvl(f)),
            // The raw reading to a turn (the estimator takes the calibration off its copy).
            Command::Compass(f) => self.feed_swing(seq, f.yaw_rad, None, |o, _| o.heading(f)),
            Command::SetCompassCal(cal) => self.set_compass_calibration(cal),
            _ => self.handle(now_us, seq, cmd),
        }
    }

    /// A new compass calibration (`COMPASS_DEV_*`): only disarmed (a new deviation turns
    /// the heading the laws fly on), checked (finite, within 30 degrees); used by the
    /// running on-board estimator at once and by every one started later. On a refusal the
    /// calibration in force stays.
    pub fn set_compass_calibration(&mut self, cal: &CompassCalibration) -> Result<(), NackReason> {
        if self.armed {
            return Err(NackReason::Armed);
        }
        let cal = cal.validate().map_err(NackReason::CompassCal)?;
        if let Some(o) = self.onboard.as_mut() {
            o.set_compass_calibration(&cal)
                .map_err(NackReason::CompassCal)?;
        }
        self.compass_cal = cal;
        Ok(())
    }

    /// The compass calibration in force.
    pub fn compass_calibration(&self) -> CompassCalibration {
        self.compass_cal
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

    /// Take waypoint `index` of a mission of `count`; the mission in use changes only when
    /// the last one arrives, and a refused item leaves it as it was.
    fn mission_item(
        &mut self,
        index: u16,
        count: u16,
        pos_m: [f32; 3],
        speed_m_s: f32,
    ) -> Result<(), NackReason> {
        // AUTO flies the mission it entered with; a new one while it flies would be
        // acknowledged and not flown (issue 22): refused, as `MissionClear` is.
        if self.mode == Mode::Auto {
            return Err(NackReason::Unsupported);
        }
        let [x, y, z] = pos_m;
        if !(x.is_finite() && y.is_finite() && z.is_finite() && speed_m_s.is_finite()) {
            return Err(NackReason::NonFinite);
        }
        let far = x.abs() > MAX_MISSION_RANGE_M || y.abs() > MAX_MISSION_RANGE_M;
        let too_many = usize::from(count) > MAX_WAYPOINTS || count == 0 || index >= count;
        let speed_ok = speed_m_s > 0.0 && speed_m_s <= MAX_MISSION_SPEED_M_S;
        if far || too_many || !(0.0..=MAX_MISSION_DEPTH_M).contains(&z) || !speed_ok {
            return Err(NackReason::OutOfRange);
        }
        if index == 0 {
            self.upload = Mission::default();
        }
        if usize::from(index) != self.upload.waypoints.len() {
            return Err(NackReason::OutOfRange);
        }
        self.upload
            .waypoints
            .push(pos_m)
            .map_err(|_| NackReason::OutOfRange)?;
        self.upload.speed_m_s = speed_m_s;
        if index + 1 == count {
            self.mission = core::mem::take(&mut self.upload);
        }
        Ok(())
    }

    /// Waypoints of the mission AUTO flies that the reference has passed (0 outside AUTO).
    pub fn mission_reached(&self, now_us: u64) -> u16 {
        match (&self.auto, self.mode) {
            (Some((path, start)), Mode::Auto) => {
                u16::try_from(path.reached(seconds_since(now_us, *start))).unwrap_or(u16::MAX)
            }
            _ => 0,
        }
    }

    /// Waypoints in the mission in use.
    pub fn mission_len(&self) -> usize {
        self.mission.waypoints.len()
    }

    /// Out of line, so that the temporaries of a new mission path (AUTO) are not in every
    /// command's frame (docs/hil-and-mcu-cost.md: where the stack went).
    #[inline(never)]
    fn set_mode(&mut self, now_us: u64, mode: Mode) -> Result<(), NackReason> {
        let changed = mode != self.mode;
        self.enter_mode(now_us, mode)?;
        self.abort_swing();
        if changed {
            self.controller.reset();
            self.engaged_us = now_us;
        }
        self.mode = mode;
        if matches!(mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold) {
            // A manual command from before the mode change must not start the thrusters.
            self.manual = None;
        }
        Ok(())
    }

    /// Check that `mode` can be flown now and set up what it flies from `now_us` (HOLD's
    /// point, AUTO's path); on `Err` nothing changed.
    fn enter_mode(&mut self, now_us: u64, mode: Mode) -> Result<(), NackReason> {
        let needs_nav = !matches!(mode, Mode::Idle | Mode::Manual | Mode::Track { .. });
        if needs_nav && !self.nav_fresh(now_us) {
            return Err(NackReason::NavStale);
        }
        // A position mode waits for the on-board estimate to be ready (issue 26).
        if let (Mode::Auto | Mode::Hold | Mode::Track { .. }, Some(o)) = (mode, &self.onboard) {
            o.position_ready().map_err(NackReason::NavNotReady)?;
        }
        let s = self.nav_state();
        let here_m = [s.x_m, s.y_m, s.z_m];
        match mode {
            Mode::Auto => {
                if self.mission.waypoints.is_empty() {
                    return Err(NackReason::NoReference);
                }
                let m = &self.mission;
                let path =
                    MissionPath::new(here_m, &m.waypoints, m.speed_m_s, MISSION_TURN_RADIUS_M)?;
                self.auto = Some((path, now_us));
            }
            Mode::Track { plane, law } => {
                law.in_plane(plane).ok_or(NackReason::Unsupported)?;
                if self.reference.is_none() {
                    return Err(NackReason::NoReference);
                }
            }
            Mode::Hold => self.hold = Some((Reference::Hold { pos_m: here_m }, now_us)),
            Mode::Idle | Mode::Manual | Mode::Stabilize | Mode::DepthHold => {}
        }
        Ok(())
    }

    /// Neutral output with the given faults.
    pub fn neutral(&self, faults: u16) -> StepOutput {
        StepOutput {
            pulse_us: [ESC_NEUTRAL_US; 3],
            faults,
            ..StepOutput::default()
        }
    }

    /// Compute the thruster commands at `now_us`, applying every failsafe. No panic path,
    /// including the controller-core law and allocation it calls (link-time proof with the
    /// `no-panic` feature, docs/firmware.md).
    #[cfg_attr(feature = "no-panic", no_panic::no_panic)]
    pub fn step(&mut self, now_us: u64) -> StepOutput {
        let out = self.step_inner(now_us);
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
            return self.neutral(faults);
        }
        // A calibration turn (in `Hold`): its surge and yaw, the depth held by the law on the
        // hold point; when it ends, the hold point is where it started.
        let swing_forces = if self.swing.is_some() && self.mode == Mode::Hold && nav_fresh {
            let nav = self.nav_state();
            self.swing_step(now_us, &nav, dt_s)
        } else {
            None
        };
        let (sample, cm) = match (self.mode, &self.reference, &self.hold) {
            (Mode::Idle, ..) => return self.neutral(faults),
            (Mode::Manual | Mode::Stabilize | Mode::DepthHold, ..) => {
                let m = match self.manual {
                    Some((t, m)) if now_us.saturating_sub(t) < fs.manual_stale_us => m,
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
            (Mode::Hold, _, Some((r, start))) => (
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

    fn law_output(&self, law: &ControlOutput, faults: u16) -> StepOutput {
        let sat = if law.allocation.saturated {
            fault::SATURATED
        } else {
            0
        };
        StepOutput {
            requested: law.requested,
            allocation: law.allocation,
            pulse_us: law.pulse_us,
            errors: law.errors,
            faults: faults | sat,
            law_ran: true,
        }
    }

    /// Forces asked for outside the controller's laws (the pilot's `Manual` thrust, the
    /// calibration turn): allocated and mapped to pulses, in one place for both.
    #[inline(never)]
    fn forces_output(
        &self,
        requested: BodyForces,
        errors: TrackingErrors,
        faults: u16,
    ) -> StepOutput {
        let allocation = allocate(&requested, self.controller.limits());
        let out = ControlOutput {
            requested,
            allocation,
            pulse_us: allocation
                .thrust_n
                .map(|f| self.controller.pwm_map().pulse_us(f)),
            errors,
        };
        self.law_output(&out, faults)
    }

    fn manual_output(&self, m: &ManualThrust, faults: u16) -> StepOutput {
        let lim = self.controller.limits();
        // The largest force each way (the thrusters are asymmetric, so it depends on the sign).
        let one_way = |x: f32| {
            if x >= 0.0 {
                lim.max_forward_n
            } else {
                lim.max_reverse_n
            }
        };
        let requested = BodyForces {
            surge_n: m.surge * 2.0 * one_way(m.surge),
            yaw_n_m: m.yaw * lim.lever_arm_m * (lim.max_forward_n + lim.max_reverse_n),
            heave_n: m.heave * one_way(m.heave),
        };
        StepOutput {
            law_ran: false,
            ..self.forces_output(requested, TrackingErrors::default(), faults)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sets one field of a state.
    type Setter = fn(&mut NavState, f32);

    /// Every field of a state, each with its limit and its setter.
    fn fields() -> [(f32, Setter); 12] {
        use nav_limits::*;
        [
            (POSITION_M, |s, v| s.x_m = v),
            (POSITION_M, |s, v| s.y_m = v),
            (POSITION_M, |s, v| s.z_m = v),
            (ANGLE_RAD, |s, v| s.roll_rad = v),
            (ANGLE_RAD, |s, v| s.pitch_rad = v),
            (ANGLE_RAD, |s, v| s.yaw_rad = v),
            (SPEED_M_S, |s, v| s.u_m_s = v),
            (SPEED_M_S, |s, v| s.v_m_s = v),
            (SPEED_M_S, |s, v| s.w_m_s = v),
            (RATE_RAD_S, |s, v| s.p_rad_s = v),
            (RATE_RAD_S, |s, v| s.q_rad_s = v),
            (RATE_RAD_S, |s, v| s.r_rad_s = v),
        ]
    }

    #[test]
    fn check_nav_names_the_first_reason_for_every_field() {
        assert_eq!(check_nav(&NavState::default()), Ok(()));
        for (k, (lim, set)) in fields().into_iter().enumerate() {
            for (v, want) in [
                (lim, Ok(())),
                (-lim, Ok(())),
                (lim * 1.001, Err(NackReason::OutOfRange)),
                (-lim * 1.001, Err(NackReason::OutOfRange)),
                (f32::NAN, Err(NackReason::NonFinite)),
                (f32::INFINITY, Err(NackReason::NonFinite)),
                (f32::NEG_INFINITY, Err(NackReason::NonFinite)),
            ] {
                let mut s = NavState::default();
                set(&mut s, v);
                assert_eq!(check_nav(&s), want, "field {k} = {v}");
            }
            // A non-finite field wins over an out-of-range one elsewhere.
            let mut s = NavState::default();
            set(&mut s, f32::NAN);
            let (lim2, set2) = fields()[(k + 1) % 12];
            set2(&mut s, lim2 * 2.0);
            assert_eq!(check_nav(&s), Err(NackReason::NonFinite), "field {k}");
        }
    }
}

#[cfg(test)]
mod tests_sticks;
