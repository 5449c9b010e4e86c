//! What a step puts on the thrusters: neutral, a law's output, or forces asked for outside the
//! laws (the pilot's `Manual` thrust, the calibration turn), allocated and mapped to pulses.

use super::{Autopilot, StepOutput};
use crate::protocol::{fault, ManualThrust};
use controller_core::alloc::{allocate, ESC_NEUTRAL_US};
use controller_core::controller::ControlOutput;
use controller_core::state::{BodyForces, TrackingErrors};

impl Autopilot {
    /// Neutral output with the given faults.
    pub fn neutral(&self, faults: u16) -> StepOutput {
        StepOutput {
            pulse_us: [ESC_NEUTRAL_US; 3],
            faults,
            ..StepOutput::default()
        }
    }

    pub(super) fn law_output(&self, law: &ControlOutput, faults: u16) -> StepOutput {
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
    pub(super) fn forces_output(
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

    pub(super) fn manual_output(&self, m: &ManualThrust, faults: u16) -> StepOutput {
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
