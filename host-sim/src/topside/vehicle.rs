//! The vehicle behind the tether, as the topside drives it: a simulated one or a real one on
//! its own clock (`--serial`).
//!
//! The simulated vehicle is the one closed loop of every run ([`ClosedLoop`]) with the
//! firmware at the far end of the tether as its controller ([`TetherEndpoint`], the same as
//! `hil`): the scenario's plant, its navigation stage (with `[navigation] source =
//! "estimator"` the simulated sensors, delivered to the vehicle's own estimator), the
//! lock-step exchange with its resends. The topside only adds the ground stations' commands
//! on the same link between the steps, and logs the true state beside what the vehicle says
//! (`truth.csv`).

use crate::clock::us;
use crate::closed_loop::estimator_nav::navigation_for_vehicle;
use crate::closed_loop::{ClosedLoop, Navigation, RunOptions};
use crate::scenario::RunSetup;
use crate::tether::endpoint::{HilOptions, HilTarget, TetherEndpoint};
use crate::tether::link::{HostLinkStats, Link};
use crate::topside::params::{Group, Settings};
use anyhow::{anyhow, bail, Context, Result};
use controller_core::params::VehicleParams;
use controller_core::state::NavState;
use firmware::protocol::{Command, NackReason, Reply, Telemetry};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::Path;
use std::time::Duration;

/// The vehicle behind the tether: a simulated one (the closed loop here, the firmware in
/// lock-step) or a real one on its own clock (`--serial`).
pub(super) struct SimVehicle {
    tether: Tether,
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
}

/// The two ends the topside can have.
enum Tether {
    /// The scenario's closed loop, the firmware its controller; the true state of each
    /// control period beside what the vehicle said, to `truth`.
    Sim {
        run: Box<ClosedLoop<Box<dyn Navigation>, TetherEndpoint>>,
        truth: BufWriter<File>,
    },
    /// A real vehicle.
    Real(Box<Link>),
}

/// A real vehicle is sent a heartbeat every this many control periods (10 Hz): its
/// `HEARTBEAT_LOST` failsafe trips after 0.5 s without one.
const HEARTBEAT_EVERY: u64 = 5;

const TETHER_TIMEOUT: Duration = Duration::from_millis(500);

/// The columns of the simulated vehicle's truth log.
pub const TRUTH_HEADER: &str = "t_s,x_m,y_m,z_m,yaw_rad,nav_x_m,nav_y_m,nav_z_m,nav_yaw_rad,armed";

impl SimVehicle {
    /// The scenario's closed loop with the firmware behind `port` (`target` says where it
    /// runs), waiting up to `hello_wait` for its `Hello`; the true state logged to `truth`.
    /// The first control period is run: the vehicle gets its description and its navigation.
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
        let mut v = Self {
            period_s: run.period_s(),
            tether: Tether::Sim {
                run: Box::new(run),
                truth,
            },
            t_s: 0.0,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            // What the endpoint sends at the start (the firmware boots with the Observer's).
            settings: Settings::new(sc.vehicle_params),
        };
        v.step()?;
        Ok(v)
    }

    /// A real vehicle on `port`, running on its own clock: found by a heartbeat answered
    /// within 2 s. Its description is sent only when `vehicle` is given (a real vehicle
    /// keeps its own otherwise; the parameter list shows the Observer's until then).
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
            tether: Tether::Real(Box::new(link)),
            t_s: 0.0,
            period_s: 0.02,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings: Settings::new(vehicle.unwrap_or(VehicleParams::OBSERVER)),
        };
        if vehicle.is_some() {
            let s = v.settings;
            if let Err(why) = v.apply(s, Group::Vehicle)? {
                bail!("the vehicle refused the vehicle description: {why:?}");
            }
        }
        Ok(v)
    }

    /// The link to the vehicle.
    pub(super) fn link(&mut self) -> &mut Link {
        match &mut self.tether {
            Tether::Sim { run, .. } => run.endpoint_mut().link(),
            Tether::Real(link) => link,
        }
    }

    /// The link's counters.
    pub(super) fn link_stats(&self) -> &HostLinkStats {
        match &self.tether {
            Tether::Sim { run, .. } => run.endpoint().link_stats(),
            Tether::Real(link) => &link.stats,
        }
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
        self.link().command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }

    /// One control period. Simulated: one step of the closed loop (the lock-step exchange,
    /// the plant through the period with the thrust of the pulse widths), its truth logged.
    /// Real: a heartbeat every [`HEARTBEAT_EVERY`] periods and whatever the vehicle said.
    pub(super) fn step(&mut self) -> Result<()> {
        match &mut self.tether {
            Tether::Sim { run, truth } => {
                if !run.step()? {
                    bail!("the simulated vehicle stopped: {}", run.stop_reason());
                }
                self.tel = *run.endpoint().latest();
                self.state = self.tel.nav;
                let s = run.sample();
                let (x, n) = (&s.state.eta, &self.state);
                writeln!(
                    truth,
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
                    u8::from(self.tel.armed)
                )?;
                // A killed topside loses at most a second of it.
                let per_second = (1.0 / self.period_s).round().max(1.0) as u64;
                if self.periods.is_multiple_of(per_second) {
                    truth.flush()?;
                }
                self.t_s = run.t_s();
            }
            Tether::Real(link) => {
                if self.periods.is_multiple_of(HEARTBEAT_EVERY) {
                    link.send(&Command::Heartbeat { t_us: us(self.t_s) })?;
                }
                while let Some((_, reply)) = link.recv(Duration::ZERO)? {
                    if let Reply::Telemetry(t) = reply {
                        self.tel = t;
                        self.state = t.nav;
                    }
                }
                self.t_s += self.period_s;
            }
        }
        self.periods += 1;
        Ok(())
    }
}
