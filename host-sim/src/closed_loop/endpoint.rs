//! The controller end of the loop ([`ControllerEndpoint`]) and the core in process
//! ([`CoreEndpoint`]).

use anyhow::{anyhow, Result};
use controller_core::alloc::PwmMap;
use controller_core::controller::{ControlMode, Controller, Gains};
use controller_core::reference::RefSample;
use controller_core::state::{BodyForces, NavState, TrackingErrors};
use protocol::{fault, Telemetry};
use sim_scenario::setup::RunSetup;
use sim_world::sensors::Measurement;

/// What the controller end answered for one control tick.
#[derive(Debug, Clone, Copy, Default)]
pub struct StepReply {
    /// Forces the law asked for.
    pub requested: BodyForces,
    /// Forces the allocated thrusts make.
    pub achieved: BodyForces,
    /// Thruster commands `[F1x, F2x, F3z]` (N).
    pub thrust_cmd_n: [f32; 3],
    /// Thrust the plant gets over the next period (N): the commands, or the thrust of the
    /// pulse widths the ESCs see.
    pub applied_n: [f64; 3],
    /// Pulse widths of the three outputs (us).
    pub pulse_us: [f64; 3],
    /// The law's tracking errors.
    pub errors: TrackingErrors,
    /// The allocation clamped the request.
    pub saturated: bool,
    /// The state the controller estimated itself (an on-board estimator), with the standard
    /// deviation of its position; the loop then logs and scores it instead of the stage's.
    pub estimate: Option<(NavState, [f64; 3])>,
}

impl StepReply {
    /// A firmware's answer from its step's telemetry: `applied_n` the thrust the plant gets;
    /// `position_std_m` with an on-board estimator (its estimate is then the telemetry's).
    pub fn from_telemetry(
        tel: &Telemetry,
        applied_n: [f64; 3],
        position_std_m: Option<[f64; 3]>,
    ) -> Self {
        StepReply {
            requested: tel.requested,
            achieved: tel.achieved,
            thrust_cmd_n: tel.thrust_n,
            applied_n,
            pulse_us: tel.pulse_us.map(f64::from),
            errors: tel.errors,
            saturated: tel.faults & fault::SATURATED != 0,
            estimate: position_std_m.map(|s| (tel.nav, s)),
        }
    }
}

/// The controller end of the loop: the core in process, the firmware library's `App` in
/// process, or the firmware over the tether.
pub trait ControllerEndpoint {
    /// Before the first step, with the first navigation state (set-up: mode, reference, arm).
    fn start(&mut self, _nav0: &NavState) -> Result<()> {
        Ok(())
    }
    /// One control step at `t_s` on `nav`; `reference` is the loop's sample of the scenario's
    /// reference at `t_s` (a firmware samples its own).
    fn step(&mut self, t_s: f64, nav: &NavState, reference: &RefSample) -> Result<StepReply>;
    /// The simulated time at which the endpoint's reference began (s): 0 unless the
    /// endpoint started it later (a firmware that took its mode only once its estimate was
    /// ready, or after a compass calibration turn, flies the reference from then on). The
    /// loop samples the scenario's reference at `t - reference_start_s()`.
    fn reference_start_s(&self) -> f64 {
        0.0
    }
    /// The USBL fixes the endpoint's own estimator refused on its gate, when it has one
    /// that counts them (the summary's `navigation.usbl_fixes_rejected`).
    fn usbl_fixes_rejected(&self) -> Option<u64> {
        None
    }
    /// Before the step: measurements for the endpoint's own estimator.
    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        if measurements.is_empty() {
            Ok(())
        } else {
            Err(anyhow!(
                "this controller endpoint has no on-board estimator"
            ))
        }
    }
}

/// The core's [`Controller`] in process, stepped at the control period.
pub struct CoreEndpoint {
    controller: Controller,
    mode: ControlMode,
    period_s: f32,
    pwm: PwmMap,
}

impl CoreEndpoint {
    /// The controller of a scenario: its vehicle and default gains, with unlimited
    /// thrusters when the scenario says `saturate = false` (the paper's setting; the
    /// set-up's [`RunSetup::controller_vehicle`]).
    pub fn for_scenario(sc: &RunSetup) -> Result<Self> {
        if sc.calibration.is_some() {
            return Err(anyhow!(
                "scenario {}: the compass calibration turn ([calibration]) is flown by the \
                 firmware: run it with `host-sim hil` (e.g. --in-process)",
                sc.name
            ));
        }
        if sc.identification.is_some() {
            return Err(anyhow!(
                "scenario {}: the identification manoeuvre ([identification]) is flown by the \
                 firmware: run it with `host-sim hil` (e.g. --in-process)",
                sc.name
            ));
        }
        let mut controller = Controller::new(
            *sc.controller_vehicle(),
            Gains::for_vehicle(sc.controller_vehicle()),
        )
        .map_err(|e| anyhow!("controller gains: {e}"))?;
        if sc.disturbance.delay_known {
            controller
                .set_measurement_delay_s(sc.disturbance.delay_s as f32)
                .map_err(|e| anyhow!("disturbance.delay_s: {e}"))?;
        }
        Ok(Self {
            controller,
            mode: sc.mode(),
            period_s: {
                let (n, dt) = sc.plant_steps();
                (dt * n as f64) as f32
            },
            pwm: PwmMap::for_vehicle(sc.vehicle()),
        })
    }
}

impl CoreEndpoint {
    /// The controller (its laws' state for logs and tests).
    pub fn controller(&self) -> &Controller {
        &self.controller
    }
}

impl ControllerEndpoint for CoreEndpoint {
    fn step(&mut self, _t_s: f64, nav: &NavState, reference: &RefSample) -> Result<StepReply> {
        let out = self
            .controller
            .step(self.mode, nav, reference, self.period_s);
        let cmd = out.allocation.thrust_n;
        Ok(StepReply {
            requested: out.requested,
            achieved: out.allocation.achieved,
            thrust_cmd_n: cmd,
            applied_n: cmd.map(f64::from),
            // The real map (clamped), also when the controller's thrusters are unlimited.
            pulse_us: cmd.map(|f| f64::from(self.pwm.pulse_us(f))),
            errors: out.errors,
            saturated: out.allocation.saturated,
            estimate: None,
        })
    }
}

/// A borrowed endpoint is one (`run_closed_loop`).
impl<T: ControllerEndpoint + ?Sized> ControllerEndpoint for &mut T {
    fn start(&mut self, nav0: &NavState) -> Result<()> {
        (**self).start(nav0)
    }
    fn step(&mut self, t_s: f64, nav: &NavState, reference: &RefSample) -> Result<StepReply> {
        (**self).step(t_s, nav, reference)
    }
    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        (**self).forward(measurements)
    }
    fn reference_start_s(&self) -> f64 {
        (**self).reference_start_s()
    }
    fn usbl_fixes_rejected(&self) -> Option<u64> {
        (**self).usbl_fixes_rejected()
    }
}
