//! Where the health inputs come from: the power-sense module's two ADC pins
//! ([`PowerSense`]), the leak probe on a GPIO (`embedded_hal::digital::InputPin`, high when
//! wet as Blue Robotics' SOS probe), and the enclosure's pressure and temperature
//! ([`EnclosureSense`]). embedded-hal 1.0 has no ADC trait, so the board implements
//! [`PowerSense`] over its own ADC. [`WithHealth`] adds them to any [`Sensors`].

use crate::protocol::HealthSample;
use crate::sensors::Sensors;
use controller_core::nav::{DvlFix, ImuSample};
use embedded_hal::digital::InputPin;

/// The power-sense module's analogue outputs.
pub trait PowerSense {
    /// The voltages on its voltage pin and on its current pin now, V (`None`: a pin not
    /// wired or the conversion failed).
    fn read_pins(&mut self) -> (Option<f32>, Option<f32>);
}

/// The enclosure's own pressure and temperature sensor.
pub trait EnclosureSense {
    /// Pressure (Pa) and temperature (degrees C) now; `None` when not available.
    fn read(&mut self) -> (Option<f32>, Option<f32>);
}

/// No enclosure sensor.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoEnclosure;

impl EnclosureSense for NoEnclosure {
    fn read(&mut self) -> (Option<f32>, Option<f32>) {
        (None, None)
    }
}

/// The health inputs added to other sensors: every other reading is the inner sensors'.
pub struct WithHealth<N, B, L, E = NoEnclosure> {
    /// The other sensors.
    pub inner: N,
    /// The power-sense module.
    pub power: B,
    /// The leak probe (`LEAK1_PIN`), if fitted.
    pub leak: Option<L>,
    /// The enclosure's sensor.
    pub enclosure: E,
    /// Leak pin reads that failed (counted as dry).
    pub leak_read_errors: u32,
}

impl<N, B, L, E> WithHealth<N, B, L, E> {
    /// The health inputs around `inner`.
    pub fn new(inner: N, power: B, leak: Option<L>, enclosure: E) -> Self {
        Self {
            inner,
            power,
            leak,
            enclosure,
            leak_read_errors: 0,
        }
    }
}

impl<N, B, L, E> Sensors for WithHealth<N, B, L, E>
where
    N: Sensors,
    B: PowerSense,
    L: InputPin,
    E: EnclosureSense,
{
    fn imu(&mut self, now_us: u64) -> Option<ImuSample> {
        self.inner.imu(now_us)
    }

    fn pressure_pa(&mut self, now_us: u64) -> Option<f32> {
        self.inner.pressure_pa(now_us)
    }

    fn dvl(&mut self, now_us: u64) -> Option<DvlFix> {
        self.inner.dvl(now_us)
    }

    fn health(&mut self, _now_us: u64) -> Option<HealthSample> {
        let (volt_pin_v, curr_pin_v) = self.power.read_pins();
        let leak_wet = match self.leak.as_mut().map(|p| p.is_high()) {
            Some(Ok(wet)) => wet,
            Some(Err(_)) => {
                self.leak_read_errors = self.leak_read_errors.wrapping_add(1);
                false
            }
            None => false,
        };
        let (enclosure_pa, enclosure_c) = self.enclosure.read();
        Some(HealthSample {
            volt_pin_v,
            curr_pin_v,
            leak_wet,
            enclosure_pa,
            enclosure_c,
            depth_m: None,
        })
    }

    fn own_sensors(&self) -> bool {
        self.inner.own_sensors()
    }

    fn faults(&self) -> u16 {
        self.inner.faults()
    }
}
