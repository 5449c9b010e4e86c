//! The served vehicle's controller end with the firmware's `qemu` image: the image in QEMU
//! `netduinoplus2` (found or built as `host-sim hil` does), its tether USART the surface's
//! byte stream through the [`TetherBridge`], beside the HIL sensor exchange.
//!
//! The image is the lock-step build: its clock is the time stamps it takes and its control
//! step runs on a `Step` (or a `Nav`), so the served loop is its clock. Each control tick at
//! `t` (whole control periods): the vehicle's own inputs of the tick (the IMU, pressure,
//! compass, DVL and USBL readings of an estimator scenario, as `host-sim hil` sends them),
//! then the surface's bytes, then `Step { t }` (with `[navigation] source = "truth"`:
//! `Nav { t, true state }`), all in one session; the image's answers are read until the
//! `Telemetry` of that step, whose pulse widths the plant gets for the period.
//!
//! The session: the bridge renumbers, as for the App in process. The image has one session
//! in force, so the surface's frames and the vehicle's inputs share it; the surface keeps its
//! numbers (its answers are renumbered back) and the vehicle's inputs get the bridge's own.
//! The alternative, the surface's session as the only one (the served side sending the
//! vehicle's inputs under the surface's session and numbers), would need the served side to
//! read and rewrite every later surface number, which is what the bridge does anyway. For a
//! lock-step image the bridge also stamps the surface's heartbeats with the vehicle's time
//! and passes the image's telemetry at a board's 100 ms.

use super::bridge::TetherBridge;
use super::endpoint::{Believed, ServedEndpoint};
use crate::closed_loop::estimator_nav::onboard_config;
use crate::closed_loop::{ControllerEndpoint, StepReply};
use crate::tether::measurement::command_of;
use crate::tether::qemu::{start_qemu_serials, QemuChild};
use anyhow::{anyhow, bail, Context, Result};
use controller_core::alloc::PwmMap;
use controller_core::nav::onboard::OnboardConfig;
use controller_core::reference::RefSample;
use controller_core::state::NavState;
use firmware::protocol::{Command, Decoded, FrameDecoder, NavSample, Reply, Telemetry};
use sim_scenario::setup::RunSetup;
use sim_world::clock::us;
use sim_world::sensors::{Measurement, NavSource};
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

/// The longest wait for the image's `Hello` after QEMU starts.
const HELLO_WAIT: Duration = Duration::from_secs(30);

/// The longest wait for the image's answer to a step (an emulator starved by a loaded
/// machine is slow, not lost; one that does not answer in this long is hung).
const STEP_WAIT: Duration = Duration::from_secs(10);

/// A board's telemetry period (us): the image's telemetry reaches the surface this often.
const TELEMETRY_PERIOD_US: u64 = 100_000;

/// The image in QEMU as the served loop's controller end.
pub struct ServedImage {
    /// The image's tether USART (USART1), blocking reads with a short time-out. Declared
    /// before the child, so it closes first.
    stream: TcpStream,
    _qemu: QemuChild,
    replies: FrameDecoder<Reply>,
    bridge: TetherBridge,
    period_us: u64,
    ticks: u64,
    /// The true state as `Nav` (truth scenarios); else `Step` on the on-board estimate.
    truth_nav: bool,
    start_nav: bool,
    vehicle: controller_core::params::VehicleParams,
    onboard: OnboardConfig,
    pwm: PwmMap,
    /// The vehicle's inputs for the next tick.
    own: Vec<Command>,
    /// The image's latest step.
    latest: Telemetry,
    surface_in: Vec<u8>,
    surface_out: Vec<u8>,
}

impl ServedImage {
    /// Boot `elf` in `qemu` (its output to `log`), wait for its `Hello`; a fixed-rate image
    /// is refused (the served loop is the lock-step image's clock).
    pub fn start(
        sc: &RunSetup,
        elf: &Path,
        qemu: &str,
        log: Option<&Path>,
        start_nav: bool,
    ) -> Result<Self> {
        let (child, mut streams) = start_qemu_serials(qemu, elf, 1, log, Duration::from_millis(20))
            .context("starting the emulated board")?;
        let stream = streams
            .pop()
            .ok_or_else(|| anyhow!("the emulated board's USART1 did not connect"))?;
        let mut me = Self {
            stream,
            _qemu: child,
            replies: FrameDecoder::new(),
            bridge: TetherBridge::new(),
            period_us: us(sc.control_period_s),
            ticks: 0,
            truth_nav: sc.navigation.source == NavSource::Truth,
            start_nav: start_nav && sc.navigation.source == NavSource::Estimator,
            vehicle: sc.vehicle_params,
            onboard: onboard_config(sc),
            pwm: PwmMap::for_vehicle(sc.vehicle()),
            own: Vec::new(),
            latest: Telemetry::default(),
            surface_in: Vec::new(),
            surface_out: Vec::new(),
        };
        me.bridge.set_telemetry_period(TELEMETRY_PERIOD_US);
        let mut lockstep = None;
        me.read_until(HELLO_WAIT, "Hello", |r| {
            if let Reply::Hello { lockstep: l, .. } = r {
                lockstep = Some(*l);
            }
            lockstep.is_some()
        })?;
        if lockstep != Some(true) {
            bail!(
                "{} runs fixed-rate: the served loop steps the lock-step image (the `qemu` \
                 binary) on the simulated clock",
                elf.display()
            );
        }
        Ok(me)
    }

    /// The bridge (its counters).
    pub fn bridge(&self) -> &TetherBridge {
        &self.bridge
    }

    /// Write `bytes` to the image.
    fn write(&mut self, bytes: &[u8]) -> Result<()> {
        if bytes.is_empty() {
            return Ok(());
        }
        self.stream
            .write_all(bytes)
            .context("writing to the emulated board (QEMU exited?)")
    }

    /// Read the image's bytes (each reply to `seen`, all of them through the bridge to the
    /// surface) until `seen` says done; an error after `wait` without.
    fn read_until(
        &mut self,
        wait: Duration,
        what: &str,
        mut seen: impl FnMut(&Reply) -> bool,
    ) -> Result<()> {
        let deadline = Instant::now() + wait;
        let mut buf = [0u8; 1024];
        let mut done = false;
        while !done {
            let n = match self.stream.read(&mut buf) {
                Ok(0) => bail!("the emulated board closed its tether (QEMU exited)"),
                Ok(n) => n,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    if Instant::now() > deadline {
                        bail!(
                            "no {what} from the emulated board within {} s",
                            wait.as_secs()
                        );
                    }
                    continue;
                }
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) => return Err(e).context("reading the emulated board's tether"),
            };
            let bytes = buf.get(..n).unwrap_or_default();
            for &b in bytes {
                if let Some(Decoded::Frame { msg, .. }) = self.replies.push(b) {
                    done |= seen(&msg);
                }
            }
            let out = self.bridge.from_app(bytes)?;
            self.surface_out.extend(out);
        }
        Ok(())
    }

    /// The vehicle's inputs, the surface's bytes, the step at `t_us`; its telemetry.
    fn exchange(&mut self, t_us: u64, step: Command) -> Result<Telemetry> {
        self.bridge.set_vehicle_time(t_us);
        let own = std::mem::take(&mut self.own);
        let bytes = self.bridge.own_inputs(&own)?;
        self.write(&bytes)?;
        if self.bridge.opening() {
            // The bridge's session: its answer passes through the bridge, which then sends
            // the inputs it held.
            let mut answered = false;
            self.read_until(STEP_WAIT, "session", |r| {
                answered |= matches!(r, Reply::Session { .. });
                answered
            })?;
            let held = self.bridge.held()?;
            self.write(&held)?;
        }
        let from_surface = std::mem::take(&mut self.surface_in);
        let bytes = self.bridge.from_surface(&from_surface)?;
        self.write(&bytes)?;
        if let Some(open) = self.bridge.surface_opening() {
            // The surface opens a session: the step goes in it, once it is in force.
            self.read_until(STEP_WAIT, "session", |r| match *r {
                Reply::Session { .. } => true,
                Reply::Nack { seq, .. } => seq == open,
                _ => false,
            })?;
        }
        let (seq, bytes) = self
            .bridge
            .own_frame(&step)?
            .ok_or_else(|| anyhow!("no session in force on the emulated board"))?;
        self.write(&bytes)?;
        let mut answer = None;
        self.read_until(STEP_WAIT, "Telemetry", |r| {
            match *r {
                Reply::Telemetry(t) if t.nav_seq == seq => answer = Some(Ok(t)),
                Reply::Nack { seq: s, reason } if s == seq => {
                    answer = Some(Err(format!("{reason:?}")))
                }
                _ => {}
            }
            answer.is_some()
        })?;
        match answer {
            Some(Ok(t)) => Ok(t),
            Some(Err(why)) => bail!(
                "the emulated board refused the step at t = {:.3} s: {why}",
                t_us as f64 * 1e-6
            ),
            None => bail!(
                "no Telemetry for the step at t = {:.3} s",
                t_us as f64 * 1e-6
            ),
        }
    }
}

impl ControllerEndpoint for ServedImage {
    /// At time 0: the vehicle's own description, with `start_nav` its estimator started at
    /// the launch point (sent at the first tick).
    fn start(&mut self, nav0: &NavState) -> Result<()> {
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
        let t_us = self.ticks * self.period_us;
        self.ticks += 1;
        let step = if self.truth_nav {
            Command::Nav(NavSample { t_us, state: *nav })
        } else {
            Command::Step { t_us }
        };
        let tel = self.exchange(t_us, step)?;
        self.latest = tel;
        let applied = tel
            .pulse_us
            .map(|p| f64::from(self.pwm.thrust_n(f32::from(p))));
        let std_m = (!self.truth_nav).then(|| tel.nav_pos_std_m.map(f64::from));
        Ok(StepReply::from_telemetry(&tel, applied, std_m))
    }

    /// The estimator's readings as the commands `host-sim hil` sends the image (a depth as
    /// the pressure the sensor reads), for the next tick; none with the true state.
    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        if self.truth_nav {
            return Ok(());
        }
        for m in measurements {
            self.own.push(command_of(m, &self.onboard.pressure));
        }
        Ok(())
    }
}

impl ServedEndpoint for ServedImage {
    fn describe(&self) -> String {
        "firmware image in QEMU netduinoplus2, lock-step on the simulated clock".into()
    }

    fn surface_sent(&mut self, bytes: &[u8]) {
        self.surface_in.extend_from_slice(bytes);
    }

    fn take_surface_out(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.surface_out)
    }

    fn believed(&self) -> Believed {
        Believed {
            nav: self.latest.nav,
            armed: self.latest.armed,
            mode: Believed::mode_name(&self.latest.mode),
            shown: self.bridge.shown(),
        }
    }

    fn own_refused(&self) -> u64 {
        self.bridge.own_refused
    }
}
