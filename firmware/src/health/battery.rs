//! The battery: voltage and current from the power-sense module's two ADC pins, the charge
//! used (mAh, integrated current), what is left (% and time at the present draw) and the
//! low / critical level, latched as in ArduPilot (a battery that recovers at rest is still
//! the one that sagged).

use super::confirm::Confirm;
use crate::protocol::{BatteryStatus, HealthParams, HealthSample};

/// Time constant of the current's low-pass filter used for the remaining time, s (the
/// thrusters' draw changes every step; the estimate follows the mean draw).
pub const CURRENT_FILTER_TAU_S: f32 = 10.0;

/// Current below which no remaining time is given (the vehicle at rest), A.
pub const CURRENT_AT_REST_A: f32 = 0.05;

/// How far the battery is run down.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, PartialOrd, Ord)]
pub enum BatteryLevel {
    /// Above both low thresholds.
    #[default]
    Normal,
    /// Under a low threshold (`BATT_LOW_VOLT` for `BATT_LOW_TIMER`, or less than
    /// `BATT_LOW_MAH` left).
    Low,
    /// Under a critical threshold.
    Critical,
}

/// The battery's figures at one check.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BatteryState {
    /// Voltage, V (0 without a voltage pin).
    pub voltage_v: f32,
    /// Current, A (0 without a current pin).
    pub current_a: f32,
    /// Current through the low-pass filter, A.
    pub current_filtered_a: f32,
    /// Charge used since boot, mAh.
    pub consumed_mah: f32,
    /// What is left, % of `BATT_CAPACITY` (0..=100).
    pub remaining_pct: f32,
    /// Time left at the filtered draw, s (None at rest or without current sensing).
    pub time_remaining_s: Option<f32>,
    /// Level (latched).
    pub level: BatteryLevel,
}

impl BatteryState {
    /// As reported in `Status`.
    pub fn status(&self) -> BatteryStatus {
        BatteryStatus {
            voltage_v: self.voltage_v,
            current_a: self.current_a,
            consumed_mah: self.consumed_mah,
            remaining_pct: self.remaining_pct,
            time_remaining_s: self.time_remaining_s.unwrap_or(0.0),
        }
    }
}

/// The battery's state between checks.
#[derive(Debug, Clone, Default)]
pub struct BatteryMonitor {
    last_us: Option<u64>,
    consumed_mah: f32,
    current_filtered_a: Option<f32>,
    voltage_filtered_v: Option<f32>,
    low_volt: Confirm,
    crt_volt: Confirm,
    level: BatteryLevel,
}

impl BatteryMonitor {
    /// Full charge assumed, nothing used.
    pub fn new() -> Self {
        Self::default()
    }

    /// Take one reading at `now_us`.
    pub fn update(&mut self, now_us: u64, s: &HealthSample, p: &HealthParams) -> BatteryState {
        let dt_s = self
            .last_us
            .map_or(0.0, |t| now_us.saturating_sub(t) as f32 * 1e-6)
            // A long gap (a stalled loop) is not integrated at the latest current.
            .min(1.0);
        self.last_us = Some(now_us);
        let finite = |v: Option<f32>| v.filter(|x| x.is_finite());
        let voltage_v = finite(s.volt_pin_v).map(|v| v * p.batt_volt_mult);
        let current_a = finite(s.curr_pin_v)
            .map(|v| (v - p.batt_amp_offset_v) * p.batt_amp_pervlt)
            .map(|a| a.max(0.0));
        let k = if dt_s > 0.0 {
            dt_s / (CURRENT_FILTER_TAU_S + dt_s)
        } else {
            0.0
        };
        let filter = |f: &mut Option<f32>, x: f32| {
            let f = f.get_or_insert(x);
            *f += k * (x - *f);
        };
        if let Some(a) = current_a {
            self.consumed_mah += a * dt_s * (1000.0 / 3600.0);
            filter(&mut self.current_filtered_a, a);
        }
        if let Some(v) = voltage_v {
            filter(&mut self.voltage_filtered_v, v);
        }
        let left_mah = (p.batt_capacity_mah - self.consumed_mah).max(0.0);
        let hold_us = (p.batt_low_timer_s * 1e6) as u64;
        let under = |v: Option<f32>, th: f32| th > 0.0 && v.is_some_and(|v| v < th);
        let low_v = self
            .low_volt
            .update(now_us, under(voltage_v, p.batt_low_volt), hold_us);
        let crt_v = self
            .crt_volt
            .update(now_us, under(voltage_v, p.batt_crt_volt), hold_us);
        let used_up = |th: f32| th > 0.0 && current_a.is_some() && left_mah < th;
        let level = if crt_v || used_up(p.batt_crt_mah) {
            BatteryLevel::Critical
        } else if low_v || used_up(p.batt_low_mah) {
            BatteryLevel::Low
        } else {
            BatteryLevel::Normal
        };
        self.level = self.level.max(level);
        let filtered = self.current_filtered_a.unwrap_or(0.0);
        // Constant power: the current rises as the voltage falls, so the time is the
        // charge left times the mean voltage to come (halfway to empty) over the power.
        let voltage_ratio = match self.voltage_filtered_v {
            Some(v) if p.batt_empty_volt > 0.0 && v > p.batt_empty_volt => {
                0.5 * (v + p.batt_empty_volt) / v
            }
            _ => 1.0,
        };
        BatteryState {
            voltage_v: voltage_v.unwrap_or(0.0),
            current_a: current_a.unwrap_or(0.0),
            current_filtered_a: filtered,
            consumed_mah: self.consumed_mah,
            remaining_pct: (100.0 * left_mah / p.batt_capacity_mah).clamp(0.0, 100.0),
            time_remaining_s: (filtered > CURRENT_AT_REST_A)
                .then(|| voltage_ratio * left_mah / filtered * (3600.0 / 1000.0)),
            level: self.level,
        }
    }
}
