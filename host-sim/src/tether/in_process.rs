//! The firmware library's `App` in this process, behind an in-memory serial port.
//!
//! [`InProcessFirmware`] is a byte [`Port`](crate::tether::port::Port) like the TCP socket of the
//! emulated board or a serial device: what the host writes is the App's received bytes, and a
//! read first lets the App run one pass of its main loop (`App::tick`, which decodes the
//! frames, runs the control step on a lock-step `Nav` and writes its replies), then returns
//! what it wrote. The App is built exactly as the boards build it (`Config::lockstep`, 50 Hz
//! PWM with 1 us per duty step, the Observer's controller), so a run through it exercises the
//! same framing, state machine, failsafes and PWM quantization as the firmware image, at the
//! speed of a software run.

use anyhow::{anyhow, Result};
use controller_core::alloc::PwmMap;
use controller_core::controller::{Controller, Gains};
use controller_core::params::Vehicle;
use firmware::health::WithHealth;
use firmware::protocol::Board;
use firmware::sensors::dvl::{a50::VelocityGate, DvlPort, WithDvl};
use firmware::{App, Config, Monotonic, NoSensors};
use sim_scenario::health::HealthSpec;
use sim_scenario::setup::RunSetup;
use sim_world::battery::{BatterySpec, HealthWire, VehicleElectrics};
use sim_world::sensors::DvlWire;
use std::collections::VecDeque;
use std::convert::Infallible;
use std::time::Instant;

/// Duty steps of a PWM output: 1 us per step at 50 Hz, like the board's timer.
const PWM_MAX_DUTY: u16 = 20_000;

/// A PWM output that keeps its duty.
#[derive(Debug, Clone, Copy, Default)]
pub struct SimPwm {
    /// The duty last written.
    pub duty: u16,
}

impl embedded_hal::pwm::ErrorType for SimPwm {
    type Error = Infallible;
}

impl embedded_hal::pwm::SetDutyCycle for SimPwm {
    fn max_duty_cycle(&self) -> u16 {
        PWM_MAX_DUTY
    }

    fn set_duty_cycle(&mut self, duty: u16) -> Result<(), Infallible> {
        self.duty = duty.min(PWM_MAX_DUTY);
        Ok(())
    }
}

/// The App's side of an in-memory serial line: bytes queued in `rx` are read by the
/// firmware; bytes the firmware writes are kept in `tx`. The one fake serial port: the
/// cross-crate tests use it too (`rov_tests::FakeSerial`).
#[derive(Debug, Default, Clone)]
pub struct SimSerial {
    /// Waiting to be read by the firmware.
    pub rx: VecDeque<u8>,
    /// Written by the firmware.
    pub tx: Vec<u8>,
}

impl embedded_io::ErrorType for SimSerial {
    type Error = Infallible;
}

impl embedded_io::Read for SimSerial {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = buf.len().min(self.rx.len());
        for (b, x) in buf.iter_mut().zip(self.rx.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}

impl embedded_io::WriteReady for SimSerial {
    /// Always ready: this port takes every byte at once.
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(true)
    }
}

impl embedded_io::ReadReady for SimSerial {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(!self.rx.is_empty())
    }
}

impl embedded_io::Write for SimSerial {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        self.tx.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The host's clock (the App's time in lock-step comes from the frames; this only times
/// its loop, in microseconds).
#[derive(Debug, Clone, Copy)]
pub struct SimClock(Instant);

impl Monotonic for SimClock {
    fn now_us(&mut self) -> u64 {
        self.0.elapsed().as_micros() as u64
    }
}

/// The App as the boards build it, with simulated peripherals: the sensor readings come
/// over the tether, the DVL on its own UART ([`DvlWire`]), the health inputs (the
/// power-sense module's ADC, the leak probe's GPIO, the enclosure's sensor) on
/// [`HealthWire`].
pub type SimApp = App<
    SimPwm,
    SimSerial,
    SimClock,
    WithHealth<WithDvl<NoSensors, DvlWire>, HealthWire, HealthWire, HealthWire>,
>;

/// The firmware library in process, as a byte port.
pub struct InProcessFirmware {
    app: SimApp,
    dvl_wire: DvlWire,
    /// The simulated battery and health events, written into the App's health inputs
    /// after each pass at the App's time.
    electrics: VehicleElectrics,
}

impl InProcessFirmware {
    /// Boot the App (lock-step, the Observer's controller); it sends its `Hello` at once.
    pub fn new() -> Result<Self> {
        Self::with_config(Config::lockstep(Board::Host))
    }

    /// Boot the App with `config`: `Config::fixed_rate` makes a vehicle that runs on the
    /// host's clock, as a board does, driven by [`Self::pass`].
    pub fn with_config(config: Config) -> Result<Self> {
        Self::with_health(config, &BatterySpec::default(), &HealthSpec::default())
    }

    /// Boot the App (lock-step) with the scenario's battery and health (`[battery]`,
    /// `[health]`): its health parameters as stored on the vehicle, its health inputs fed by
    /// the simulated battery and events.
    pub fn for_scenario(sc: &RunSetup) -> Result<Self> {
        Self::with_health(Config::lockstep(Board::Host), &sc.battery, &sc.health)
    }

    /// Boot the App with `config`, a simulated `battery` and the `health` events and
    /// parameters.
    pub fn with_health(config: Config, battery: &BatterySpec, health: &HealthSpec) -> Result<Self> {
        let vehicle = Vehicle::observer();
        let params = health.params(battery)?;
        let electrics = VehicleElectrics::new(
            *battery,
            health.events()?,
            params,
            PwmMap::for_vehicle(&vehicle),
            f64::from(vehicle.params().thrust_max_forward_n),
        );
        let controller =
            Controller::new(vehicle, Gains::default()).map_err(|e| anyhow!("controller: {e}"))?;
        let dvl_wire = DvlWire::default();
        // The in-memory line takes no time per byte.
        let dvl = WithDvl {
            inner: NoSensors,
            dvl: DvlPort::new(dvl_wire.clone(), VelocityGate::default(), 0),
        };
        let wire = electrics.wire();
        let sensors = WithHealth::new(dvl, wire.clone(), Some(wire.clone()), wire);
        let mut app = App::with_sensors(
            [SimPwm::default(), SimPwm::default(), SimPwm::default()],
            SimSerial::default(),
            SimClock(Instant::now()),
            controller,
            config,
            sensors,
        )
        .map_err(|e| anyhow!("firmware config: {e}"))?;
        app.set_health_params(&params)
            .map_err(|r| anyhow!("the firmware refused the health parameters: {r:?}"))?;
        app.hello();
        Ok(Self {
            app,
            dvl_wire,
            electrics,
        })
    }

    /// The simulated battery and health inputs (the truth the vehicle measures).
    pub fn electrics(&self) -> &VehicleElectrics {
        &self.electrics
    }

    /// One pass of the App's main loop, then the battery advanced to the App's time with
    /// the pulses it commands.
    fn tick(&mut self) {
        self.app.tick();
        let t_us = self.app.now_us();
        let pulses = self.app.last_output().pulse_us;
        self.electrics.advance(t_us, pulses);
    }

    /// The line into the App's DVL port (a clone: what is sent on it, the App reads).
    pub fn dvl_wire(&self) -> DvlWire {
        self.dvl_wire.clone()
    }

    /// One pass of the App's main loop (a fixed-rate App steps when its period is due on
    /// the host's clock): `received` goes in first; what it sent comes back.
    pub fn pass(&mut self, received: &[u8]) -> Vec<u8> {
        self.app.parts_mut().1.rx.extend(received);
        self.tick();
        self.app.parts_mut().1.tx.drain(..).collect()
    }

    /// The App (read-only), e.g. for its state machine.
    pub fn app(&self) -> &SimApp {
        &self.app
    }
}

impl std::io::Write for InProcessFirmware {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.app.parts_mut().1.rx.extend(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Read for InProcessFirmware {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        // One pass of the main loop per read while bytes wait (a tick reads a bounded number).
        while self.app.parts_mut().1.tx.is_empty() && !self.app.parts_mut().1.rx.is_empty() {
            self.tick();
        }
        let tx = &mut self.app.parts_mut().1.tx;
        let n = buf.len().min(tx.len());
        for (b, x) in buf.iter_mut().zip(tx.drain(..n)) {
            *b = x;
        }
        Ok(n)
    }
}
