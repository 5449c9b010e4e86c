//! The served vehicle's controller end of the closed loop: the firmware library's `App` as a
//! board runs it (fixed-rate, on its own clock, which here is the simulation's), its
//! thrusters the plant's, its IMU and pressure sensor the simulated ones, its tether the
//! surface's byte stream through the [`TetherBridge`].
//!
//! Each control tick at `t`: the vehicle's own inputs of the tick go in first (with
//! `[navigation] source = "truth"` the true state as a `Nav`, the simulated navigation
//! computer; the compass, DVL and USBL fixes of an estimator scenario), then the surface's
//! bytes, then one pass of the App's main loop at `t` (every frame read; the control step
//! and the telemetry when due on its clock, exactly as on a board); what it wrote goes to
//! the surface. The plant gets the thrust of the pulse widths on its three outputs.

use super::bridge::TetherBridge;
use super::endpoint::{Believed, ServedEndpoint};
use crate::closed_loop::estimator_nav::onboard_config;
use crate::closed_loop::{ControllerEndpoint, StepReply};
use crate::tether::in_process::{SimPwm, SimSerial};
use anyhow::{anyhow, Result};
use controller_core::alloc::PwmMap;
use controller_core::controller::{Controller, Gains};
use controller_core::nav::{DvlFix, ImuSample};
use controller_core::reference::RefSample;
use controller_core::state::NavState;
use firmware::protocol::{Board, Command, NavSample};
use firmware::sensors::dvl::{a50::VelocityGate, DvlPort};
use firmware::{App, Config, Monotonic, Sensors, Timing};
use sim_scenario::setup::RunSetup;
use sim_world::battery::{HealthWire, VehicleElectrics};
use sim_world::clock::us;
use sim_world::sensors::{DvlWire, Measurement, NavSource};
use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::rc::Rc;

/// The vehicle's clock: the simulated time (us).
#[derive(Debug, Clone, Default)]
pub struct SimTime(Rc<Cell<u64>>);

impl Monotonic for SimTime {
    fn now_us(&mut self) -> u64 {
        self.0.get()
    }
}

/// Readings of the simulated IMU and pressure sensor, each available from its time stamp.
#[derive(Debug, Default)]
struct Feed {
    imu: VecDeque<ImuSample>,
    current_imu: Option<ImuSample>,
    pressure: VecDeque<(u64, f32)>,
    dvl: VecDeque<DvlFix>,
    /// The DVL's UART: its fixes as the A50's reports, parsed and gated as on a board.
    dvl_uart: DvlUart,
    /// The power-sense module, leak probe and enclosure sensor.
    health: Option<HealthWire>,
}

/// The vehicle's own IMU, pressure sensor, DVL (on its UART) and health inputs, fed from the
/// plant and the simulated battery: the
/// surface's `Imu` and `Pressure` are refused (`OwnSensors`), as by a real vehicle. Read
/// before each control step (the IMU and pressure only while the on-board estimator runs:
/// the App's rule).
#[derive(Debug, Clone, Default)]
pub struct PlantBus(Rc<RefCell<Feed>>);

impl Sensors for PlantBus {
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        let mut f = self.0.borrow_mut();
        while f.imu.front().is_some_and(|s| s.t_us <= now_us) {
            f.current_imu = f.imu.pop_front();
        }
        f.current_imu.map(|s| ImuSample { t_us: now_us, ..s })
    }

    fn pressure_pa(&mut self, now_us: u64) -> Option<f32> {
        let mut f = self.0.borrow_mut();
        let mut latest = None;
        while f.pressure.front().is_some_and(|&(t, _)| t <= now_us) {
            latest = f.pressure.pop_front().map(|(_, p)| p);
        }
        latest
    }

    /// The DVL's reports of their time or before, sent on its UART; the newest admitted
    /// (the older ones are superseded).
    fn dvl(&mut self, now_us: u64) -> Option<DvlFix> {
        let f = &mut *self.0.borrow_mut();
        while f.dvl.front().is_some_and(|d| d.t_us <= now_us) {
            if let Some(d) = f.dvl.pop_front() {
                f.dvl_uart.wire.send_wrz(&d);
            }
        }
        f.dvl_uart.port.poll(now_us)
    }

    fn health(&mut self, _now_us: u64) -> Option<firmware::health::HealthSample> {
        self.0.borrow_mut().health.as_mut().map(HealthWire::sample)
    }
}

/// The DVL on its UART: the in-memory line (no time per byte) and the board's port on it.
struct DvlUart {
    wire: DvlWire,
    port: DvlPort<DvlWire>,
}

impl Default for DvlUart {
    fn default() -> Self {
        let wire = DvlWire::default();
        Self {
            port: DvlPort::new(wire.clone(), VelocityGate::default(), 0),
            wire,
        }
    }
}

impl std::fmt::Debug for DvlUart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DvlUart")
            .field("stats", &self.port.stats())
            .finish()
    }
}

/// The App of the served vehicle.
pub type ServedApp = App<SimPwm, SimSerial, SimTime, PlantBus>;

/// The served vehicle as the loop's controller endpoint.
pub struct ServedVehicle {
    app: ServedApp,
    clock: SimTime,
    feed: PlantBus,
    /// The simulated battery and health events (`[battery]`, `[health]`).
    electrics: VehicleElectrics,
    bridge: TetherBridge,
    /// The control period (us): the App's, and the loop's.
    period_us: u64,
    /// Control ticks run.
    ticks: u64,
    truth_nav: bool,
    /// Starts the on-board estimator at the launch point (in place of the surface).
    start_nav: bool,
    vehicle: controller_core::params::VehicleParams,
    onboard: controller_core::nav::onboard::OnboardConfig,
    pwm: PwmMap,
    /// Vehicle inputs for the next pass (before the surface's bytes).
    own: Vec<Command>,
    /// Bytes from the surface, for the next pass.
    pub surface_in: Vec<u8>,
    /// Bytes for the surface, written by the passes since taken.
    pub surface_out: Vec<u8>,
    /// The simulated USBL at the surface: its fixes go to the surface program as NMEA
    /// (otherwise into the vehicle's inputs, as a navigation computer's would).
    usbl: Option<super::usbl_out::UsblOut>,
    /// The launch point the vehicle was put in the water at (known once the loop starts).
    pub launch: Option<NavState>,
}

impl ServedVehicle {
    /// The App as a board builds it (the Observer's controller; 50 Hz PWM, 1 us a duty step;
    /// telemetry every 100 ms), its control period the scenario's; `start_nav`: the vehicle
    /// starts its own estimator at the launch point (estimator scenarios).
    pub fn new(sc: &RunSetup, start_nav: bool) -> Result<Self> {
        let period_us = us(sc.control_period_s);
        let control_period_us = u32::try_from(period_us)
            .map_err(|_| anyhow!("control period {} s too long", sc.control_period_s))?;
        let config = Config {
            timing: Timing::FixedRate {
                control_period_us,
                telemetry_period_us: 100_000,
            },
            ..Config::fixed_rate(Board::Host)
        };
        let controller = Controller::new(
            controller_core::params::Vehicle::observer(),
            Gains::default(),
        )
        .map_err(|e| anyhow!("controller: {e}"))?;
        let clock = SimTime::default();
        let feed = PlantBus::default();
        let health = sc.health.params(&sc.battery)?;
        let electrics = VehicleElectrics::new(
            sc.battery,
            sc.health.events()?,
            health,
            PwmMap::for_vehicle(sc.vehicle()),
            f64::from(sc.vehicle_params.thrust_max_forward_n),
        );
        feed.0.borrow_mut().health = Some(electrics.wire());
        let mut app = App::with_sensors(
            [SimPwm::default(), SimPwm::default(), SimPwm::default()],
            SimSerial::default(),
            clock.clone(),
            controller,
            config,
            feed.clone(),
        )
        .map_err(|e| anyhow!("firmware config: {e}"))?;
        app.set_health_params(&health)
            .map_err(|r| anyhow!("the firmware refused the health parameters: {r:?}"))?;
        app.hello();
        Ok(Self {
            app,
            clock,
            feed,
            electrics,
            bridge: TetherBridge::new(),
            period_us,
            ticks: 0,
            truth_nav: sc.navigation.source == NavSource::Truth,
            start_nav: start_nav && sc.navigation.source == NavSource::Estimator,
            vehicle: sc.vehicle_params,
            onboard: onboard_config(sc),
            pwm: PwmMap::for_vehicle(sc.vehicle()),
            own: Vec::new(),
            surface_in: Vec::new(),
            surface_out: Vec::new(),
            usbl: None,
            launch: None,
        })
    }

    /// The App (read-only).
    pub fn app(&self) -> &ServedApp {
        &self.app
    }

    /// The bridge (its counters).
    pub fn bridge(&self) -> &TetherBridge {
        &self.bridge
    }

    /// The App's main loop at the clock's time: the vehicle's inputs first (the control
    /// step, due now, runs on them), then the surface's bytes; every frame read; what it
    /// wrote to the surface.
    fn pass(&mut self) -> Result<()> {
        let own = std::mem::take(&mut self.own);
        let bytes = self.bridge.own_inputs(&own)?;
        self.run(&bytes)?;
        // Inputs held while the bridge's session opened (its answer has been read now).
        let bytes = self.bridge.held()?;
        if !bytes.is_empty() {
            self.run(&bytes)?;
        }
        let from_surface = std::mem::take(&mut self.surface_in);
        let bytes = self.bridge.from_surface(&from_surface)?;
        if !bytes.is_empty() {
            self.run(&bytes)?;
        }
        Ok(())
    }

    /// `rx` to the App's serial port, passes until every byte is read (a board reads a
    /// bounded number a pass; the simulated time stands still meanwhile), its output through
    /// the bridge to the surface.
    fn run(&mut self, rx: &[u8]) -> Result<()> {
        self.app.parts_mut().1.rx.extend(rx);
        self.app.tick();
        while !self.app.parts_mut().1.rx.is_empty() {
            self.app.tick();
        }
        let tx: Vec<u8> = self.app.parts_mut().1.tx.drain(..).collect();
        let out = self.bridge.from_app(&tx)?;
        self.surface_out.extend(out);
        Ok(())
    }
}

impl ServedVehicle {
    /// The USBL's fixes to the surface program as NMEA over UDP (`usbl_out`).
    pub fn set_usbl_out(&mut self, out: super::usbl_out::UsblOut) {
        self.usbl = Some(out);
    }
}

impl ControllerEndpoint for ServedVehicle {
    /// At time 0: the vehicle's own description (as configured on a real vehicle), with
    /// `start_nav` its estimator started at the launch point; the boot's pass.
    fn start(&mut self, nav0: &NavState) -> Result<()> {
        self.launch = Some(*nav0);
        self.own.push(Command::SetVehicle(self.vehicle));
        if self.start_nav {
            self.own.push(Command::StartNav {
                t_us: 0,
                initial: *nav0,
                config: self.onboard,
            });
        }
        Ok(())
    }

    fn step(&mut self, _t_s: f64, nav: &NavState, _reference: &RefSample) -> Result<StepReply> {
        // Whole control periods of the App's clock, so that every tick finds its step due.
        let t_us = self.ticks * self.period_us;
        self.ticks += 1;
        self.clock.0.set(t_us);
        if self.truth_nav {
            self.own.push(Command::Nav(NavSample { t_us, state: *nav }));
        }
        self.pass()?;
        self.electrics
            .advance(t_us, self.app.last_output().pulse_us);
        let tel = self.app.telemetry(t_us);
        let applied = tel
            .pulse_us
            .map(|p| f64::from(self.pwm.thrust_n(f32::from(p))));
        let std_m = self
            .app
            .autopilot()
            .onboard_nav()
            .map(|o| o.position_std_m().map(f64::from));
        Ok(StepReply::from_telemetry(&tel, applied, std_m))
    }

    /// IMU, depth and DVL to the vehicle's own sensors (available from their time stamps);
    /// the compass and USBL fixes as the vehicle's inputs of the next tick.
    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        let mut f = self.feed.0.borrow_mut();
        for m in measurements {
            match *m {
                Measurement::Imu(s) => f.imu.push_back(s),
                Measurement::Depth(d) => f
                    .pressure
                    .push_back((d.t_us, self.onboard.pressure.pressure_pa(d.depth_m))),
                Measurement::Heading(h) => self.own.push(Command::Compass(h)),
                Measurement::Dvl(d) => f.dvl.push_back(d),
                Measurement::Position(p, _) => match self.usbl.as_mut() {
                    Some(out) => {
                        // The transponder's depth as the USBL sees it: the latest pressure
                        // reading's.
                        let depth_m = f
                            .pressure
                            .back()
                            .map_or(0.0, |&(_, pa)| self.onboard.pressure.depth_m(pa));
                        out.send(&p, depth_m, self.ticks.saturating_sub(1) * self.period_us);
                    }
                    None => self.own.push(Command::UsblFix(p)),
                },
            }
        }
        Ok(())
    }
}

impl ServedEndpoint for ServedVehicle {
    fn describe(&self) -> String {
        "firmware library in process".into()
    }

    fn surface_sent(&mut self, bytes: &[u8]) {
        self.surface_in.extend_from_slice(bytes);
    }

    fn take_surface_out(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.surface_out)
    }

    fn believed(&self) -> Believed {
        let ap = self.app.autopilot();
        Believed {
            nav: ap.nav_state(),
            armed: ap.armed(),
            mode: Believed::mode_name(&ap.mode()),
            shown: self.bridge.shown(),
        }
    }

    fn own_refused(&self) -> u64 {
        self.bridge.own_refused
    }

    fn launch(&self) -> Option<NavState> {
        self.launch
    }

    fn onboard_config(&self) -> Option<controller_core::nav::onboard::OnboardConfig> {
        Some(self.onboard)
    }
}
