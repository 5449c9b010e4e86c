//! The health inputs of the boards.
//!
//! The real board: the power-sense module (Blue Robotics' Power Sense Module or alike: a
//! voltage divider and a current-sense amplifier, 0-3.3 V outputs) on ADC1, its voltage
//! output on PC0 (ADC123_IN10) and its current output on PC1 (ADC123_IN11), one conversion
//! each per control step at 480 sampling cycles (ADC clock PCLK2 / 4 = 21 MHz, under the
//! F405's 36 MHz: 23 us a conversion); the pin voltages go to the health monitor, which
//! scales them with `BATT_VOLT_MULT`, `BATT_AMP_PERVLT` and `BATT_AMP_OFFSET`
//! ([`crate::health`]). The leak probe (Blue Robotics' SOS: high when wet) on PC2, an input
//! with the pull-down on, so that an unplugged probe reads dry.
//!
//! The emulated board (QEMU models no GPIO a host drives and no ADC a host sets): the host
//! sends the same readings on USART3 (PB10 / PB11, QEMU `-serial` 2), received by its
//! interrupt into a ring ([`HealthUart`]) and decoded by [`crate::health::HarnessHealth`].

use crate::health::PowerSense;
use stm32f4xx_hal::{
    adc::{
        config::{AdcConfig, Clock, SampleTime},
        Adc,
    },
    gpio::{Analog, PC0, PC1},
    pac::ADC1,
};

use super::rx_ring::interrupt_rx_ring;

/// The power-sense module on ADC1.
pub struct AdcPowerSense {
    adc: Adc<ADC1>,
    volt_pin: PC0<Analog>,
    curr_pin: PC1<Analog>,
}

impl AdcPowerSense {
    /// ADC1 (calibrated against the internal reference at start) with the two pins.
    pub fn new(
        adc1: ADC1,
        volt_pin: PC0<Analog>,
        curr_pin: PC1<Analog>,
        rcc: &mut stm32f4xx_hal::rcc::Rcc,
    ) -> Self {
        let config = AdcConfig::default()
            .clock(Clock::Pclk2_div_4)
            .default_sample_time(SampleTime::Cycles_480);
        Self {
            adc: Adc::new(adc1, true, config, rcc),
            volt_pin,
            curr_pin,
        }
    }
}

impl PowerSense for AdcPowerSense {
    fn read_pins(&mut self) -> (Option<f32>, Option<f32>) {
        let v = self.adc.convert(&self.volt_pin, SampleTime::Cycles_480);
        let i = self.adc.convert(&self.curr_pin, SampleTime::Cycles_480);
        let volts = |s: u16| f32::from(self.adc.sample_to_millivolts(s)) * 1e-3;
        (Some(volts(v)), Some(volts(i)))
    }
}

interrupt_rx_ring!(HealthUart, USART3, 256, HEALTH_RX_LOST);
