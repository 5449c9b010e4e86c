//! The vehicle behind the tether, as the topside drives it: a simulated one or a real one on
//! its own clock (`--serial`).
//!
//! The simulated vehicle is the one closed loop of every run ([`ClosedLoop`]) with the
//! controller of the scenario's layout as its endpoint (`[deployment] control`):
//! - `onboard`: the firmware at the far end of the tether ([`TetherEndpoint`], the same as
//!   `hil`; the library in process or the image in QEMU);
//! - `topside` (the paper's layout): [`TopsideLayout`], the topside MCU's `App`
//!   with its node on the vehicle behind the node link; the topside's commands go to the
//!   topside App over its PC tether, as they would to the topside board.
//!
//! Either way: the scenario's plant, its navigation stage (with `[navigation] source =
//! "estimator"` the simulated sensors, delivered to the vehicle's own estimator), the
//! lock-step exchange. The topside only adds the ground stations' commands between the
//! steps, and logs the true state beside what the vehicle says (`truth.csv`). The topside's
//! code sees only [`VehicleEnd`]: send a command and get its answer, send the pilot's
//! sticks, step one control period, read the latest telemetry and status.
//!
//! Every telemetry frame is checked before it is believed ([`check_telemetry`]): finite
//! values in physical ranges, pulse widths an ESC can be sent, at most a mission's waypoints
//! reached; in a frame out of range no number is believed (the last good ones stay; the armed
//! flag, the mode and the fault flags, bounded by their types, are still shown) and it is
//! counted. A
//! vehicle that says nothing for [`VEHICLE_SILENCE`] is silent: its commands are refused at
//! once (`Refusal::Silent`) instead of waited for, and a command it leaves unanswered is a
//! refusal, never the end of the topside.

use crate::clock::us;
use crate::closed_loop::estimator_nav::navigation_for_vehicle;
use crate::closed_loop::{ClosedLoop, ControllerEndpoint, Navigation, RunOptions};
use crate::scenario::RunSetup;
use crate::tether::endpoint::{HilOptions, HilTarget, TetherEndpoint};
use crate::tether::link::Link;
use crate::tether::topside_layout::TopsideLayout;
use crate::topside::params::{Group, Settings};
use anyhow::{anyhow, bail, Context, Result};
use controller_core::params::VehicleParams;
use controller_core::state::NavState;
use firmware::protocol::{Command, NackReason, Reply, Status, Telemetry};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::{Duration, Instant};

/// A vehicle that sends no telemetry for this long (wall clock) is silent.
pub const VEHICLE_SILENCE: Duration = Duration::from_secs(1);

/// Why the vehicle did not take a command: its `Nack`, or no answer at all. Shown in the
/// refusals' words (`{:?}`): the reason's name, or that the vehicle is silent.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Refusal {
    /// The vehicle refused it.
    Nack(NackReason),
    /// The vehicle is silent (nothing for [`VEHICLE_SILENCE`], or the command unanswered).
    Silent,
}

impl std::fmt::Debug for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::Nack(NackReason::SticksNotCentred) => {
                f.write_str("the vehicle saw a stick off centre (centre the sticks)")
            }
            Refusal::Nack(r) => write!(f, "{r:?}"),
            Refusal::Silent => f.write_str("no answer from the vehicle (silent)"),
        }
    }
}

/// Farthest position believed from the origin, horizontally (m).
const MAX_POSITION_M: f32 = 10_000.0;
/// Deepest (and highest) position believed (m).
const MAX_DEPTH_M: f32 = 1_000.0;
/// Largest speed believed (m/s) and turn rate (rad/s).
const MAX_SPEED_M_S: f32 = 20.0;
const MAX_RATE_RAD_S: f32 = 50.0;
/// Largest heading believed (rad): the vehicle may report it unwrapped.
const MAX_YAW_RAD: f32 = 10_000.0;
/// Largest thruster force believed (N).
const MAX_THRUST_N: f32 = 1_000.0;
/// Pulse widths believed (us): what an RC output can send an ESC; 0 is an output off.
pub const PULSE_RANGE_US: std::ops::RangeInclusive<u16> = 800..=2200;

/// Is `t` believable? Every value the topside forwards or acts on: finite and in range, or
/// the first field that is not.
pub fn check_telemetry(t: &Telemetry) -> std::result::Result<(), String> {
    let n = &t.nav;
    if !n.is_finite() || !t.requested.is_finite() || !t.achieved.is_finite() {
        return Err("a navigation value or force is not finite".into());
    }
    let e = &t.errors;
    if ![e.x_m, e.y_m, e.z_m, e.pitch_rad, e.yaw_rad]
        .iter()
        .chain(&t.nav_pos_std_m)
        .all(|v| v.is_finite())
    {
        return Err("a tracking error or position spread is not finite".into());
    }
    if n.x_m.hypot(n.y_m) > MAX_POSITION_M || n.z_m.abs() > MAX_DEPTH_M {
        return Err(format!(
            "position ({}, {}, {}) m out of range",
            n.x_m, n.y_m, n.z_m
        ));
    }
    let pi2 = 2.0 * std::f32::consts::PI;
    if n.roll_rad.abs() > pi2 || n.pitch_rad.abs() > pi2 || n.yaw_rad.abs() > MAX_YAW_RAD {
        return Err("an attitude angle out of range".into());
    }
    let speeds = [n.u_m_s, n.v_m_s, n.w_m_s];
    let rates = [n.p_rad_s, n.q_rad_s, n.r_rad_s];
    if speeds.iter().any(|v| v.abs() > MAX_SPEED_M_S)
        || rates.iter().any(|v| v.abs() > MAX_RATE_RAD_S)
    {
        return Err("a speed or turn rate out of range".into());
    }
    if t.thrust_n
        .iter()
        .any(|f| !f.is_finite() || f.abs() > MAX_THRUST_N)
    {
        return Err(format!("thrust {:?} N out of range", t.thrust_n));
    }
    if t.pulse_us
        .iter()
        .any(|&p| p != 0 && !PULSE_RANGE_US.contains(&p))
    {
        return Err(format!("pulse widths {:?} us out of range", t.pulse_us));
    }
    let most = protocol::limits::MAX_MISSION_ITEMS;
    if usize::from(t.mission_reached) > most {
        return Err(format!(
            "{} waypoints reached, a mission has at most {most}",
            t.mission_reached
        ));
    }
    Ok(())
}

/// What the topside needs of the vehicle behind the tether, whichever it is.
pub(super) trait VehicleEnd {
    /// A command answered by `Ack` (`Ok`) or `Nack` (its reason).
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>>;
    /// A command not waited for (the pilot's sticks, every period).
    fn send(&mut self, cmd: &Command) -> Result<()>;
    /// One control period, the `periods`-th: the simulated time after it, and the latest
    /// telemetry if one came.
    fn step(&mut self, periods: u64) -> Result<(f64, Option<Telemetry>)>;
    /// The control period (s).
    fn period_s(&self) -> f64;
    /// The latest `Status` (the answer to a heartbeat).
    fn last_status(&mut self) -> Option<Status>;
    /// Frames dropped on the tether to the vehicle (bad CRC, framing), for `SYS_STATUS`.
    fn frames_dropped(&self) -> u64;
}

/// The vehicle behind the tether: a simulated one (the closed loop here, the scenario's
/// layout in lock-step) or a real one on its own clock (`--serial`).
pub(super) struct SimVehicle {
    end: Box<dyn VehicleEnd>,
    pub(super) t_s: f64,
    pub(super) period_s: f64,
    /// Control periods run.
    pub(super) periods: u64,
    /// The vehicle's navigation state, from its telemetry (its own estimate, or the `Nav`
    /// it was sent).
    pub(super) state: NavState,
    pub(super) tel: Telemetry,
    /// The gains, timeouts and description in force on the vehicle (as last accepted).
    pub(super) settings: Settings,
    /// The pilot's sticks are forwarded every this many periods, and the truth log gets a
    /// row as often: every period, except for the topside layout, whose loop period (2.5 ms,
    /// the node's IMU period) is finer than its topside's control (the node link's 20 ms).
    pub(super) stride: u64,
    /// When the vehicle last sent telemetry (wall clock).
    heard_at: Instant,
    /// Telemetry frames refused by [`check_telemetry`], and the latest reason.
    pub(super) frames_refused: u64,
    pub(super) last_refusal: Option<String>,
}

/// A real vehicle is sent a heartbeat every this many control periods (10 Hz): its
/// `HEARTBEAT_LOST` failsafe trips after 0.5 s without one.
const HEARTBEAT_EVERY: u64 = 5;

const TETHER_TIMEOUT: Duration = Duration::from_millis(500);

/// The topside layout's sticks and truth rows: every this long (s), its topside's control
/// period (the node link's 50 Hz); 400 rows a second would be about 100 MB an hour.
const LAYOUT_STRIDE_S: f64 = 0.02;

/// The columns of the simulated vehicle's truth log.
pub const TRUTH_HEADER: &str = "t_s,x_m,y_m,z_m,yaw_rad,nav_x_m,nav_y_m,nav_z_m,nav_yaw_rad,armed";

/// The controller endpoints a simulated vehicle can have: what the topside needs of each
/// beyond the loop's [`ControllerEndpoint`].
pub(super) trait SimEndpoint: ControllerEndpoint {
    /// See [`VehicleEnd::command`].
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>>;
    /// See [`VehicleEnd::send`].
    fn send(&mut self, cmd: &Command) -> Result<()>;
    /// The latest telemetry the PC received.
    fn telemetry(&self) -> Option<Telemetry>;
    /// See [`VehicleEnd::last_status`].
    fn last_status(&mut self) -> Option<Status>;
    /// See [`VehicleEnd::frames_dropped`].
    fn frames_dropped(&self) -> u64;
}

/// The onboard layout: the firmware at the far end of a tether.
impl SimEndpoint for TetherEndpoint {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.link().command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }
    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.link().send(cmd).map(|_| ())
    }
    fn telemetry(&self) -> Option<Telemetry> {
        Some(*self.latest())
    }
    fn last_status(&mut self) -> Option<Status> {
        self.link().last_status
    }
    fn frames_dropped(&self) -> u64 {
        self.link_stats().frames_dropped
    }
}

/// The topside layout: the topside App's PC tether is in memory (it cannot drop a frame);
/// a command runs at once in the topside App, the sticks go at its next pass.
impl SimEndpoint for TopsideLayout {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.try_command(cmd)
    }
    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.queue_command(*cmd);
        Ok(())
    }
    fn telemetry(&self) -> Option<Telemetry> {
        self.latest_telemetry().copied()
    }
    fn last_status(&mut self) -> Option<Status> {
        self.latest_status().copied()
    }
    fn frames_dropped(&self) -> u64 {
        0
    }
}

/// A simulated vehicle: the scenario's closed loop with `E` as its controller; the true
/// state beside what the vehicle said, to `truth`, every `stride` periods.
struct Simulated<E: SimEndpoint> {
    run: ClosedLoop<Box<dyn Navigation>, E>,
    truth: BufWriter<File>,
    stride: u64,
    last: Telemetry,
}

impl<E: SimEndpoint> VehicleEnd for Simulated<E> {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.run.endpoint_mut().command(cmd)
    }

    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.run.endpoint_mut().send(cmd)
    }

    /// One step of the closed loop (the lock-step exchange, the plant through the period
    /// with the thrust of the pulse widths), its truth logged.
    fn step(&mut self, periods: u64) -> Result<(f64, Option<Telemetry>)> {
        let run = &mut self.run;
        if !run.step()? {
            bail!("the simulated vehicle stopped: {}", run.stop_reason());
        }
        let tel = run.endpoint().telemetry();
        if let Some(t) = tel {
            self.last = t;
        }
        let every = self.stride;
        if !periods.is_multiple_of(every) {
            return Ok((run.t_s(), tel));
        }
        let s = run.sample();
        let (x, n) = (&s.state.eta, &self.last.nav);
        writeln!(
            self.truth,
            "{:.3},{:.4},{:.4},{:.4},{:.5},{:.4},{:.4},{:.4},{:.5},{}",
            s.t_s,
            x[0],
            x[1],
            x[2],
            x[5],
            n.x_m,
            n.y_m,
            n.z_m,
            n.yaw_rad,
            u8::from(self.last.armed)
        )?;
        // A killed topside loses at most a second of it.
        let per_second = (1.0 / run.period_s()).round().max(1.0) as u64;
        if (periods / every).is_multiple_of((per_second / every).max(1)) {
            self.truth.flush()?;
        }
        Ok((run.t_s(), tel))
    }

    fn period_s(&self) -> f64 {
        self.run.period_s()
    }

    fn last_status(&mut self) -> Option<Status> {
        self.run.endpoint_mut().last_status()
    }

    fn frames_dropped(&self) -> u64 {
        self.run.endpoint().frames_dropped()
    }
}

/// A real vehicle on its own clock: a heartbeat every [`HEARTBEAT_EVERY`] periods and
/// whatever it said.
struct Real {
    link: Link,
    t_s: f64,
}

/// The period the topside runs a real vehicle's side at (s).
const REAL_PERIOD_S: f64 = 0.02;

impl VehicleEnd for Real {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.link.command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }

    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.link.send(cmd).map(|_| ())
    }

    fn step(&mut self, periods: u64) -> Result<(f64, Option<Telemetry>)> {
        if periods.is_multiple_of(HEARTBEAT_EVERY) {
            self.link.send(&Command::Heartbeat { t_us: us(self.t_s) })?;
        }
        let mut tel = None;
        while let Some((_, reply)) = self.link.recv(Duration::ZERO)? {
            if let Reply::Telemetry(t) = reply {
                tel = Some(t);
            }
        }
        self.t_s += REAL_PERIOD_S;
        Ok((self.t_s, tel))
    }

    fn period_s(&self) -> f64 {
        REAL_PERIOD_S
    }

    fn last_status(&mut self) -> Option<Status> {
        self.link.last_status
    }

    fn frames_dropped(&self) -> u64 {
        self.link.stats.frames_dropped
    }
}

impl SimVehicle {
    /// The onboard layout: the scenario's closed loop with the firmware behind `port`
    /// (`target` says where it runs), waiting up to `hello_wait` for its `Hello`; the true
    /// state logged to `truth`. The first control period is run: the vehicle gets its
    /// description and its navigation.
    pub(super) fn new(
        sc: &RunSetup,
        port: Box<dyn crate::tether::port::Port>,
        target: HilTarget,
        hello_wait: Duration,
        truth: &Path,
    ) -> Result<Self> {
        let mut opts = HilOptions::new(target);
        // The ground stations arm and choose the modes; the topside runs until stopped.
        opts.fly_scenario = false;
        opts.record = false;
        opts.telemetry_rows = false;
        opts.wall_limit = Duration::MAX;
        let endpoint = TetherEndpoint::connect(
            Link::new(port, None),
            sc,
            &opts,
            "topside".into(),
            hello_wait,
            true,
        )?;
        Self::simulated(sc, endpoint, truth, 1)
    }

    /// The topside layout (`[deployment] control = "topside"`): the scenario's closed loop
    /// with `layout` as its controller (the topside App, its node, the node link); `sc` is
    /// the scenario as the layout flies it (`topside_layout::layout_scenario`). The ground
    /// stations arm and choose the modes: the layout only gets the vehicle and starts its
    /// navigation.
    pub(super) fn topside_layout(
        sc: &RunSetup,
        mut layout: TopsideLayout,
        truth: &Path,
    ) -> Result<Self> {
        layout.ground_station_commands();
        let stride = (LAYOUT_STRIDE_S / sc.control_period_s).round().max(1.0) as u64;
        Self::simulated(sc, layout, truth, stride)
    }

    /// The scenario's closed loop with `endpoint`, its first control period run; the sticks
    /// and the truth rows every `stride` periods.
    fn simulated<E: SimEndpoint + 'static>(
        sc: &RunSetup,
        endpoint: E,
        truth: &Path,
        stride: u64,
    ) -> Result<Self> {
        let run_opts = RunOptions {
            open_ended: true,
            ..RunOptions::default()
        };
        let run = ClosedLoop::new(sc, &run_opts, navigation_for_vehicle(sc), endpoint)?;
        // Beside the time-stamped logs of this start: never an existing file.
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(truth)
            .with_context(|| format!("create {}", truth.display()))?;
        let mut truth = BufWriter::new(file);
        writeln!(truth, "{TRUTH_HEADER}")?;
        let end = Simulated {
            run,
            truth,
            stride,
            last: Telemetry::default(),
        };
        let mut v = Self {
            period_s: end.period_s(),
            end: Box::new(end),
            t_s: 0.0,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            // What the endpoint sends at the start (the firmware boots with the Observer's).
            settings: Settings::new(sc.vehicle_params),
            stride,
            heard_at: Instant::now(),
            frames_refused: 0,
            last_refusal: None,
        };
        v.step()?;
        Ok(v)
    }

    /// A real vehicle on `port`, running on its own clock: found by a heartbeat answered
    /// within 2 s. Its description is sent only when `vehicle` is given (a real vehicle
    /// keeps its own otherwise; the parameter list shows the Observer's until then). An
    /// onboard vehicle and a topside board of the topside layout answer alike: the same
    /// tether protocol.
    pub(super) fn real(
        port: Box<dyn crate::tether::port::Port>,
        vehicle: Option<VehicleParams>,
    ) -> Result<Self> {
        let mut link = Link::new(port, None);
        link.send(&Command::Heartbeat { t_us: 0 })?;
        let first = link
            .wait_for(
                Duration::from_secs(2),
                |r| match r {
                    Reply::Status(_) | Reply::Telemetry(_) | Reply::Hello { .. } => Some(Ok(())),
                    Reply::Nack { reason, .. } => Some(Err(*reason)),
                    Reply::Ack { .. } | Reply::Session { .. } => None,
                },
                |_| {},
            )?
            .ok_or_else(|| anyhow!("no answer from a vehicle on the serial port within 2 s"))?;
        if let Err(why) = first {
            bail!("the vehicle refused our heartbeat: {why:?} (another protocol version?)");
        }
        let mut v = Self {
            end: Box::new(Real { link, t_s: 0.0 }),
            t_s: 0.0,
            period_s: REAL_PERIOD_S,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings: Settings::new(vehicle.unwrap_or(VehicleParams::OBSERVER)),
            stride: 1,
            heard_at: Instant::now(),
            frames_refused: 0,
            last_refusal: None,
        };
        if vehicle.is_some() {
            let s = v.settings;
            if let Err(why) = v.apply(s, Group::Vehicle)? {
                bail!("the vehicle refused the vehicle description: {why:?}");
            }
        }
        Ok(v)
    }

    /// A command not waited for (the pilot's sticks).
    pub(super) fn send(&mut self, cmd: &Command) -> Result<()> {
        self.end.send(cmd)
    }

    /// The vehicle's latest `Status`.
    pub(super) fn last_status(&mut self) -> Option<Status> {
        self.end.last_status()
    }

    /// Frames dropped on the tether.
    pub(super) fn frames_dropped(&self) -> u64 {
        self.end.frames_dropped()
    }

    /// Send one group of settings; on a refusal nothing changes, here or on the vehicle.
    pub(super) fn apply(
        &mut self,
        proposed: Settings,
        group: Group,
    ) -> Result<std::result::Result<(), Refusal>> {
        let cmd = match group {
            Group::Tracking => Command::SetTrackingGains(proposed.gains.tracking),
            Group::Paper => Command::SetPaperGains {
                xz: proposed.gains.paper_xz,
                xy: proposed.gains.paper_xy,
            },
            Group::Failsafe => match proposed.failsafe.to_firmware() {
                Ok(f) => Command::SetFailsafe(f),
                Err(_) => return Ok(Err(Refusal::Nack(NackReason::OutOfRange))),
            },
            Group::Vehicle => Command::SetVehicle(proposed.vehicle),
            Group::Compass => Command::SetCompassCal(proposed.compass.to_calibration()),
            Group::Mission | Group::Control => {
                // Nothing to send now: kept at the surface (the next mission carries the
                // speed).
                self.settings.take_group(&proposed, group);
                return Ok(Ok(()));
            }
        };
        let r = self.command(&cmd)?;
        if r.is_ok() {
            self.settings.take_group(&proposed, group);
        }
        Ok(r)
    }

    /// How long the vehicle has said nothing (wall clock).
    pub(super) fn silent_for(&self) -> Duration {
        self.heard_at.elapsed()
    }

    /// A command answered by `Ack` / `Nack`; refused at once while the vehicle is silent, and
    /// a command left unanswered is a refusal (noted), never an error that ends the topside.
    pub(super) fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), Refusal>> {
        if self.silent_for() >= VEHICLE_SILENCE {
            return Ok(Err(Refusal::Silent));
        }
        match self.end.command(cmd) {
            Ok(r) => Ok(r.map_err(Refusal::Nack)),
            Err(e) => {
                eprintln!("topside: {e:#} (refused; the topside goes on)");
                Ok(Err(Refusal::Silent))
            }
        }
    }

    /// One control period. Simulated: one step of the closed loop, its truth logged. Real:
    /// a heartbeat every [`HEARTBEAT_EVERY`] periods and whatever the vehicle said.
    pub(super) fn step(&mut self) -> Result<()> {
        let (t_s, tel) = self.end.step(self.periods)?;
        if let Some(t) = tel {
            self.heard_at = Instant::now();
            match check_telemetry(&t) {
                Ok(()) => {
                    self.tel = t;
                    self.state = t.nav;
                }
                Err(why) => {
                    self.frames_refused += 1;
                    self.last_refusal = Some(why);
                    // What every frame says in values its type bounds (armed, the mode, the
                    // fault flags) is still shown; the numbers stay the last good ones.
                    self.tel.armed = t.armed;
                    self.tel.mode = t.mode;
                    self.tel.faults = t.faults;
                    self.tel.t_us = t.t_us;
                }
            }
        }
        self.t_s = t_s;
        self.periods += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn telemetry_out_of_range_is_named_and_a_plain_frame_passes() {
        let good = Telemetry {
            pulse_us: [1500; 3],
            ..Telemetry::default()
        };
        assert_eq!(check_telemetry(&good), Ok(()));
        let mut t = good;
        t.mission_reached = u16::MAX;
        assert!(check_telemetry(&t).unwrap_err().contains("65535 waypoints"));
        let mut t = good;
        t.nav.x_m = f32::NAN;
        assert!(check_telemetry(&t).unwrap_err().contains("not finite"));
        let mut t = good;
        t.pulse_us = [1500, u16::MAX, 1500];
        assert!(check_telemetry(&t).unwrap_err().contains("pulse"));
        let mut t = good;
        t.nav.z_m = 5_000.0;
        assert!(check_telemetry(&t).unwrap_err().contains("position"));
        // An output off (0 us) is a pulse an ESC can be sent.
        let mut t = good;
        t.pulse_us = [0; 3];
        assert_eq!(check_telemetry(&t), Ok(()));
    }
}
