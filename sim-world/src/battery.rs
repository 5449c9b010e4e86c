//! The vehicle's electrical side as the simulation sees it: a battery (capacity, open-circuit
//! voltage by state of charge, internal resistance, so the voltage sags under the thrusters'
//! power), the power-sense module's two ADC pins, the leak probe and the enclosure's pressure
//! and temperature. The `[battery]` table of a scenario:
//!
//! ```toml
//! [battery]
//! capacity_mah = 18000.0        # full charge
//! initial_pct = 100.0           # charge at the start
//! cells = 4                     # lithium-ion cells in series: 4.2 V full, 3.0 V empty at rest
//! internal_resistance_ohm = 0.05
//! hotel_w = 15.0                # electronics, lights, camera
//! thruster_full_power_w = 150.0 # one thruster's electrical power at its largest thrust
//! ```
//!
//! A thruster's electrical power is `thruster_full_power_w * (|T| / T_max)^1.5` (momentum
//! theory: power grows as thrust to the 3/2). The battery's current solves
//! `P = (V_oc - I R) I`; its terminal voltage is `V_oc - I R`. The open-circuit voltage
//! follows a lithium-ion cell's rest curve ([`CELL_OCV`]); the charge is counted in mAh, and
//! when it is gone the open-circuit voltage is the empty one.
//!
//! [`HealthWire`] is what the firmware's health inputs read (the `PowerSense`, leak
//! `InputPin` and `EnclosureSense` of `firmware::health::sensing`); [`VehicleElectrics`]
//! writes it each step from the battery and the scenario's events (a leak at a time, an
//! enclosure pressure rise).

use crate::checks::{fin, pos};
use anyhow::{bail, Result};
use controller_core::alloc::PwmMap;
use firmware::health::{EnclosureSense, HealthSample, PowerSense};
use firmware::protocol::HealthParams;
use serde::{Deserialize, Serialize};
use std::convert::Infallible;
use std::sync::{Arc, Mutex, MutexGuard};

/// Full-scale voltage of the simulated ADC (the STM32F4's 3.3 V reference), V.
pub const ADC_FULL_SCALE_V: f64 = 3.3;
/// Counts of the simulated 12-bit ADC.
pub const ADC_COUNTS: f64 = 4096.0;
/// Open-circuit voltage of one lithium-ion cell by state of charge, `(SoC, V)` every 10 %
/// (a typical NMC 18650's rest curve: steep at both ends, flat between).
pub const CELL_OCV: [(f64, f64); 12] = [
    (0.00, 3.00),
    (0.05, 3.30),
    (0.10, 3.45),
    (0.20, 3.55),
    (0.30, 3.62),
    (0.40, 3.68),
    (0.50, 3.74),
    (0.60, 3.80),
    (0.70, 3.88),
    (0.80, 3.96),
    (0.90, 4.06),
    (1.00, 4.20),
];

/// One cell's open-circuit voltage at state of charge `soc` (0-1), interpolated linearly in
/// [`CELL_OCV`].
pub fn cell_ocv_v(soc: f64) -> f64 {
    let soc = soc.clamp(0.0, 1.0);
    CELL_OCV
        .windows(2)
        .find(|w| soc <= w[1].0)
        .map_or(CELL_OCV[CELL_OCV.len() - 1].1, |w| {
            let ((s0, v0), (s1, v1)) = (w[0], w[1]);
            v0 + (v1 - v0) * (soc - s0) / (s1 - s0)
        })
}
/// Atmospheric pressure inside a sealed enclosure, Pa.
pub const ENCLOSURE_START_PA: f64 = 101_325.0;

/// `[battery]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BatterySpec {
    /// Full charge, mAh.
    pub capacity_mah: f64,
    /// Charge at the start, % of the capacity.
    pub initial_pct: f64,
    /// Cells in series.
    pub cells: u8,
    /// Internal resistance of the pack, ohm.
    pub internal_resistance_ohm: f64,
    /// Constant load of the electronics, W.
    pub hotel_w: f64,
    /// One thruster's electrical power at its largest thrust, W.
    pub thruster_full_power_w: f64,
}

impl Default for BatterySpec {
    /// An 18 Ah 4S pack (Blue Robotics' lithium-ion battery), 50 milliohm, 15 W of
    /// electronics, 150 W per thruster at full thrust.
    fn default() -> Self {
        Self {
            capacity_mah: 18_000.0,
            initial_pct: 100.0,
            cells: 4,
            internal_resistance_ohm: 0.05,
            hotel_w: 15.0,
            thruster_full_power_w: 150.0,
        }
    }
}

impl BatterySpec {
    /// Every value finite and in range.
    pub fn check(&self) -> Result<()> {
        pos("battery.capacity_mah", self.capacity_mah)?;
        fin("battery.initial_pct", self.initial_pct)?;
        if !(0.0..=100.0).contains(&self.initial_pct) {
            bail!("battery.initial_pct = {} must be 0-100", self.initial_pct);
        }
        if !(1..=14).contains(&self.cells) {
            bail!("battery.cells = {} must be 1-14", self.cells);
        }
        for (name, v) in [
            (
                "battery.internal_resistance_ohm",
                self.internal_resistance_ohm,
            ),
            ("battery.hotel_w", self.hotel_w),
            ("battery.thruster_full_power_w", self.thruster_full_power_w),
        ] {
            fin(name, v)?;
            if v < 0.0 {
                bail!("{name} = {v} must not be negative");
            }
        }
        Ok(())
    }
}

/// The battery's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Battery {
    spec: BatterySpec,
    used_mah: f64,
    voltage_v: f64,
    current_a: f64,
}

impl Battery {
    /// A battery at its initial charge, at rest.
    pub fn new(spec: BatterySpec) -> Self {
        let mut b = Self {
            spec,
            used_mah: spec.capacity_mah * (1.0 - spec.initial_pct / 100.0),
            voltage_v: 0.0,
            current_a: 0.0,
        };
        b.voltage_v = b.open_circuit_v();
        b
    }

    /// Charge left, mAh.
    pub fn left_mah(&self) -> f64 {
        (self.spec.capacity_mah - self.used_mah).max(0.0)
    }

    /// Charge used since full, mAh.
    pub fn used_mah(&self) -> f64 {
        self.used_mah
    }

    /// Open-circuit voltage at the present charge ([`cell_ocv_v`] per cell), V.
    pub fn open_circuit_v(&self) -> f64 {
        let soc = self.left_mah() / self.spec.capacity_mah;
        f64::from(self.spec.cells) * cell_ocv_v(soc)
    }

    /// Terminal voltage of the latest step, V.
    pub fn voltage_v(&self) -> f64 {
        self.voltage_v
    }

    /// Current of the latest step, A.
    pub fn current_a(&self) -> f64 {
        self.current_a
    }

    /// Deliver `power_w` for `dt_s`: the current from `P = (V_oc - I R) I` (the smaller
    /// root; past the pack's largest power, the current at that largest power), the sag, the
    /// charge.
    pub fn step(&mut self, power_w: f64, dt_s: f64) {
        let v_oc = self.open_circuit_v();
        let r = self.spec.internal_resistance_ohm;
        let p = power_w.max(0.0);
        let i = if r > 0.0 {
            let disc = (v_oc * v_oc - 4.0 * r * p).max(0.0);
            (v_oc - disc.sqrt()) / (2.0 * r)
        } else {
            p / v_oc
        };
        self.current_a = i;
        self.voltage_v = v_oc - i * r;
        self.used_mah += i * dt_s.max(0.0) * (1000.0 / 3600.0);
    }
}

/// What the firmware's health inputs read now.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HealthPins {
    /// The power-sense module's voltage pin, V.
    pub volt_pin_v: f64,
    /// Its current pin, V.
    pub curr_pin_v: f64,
    /// The leak probe is wet.
    pub leak_wet: bool,
    /// Enclosure pressure, Pa.
    pub enclosure_pa: f64,
    /// Enclosure temperature, degrees C.
    pub enclosure_c: f64,
}

/// The simulated health inputs, shared by the simulation (which writes them) and the
/// firmware's sensors (which read them); clones are the same wires.
#[derive(Debug, Clone, Default)]
pub struct HealthWire(Arc<Mutex<HealthPins>>);

impl HealthWire {
    fn pins(&self) -> MutexGuard<'_, HealthPins> {
        // A panic elsewhere while holding the lock leaves whole values behind: still usable.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// The inputs now.
    pub fn get(&self) -> HealthPins {
        *self.pins()
    }

    /// Set the inputs.
    pub fn set(&self, p: HealthPins) {
        *self.pins() = p;
    }

    /// Everything read as the firmware's health inputs read it (the ADC's conversions), for
    /// a vehicle whose sensors are not a `WithHealth`.
    pub fn sample(&mut self) -> HealthSample {
        let (volt_pin_v, curr_pin_v) = self.read_pins();
        let (enclosure_pa, enclosure_c) = EnclosureSense::read(self);
        HealthSample {
            volt_pin_v,
            curr_pin_v,
            leak_wet: self.get().leak_wet,
            enclosure_pa,
            enclosure_c,
            depth_m: None,
        }
    }
}

/// A 12-bit conversion of `v` on the simulated ADC.
fn adc(v: f64) -> f32 {
    let lsb = ADC_FULL_SCALE_V / ADC_COUNTS;
    ((v.clamp(0.0, ADC_FULL_SCALE_V) / lsb).round() * lsb) as f32
}

impl PowerSense for HealthWire {
    fn read_pins(&mut self) -> (Option<f32>, Option<f32>) {
        let p = self.get();
        (Some(adc(p.volt_pin_v)), Some(adc(p.curr_pin_v)))
    }
}

impl embedded_hal::digital::ErrorType for HealthWire {
    type Error = Infallible;
}

impl embedded_hal::digital::InputPin for HealthWire {
    /// The leak probe: high when wet.
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.get().leak_wet)
    }

    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(!self.get().leak_wet)
    }
}

impl EnclosureSense for HealthWire {
    fn read(&mut self) -> (Option<f32>, Option<f32>) {
        let p = self.get();
        (Some(p.enclosure_pa as f32), Some(p.enclosure_c as f32))
    }
}

/// The scenario's health events.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HealthEvents {
    /// The leak probe is wet from this simulated time on, s.
    pub leak_at_s: Option<f64>,
    /// The enclosure's pressure starts to rise at this time, s.
    pub pressure_rise_at_s: Option<f64>,
    /// ... at this rate, Pa/s.
    pub pressure_rise_pa_s: f64,
    /// Enclosure temperature, degrees C.
    pub enclosure_c: f64,
}

/// The battery, the events and the power-sense module's scales, writing the firmware's
/// health inputs each step.
#[derive(Debug, Clone)]
pub struct VehicleElectrics {
    battery: Battery,
    spec: BatterySpec,
    events: HealthEvents,
    /// The module's scales (the vehicle's `BATT_VOLT_MULT`, `BATT_AMP_PERVLT`,
    /// `BATT_AMP_OFFSET`: the simulated module is the one the parameters describe).
    scales: HealthParams,
    pwm: PwmMap,
    max_thrust_n: f64,
    wire: HealthWire,
    last_t_us: Option<u64>,
}

impl VehicleElectrics {
    /// A battery per `spec`, events per `events`, the thrust map of the vehicle (`pwm`,
    /// `max_thrust_n`) and the power-sense module of `scales`.
    pub fn new(
        spec: BatterySpec,
        events: HealthEvents,
        scales: HealthParams,
        pwm: PwmMap,
        max_thrust_n: f64,
    ) -> Self {
        let mut e = Self {
            battery: Battery::new(spec),
            spec,
            events,
            scales,
            pwm,
            max_thrust_n: max_thrust_n.max(1e-3),
            wire: HealthWire::default(),
            last_t_us: None,
        };
        e.write(0.0);
        e
    }

    /// The wires the firmware reads (a clone).
    pub fn wire(&self) -> HealthWire {
        self.wire.clone()
    }

    /// The battery (the simulated truth).
    pub fn battery(&self) -> &Battery {
        &self.battery
    }

    /// Electrical power drawn with the ESCs at `pulses_us`, W.
    pub fn power_w(&self, pulses_us: [f32; 3]) -> f64 {
        let thrusters: f64 = pulses_us
            .iter()
            .map(|&p| {
                let t = f64::from(self.pwm.thrust_n(p)).abs() / self.max_thrust_n;
                self.spec.thruster_full_power_w * t.min(1.5).powf(1.5)
            })
            .sum();
        self.spec.hotel_w + thrusters
    }

    /// Advance to `t_us` (the firmware's clock) with the ESCs at `pulses_us` since the
    /// previous call, and write the inputs the firmware reads next.
    pub fn advance(&mut self, t_us: u64, pulses_us: [f32; 3]) {
        let dt_s = self
            .last_t_us
            .map_or(0.0, |t0| t_us.saturating_sub(t0) as f64 * 1e-6);
        self.last_t_us = Some(t_us);
        if dt_s > 0.0 {
            let p = self.power_w(pulses_us);
            self.battery.step(p, dt_s);
        }
        self.write(t_us as f64 * 1e-6);
    }

    fn write(&mut self, t_s: f64) {
        let s = &self.scales;
        let ev = &self.events;
        let rise_s = ev.pressure_rise_at_s.map_or(0.0, |t0| (t_s - t0).max(0.0));
        self.wire.set(HealthPins {
            volt_pin_v: self.battery.voltage_v() / f64::from(s.batt_volt_mult),
            curr_pin_v: self.battery.current_a() / f64::from(s.batt_amp_pervlt)
                + f64::from(s.batt_amp_offset_v),
            leak_wet: ev.leak_at_s.is_some_and(|t| t_s >= t),
            enclosure_pa: ENCLOSURE_START_PA + ev.pressure_rise_pa_s * rise_s,
            enclosure_c: ev.enclosure_c,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_voltage_sags_with_the_current_and_the_charge_is_counted() {
        let spec = BatterySpec::default();
        let mut b = Battery::new(spec);
        assert!((b.voltage_v() - 16.8).abs() < 1e-9);
        b.step(336.0, 3600.0);
        // 336 W drawn through 0.05 ohm from 16.8 V at rest: I (16.8 - 0.05 I) = 336, so
        // I = (16.8 - sqrt(16.8^2 - 4 x 0.05 x 336)) / (2 x 0.05) = 21.358 A.
        let i = b.current_a();
        let expected = (16.8 - (16.8f64.powi(2) - 4.0 * 0.05 * 336.0).sqrt()) / (2.0 * 0.05);
        assert!((i - expected).abs() < 1e-3, "{i} A, expected {expected} A");
        assert!((cell_ocv_v(0.55) - 3.77).abs() < 1e-9);
        assert!((b.voltage_v() - (16.8 - i * 0.05)).abs() < 1e-9);
        assert!((b.used_mah() - i * 1000.0).abs() < 1e-6);
    }

    #[test]
    fn an_empty_battery_reads_the_empty_voltage_at_rest() {
        let spec = BatterySpec {
            initial_pct: 0.0,
            ..BatterySpec::default()
        };
        let b = Battery::new(spec);
        assert!((b.open_circuit_v() - 12.0).abs() < 1e-9);
        assert_eq!(b.left_mah(), 0.0);
    }

    #[test]
    fn a_bad_spec_is_refused() {
        for bad in [
            BatterySpec {
                capacity_mah: 0.0,
                ..BatterySpec::default()
            },
            BatterySpec {
                initial_pct: 120.0,
                ..BatterySpec::default()
            },
            BatterySpec {
                cells: 0,
                ..BatterySpec::default()
            },
            BatterySpec {
                hotel_w: f64::NAN,
                ..BatterySpec::default()
            },
        ] {
            assert!(bad.check().is_err(), "{bad:?}");
        }
    }
}
