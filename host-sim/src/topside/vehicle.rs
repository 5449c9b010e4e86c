//! The vehicle behind the tether, as the topside drives it: a simulated one (the scenario's
//! plant and navigation here, the firmware in lock-step) or a real one on its own clock
//! (`--serial`). Behaviour unchanged from the single-file topside (issue 24's one loop will
//! replace the simulated body).

use crate::clock::us;
use crate::estimator_nav::navigation_for;
use crate::link::Link;
use crate::params::{Group, Settings};
use crate::plant::Plant;
use crate::scenario::Scenario;
use crate::sim_loop::{make_plant, nominal_plant_params, Navigation};
use anyhow::{anyhow, bail, Result};
use controller_core::alloc::PwmMap;
use controller_core::params::VehicleParams;
use controller_core::state::NavState;
use firmware::protocol::{Command, NackReason, NavSample, Reply, Telemetry};
use std::time::Duration;

/// The vehicle behind the tether: a simulated one (the plant and its navigation here, the
/// firmware in lock-step) or a real one on its own clock (`--serial`).
pub(super) struct SimVehicle {
    /// The simulated body; `None` for a real vehicle.
    body: Option<Body>,
    pub(super) link: Link,
    pub(super) t_s: f64,
    pub(super) period_s: f64,
    /// Control periods run.
    pub(super) periods: u64,
    /// The vehicle's navigation state (a real vehicle's: from its telemetry).
    pub(super) state: NavState,
    pub(super) tel: Telemetry,
    /// The gains, timeouts and description in force on the vehicle (as last accepted).
    pub(super) settings: Settings,
}

/// A simulated vehicle's body: plant, navigation, the ESCs' pulse curve.
struct Body {
    plant: Box<dyn Plant>,
    nav: Box<dyn Navigation>,
    pwm: PwmMap,
    plant_dt_s: f64,
    steps_per_period: usize,
    held_n: [f64; 3],
}

/// A real vehicle is sent a heartbeat every this many control periods (10 Hz): its
/// `HEARTBEAT_LOST` failsafe trips after 0.5 s without one.
const HEARTBEAT_EVERY: u64 = 5;

const TETHER_TIMEOUT: Duration = Duration::from_millis(500);

impl SimVehicle {
    /// The scenario's plant and navigation with the firmware behind `port`, waiting up to
    /// `hello_wait` for its `Hello`.
    pub(super) fn new(
        sc: &Scenario,
        port: Box<dyn crate::port::Port>,
        hello_wait: Duration,
    ) -> Result<Self> {
        let params = nominal_plant_params(sc);
        let plant = make_plant(
            sc.plane,
            &params,
            crate::plant::Environment {
                current_m_s: sc.disturbance.current_m_s,
            },
            sc.thrusters.saturate,
            sc.initial.to_plant(),
        )?;
        let nav = navigation_for(sc, None)?;
        let mut link = Link::new(port, None);
        link.wait_for(
            hello_wait,
            |r| matches!(r, Reply::Hello { .. }).then_some(()),
            |_| {},
        )?
        .ok_or_else(|| anyhow!("no Hello from the firmware"))?;
        let n = sc.plant_steps_per_control().max(1);
        let mut v = Self {
            body: Some(Body {
                plant,
                nav,
                pwm: PwmMap::for_vehicle(&sc.vehicle_model()?),
                plant_dt_s: sc.plant_dt_s,
                steps_per_period: n,
                held_n: [0.0; 3],
            }),
            link,
            t_s: 0.0,
            period_s: sc.plant_dt_s * n as f64,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings: Settings::new(sc.vehicle_params),
        };
        // The firmware boots with the Observer's description: send the scenario's.
        let vehicle = v.settings;
        if let Err(why) = v.apply(vehicle, Group::Vehicle)? {
            bail!("the vehicle refused the vehicle description: {why:?}");
        }
        v.step()?;
        Ok(v)
    }

    /// A real vehicle on `port`, running on its own clock: found by a heartbeat answered
    /// within 2 s. Its description is sent only when `vehicle` is given (a real vehicle
    /// keeps its own otherwise; the parameter list shows the Observer's until then).
    pub(super) fn real(
        port: Box<dyn crate::port::Port>,
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
            body: None,
            link,
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
            }
        }
        Ok(r)
    }

    /// A command answered by `Ack` / `Nack`.
    pub(super) fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.link.command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }

    /// One control period. Simulated: heartbeat and navigation to the firmware, its
    /// telemetry back, the plant through the period with the thrust of the pulse widths.
    /// Real: a heartbeat every [`HEARTBEAT_EVERY`] periods and whatever the vehicle said.
    pub(super) fn step(&mut self) -> Result<()> {
        let t_us = us(self.t_s);
        let Some(body) = self.body.as_mut() else {
            if self.periods.is_multiple_of(HEARTBEAT_EVERY) {
                self.link.send(&Command::Heartbeat { t_us })?;
            }
            self.periods += 1;
            while let Some((_, reply)) = self.link.recv(Duration::ZERO)? {
                if let Reply::Telemetry(t) = reply {
                    self.tel = t;
                    self.state = t.nav;
                }
            }
            self.t_s += self.period_s;
            return Ok(());
        };
        self.state = body.state_at(self.t_s);
        self.link.send(&Command::Heartbeat { t_us })?;
        let nav_seq = self.link.send(&Command::Nav(NavSample {
            t_us,
            state: self.state,
        }))?;
        let tel = self
            .link
            .wait_for(
                TETHER_TIMEOUT,
                |r| match r {
                    Reply::Telemetry(tl) if tl.nav_seq == nav_seq => Some(*tl),
                    _ => None,
                },
                |_| {},
            )?
            .ok_or_else(|| anyhow!("tether: no Telemetry at t = {:.2} s", self.t_s))?;
        self.tel = tel;
        body.advance(self.t_s, &tel);
        self.t_s += self.period_s;
        Ok(())
    }
}

impl Body {
    /// What the simulated vehicle's navigation says at `t_s`.
    fn state_at(&mut self, t_s: f64) -> NavState {
        self.nav.estimate(t_s, self.held_n)
    }

    /// The plant through one control period from `t_s` under the telemetry's pulse widths.
    fn advance(&mut self, t_s: f64, tel: &Telemetry) {
        let applied = tel
            .pulse_us
            .map(|p| f64::from(self.pwm.thrust_n(f32::from(p))));
        for i in 0..self.steps_per_period {
            self.plant.step(applied, self.plant_dt_s);
            self.nav
                .observe(t_s + (i + 1) as f64 * self.plant_dt_s, &self.plant.state());
        }
        self.held_n = tel.thrust_n.map(f64::from);
    }
}
