//! The three PWM outputs written from the thrusters' pulse widths.

use super::duty::set_duties;
use super::{App, Monotonic};
use crate::protocol::fault;
use crate::sensors::Sensors;
use embedded_hal::pwm::SetDutyCycle;
use embedded_io::{Read, ReadReady, Write, WriteReady};

impl<P, S, C, N> App<P, S, C, N>
where
    P: SetDutyCycle,
    S: Read + ReadReady + Write + WriteReady,
    C: Monotonic,
    N: Sensors,
{
    pub(super) fn write_pwm(&mut self, pulse_us: [f32; 3]) {
        let map = *self.autopilot.controller().pwm_map();
        let period = self.config.pwm_period_us();
        let (duty, ok) = set_duties(&mut self.pwm, &map, period, pulse_us);
        if !ok {
            self.io_faults |= fault::PWM_ERROR;
        }
        self.duty = duty;
    }
}
