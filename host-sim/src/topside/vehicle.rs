//! The vehicle behind the tether, as the topside drives it: a simulated one or a real one on
//! its own clock (`--serial`).
//!
//! The simulated vehicle is the one closed loop of every run ([`ClosedLoop`]) with the
//! controller of the scenario's layout as its endpoint (`[deployment] control`):
//! - `onboard`: the firmware at the far end of the tether ([`TetherEndpoint`], the same as
//!   `hil`; the library in process or the image in QEMU);
//! - `topside` (the paper's layout, issue 25): [`TopsideLayout`], the topside MCU's `App`
//!   with its node on the vehicle behind the node link; the topside's commands go to the
//!   topside App over its PC tether, as they would to the topside board.
//!
//! Either way: the scenario's plant, its navigation stage (with `[navigation] source =
//! "estimator"` the simulated sensors, delivered to the vehicle's own estimator), the
//! lock-step exchange. The topside only adds the ground stations' commands between the
//! steps, and logs the true state beside what the vehicle says (`truth.csv`). The topside's
//! code sees only [`VehicleEnd`]: send a command and get its answer, send the pilot's
//! sticks, step one control period, read the latest telemetry and status.

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
use std::time::Duration;

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
    ) -> Result<std::result::Result<(), NackReason>> {
        let cmd = match group {
            Group::Tracking => Command::SetTrackingGains(proposed.gains.tracking),
            Group::Paper => Command::SetPaperGains {
                xz: proposed.gains.paper_xz,
                xy: proposed.gains.paper_xy,
            },
            Group::Failsafe => match proposed.failsafe.to_firmware() {
                Ok(f) => Command::SetFailsafe(f),
                Err(_) => return Ok(Err(NackReason::OutOfRange)),
            },
            Group::Vehicle => Command::SetVehicle(proposed.vehicle),
            Group::Compass => Command::SetCompassCal(proposed.compass.to_calibration()),
            Group::Mission => {
                // Nothing to send now: the next mission carries it.
                self.settings.mission_speed_m_s = proposed.mission_speed_m_s;
                return Ok(Ok(()));
            }
        };
        let r = self.command(&cmd)?;
        if r.is_ok() {
            let s = &mut self.settings;
            match group {
                Group::Tracking => s.gains.tracking = proposed.gains.tracking,
                Group::Paper => {
                    s.gains.paper_xz = proposed.gains.paper_xz;
                    s.gains.paper_xy = proposed.gains.paper_xy;
                }
                Group::Failsafe => s.failsafe = proposed.failsafe,
                Group::Vehicle => s.vehicle = proposed.vehicle,
                Group::Mission => s.mission_speed_m_s = proposed.mission_speed_m_s,
                Group::Compass => s.compass = proposed.compass,
            }
        }
        Ok(r)
    }

    /// A command answered by `Ack` / `Nack`.
    pub(super) fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.end.command(cmd)
    }

    /// One control period. Simulated: one step of the closed loop, its truth logged. Real:
    /// a heartbeat every [`HEARTBEAT_EVERY`] periods and whatever the vehicle said.
    pub(super) fn step(&mut self) -> Result<()> {
        let (t_s, tel) = self.end.step(self.periods)?;
        if let Some(t) = tel {
            self.tel = t;
            self.state = t.nav;
        }
        self.t_s = t_s;
        self.periods += 1;
        Ok(())
    }
}
