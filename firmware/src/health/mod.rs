//! The vehicle's health: battery (voltage and current through a power-sense module, consumed
//! mAh, remaining % and time), leak probes, the enclosure's pressure and temperature, and the
//! depth limit. No I/O: [`HealthMonitor::update`] takes one [`HealthSample`] (read by the
//! App from its ADC and GPIO) and returns a [`HealthReport`] with the fault bits to report and
//! the failsafe action to take, once, when an event starts.
//!
//! Parameters carry ArduSub's names where ArduSub has one (`BATT_*`, `FS_LEAK_ENABLE`,
//! `FS_PRESS_MAX`, `FS_TEMP_MAX`); the depth limit (`DEPTH_LIMIT_M`) and the end of the
//! SURFACE mode (`SURFACE_END`) are this vehicle's own. `docs/health.md` has the table.

mod battery;
mod confirm;
pub mod depth_limit;
pub mod harness_inputs;
mod leak;
pub mod sensing;

pub use battery::{BatteryLevel, BatteryMonitor, BatteryState};
pub use confirm::Confirm;
pub use depth_limit::DepthLimit;
pub use harness_inputs::HarnessHealth;
pub use leak::LeakDebounce;
pub use sensing::{EnclosureSense, NoEnclosure, PowerSense, WithHealth};

use crate::protocol::{fault, NackReason};
pub use crate::protocol::{BatteryStatus, FailsafeAction, HealthParams, HealthSample, SurfaceEnd};

/// Depth at which the SURFACE mode has arrived, m.
pub const SURFACE_DONE_DEPTH_M: f32 = 0.3;

/// Time a leak probe must read wet before the leak counts (a splash or a bounce is not a
/// leak), microseconds. With the App's check at the control rate, the action starts at most
/// this plus one control period after the probe is wet (the requirement: 0.5 s).
pub const LEAK_CONFIRM_US: u64 = 200_000;

/// Time the enclosure's pressure or temperature must stay over its limit before the warning
/// (ArduSub: 2 s), microseconds.
pub const ENCLOSURE_CONFIRM_US: u64 = 2_000_000;

/// What one health check found.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HealthReport {
    /// Health fault bits ([`fault`]) holding now.
    pub faults: u16,
    /// The action to take now: set only on the check where an event starts (or worsens), so
    /// the pilot may take over afterwards, as in ArduSub.
    pub action: FailsafeAction,
    /// Battery figures.
    pub battery: BatteryState,
}

/// Every health fault bit.
pub const HEALTH_FAULTS: u16 = fault::BATTERY_LOW
    | fault::BATTERY_CRITICAL
    | fault::LEAK
    | fault::ENCLOSURE
    | fault::DEPTH_LIMIT;

/// The health checks and their state between calls.
#[derive(Debug, Clone)]
pub struct HealthMonitor {
    params: HealthParams,
    battery: BatteryMonitor,
    leak: LeakDebounce,
    press: Confirm,
    temp: Confirm,
    /// Faults of the previous check (an action fires on a new one).
    prev_faults: u16,
    latest: HealthReport,
}

impl HealthMonitor {
    /// With checked parameters.
    pub fn new(params: HealthParams) -> Result<Self, NackReason> {
        params.validate()?;
        Ok(Self {
            params,
            battery: BatteryMonitor::new(),
            leak: LeakDebounce::new(LEAK_CONFIRM_US),
            press: Confirm::default(),
            temp: Confirm::default(),
            prev_faults: 0,
            latest: HealthReport::default(),
        })
    }

    /// With [`HealthParams::DEFAULT`] (valid: tested).
    pub fn with_defaults() -> Self {
        Self {
            params: HealthParams::DEFAULT,
            battery: BatteryMonitor::new(),
            leak: LeakDebounce::new(LEAK_CONFIRM_US),
            press: Confirm::default(),
            temp: Confirm::default(),
            prev_faults: 0,
            latest: HealthReport::default(),
        }
    }

    /// The parameters in force.
    pub fn params(&self) -> &HealthParams {
        &self.params
    }

    /// New parameters (checked; on `Err` nothing changes). The battery's count of mAh stays.
    pub fn set_params(&mut self, params: HealthParams) -> Result<(), NackReason> {
        params.validate()?;
        self.params = params;
        Ok(())
    }

    /// The latest report (its action is the one of the latest check).
    pub fn latest(&self) -> &HealthReport {
        &self.latest
    }

    /// The depth limit in force (None: off).
    pub fn depth_limit(&self) -> Option<DepthLimit> {
        DepthLimit::new(self.params.depth_limit_m)
    }

    /// Check everything at `now_us`.
    pub fn update(&mut self, now_us: u64, s: &HealthSample) -> HealthReport {
        let p = self.params;
        let battery = self.battery.update(now_us, s, &p);
        // Each event with its action; an action fires only when its event is new (ArduSub
        // acts once per event, and the pilot may take over afterwards).
        let mut events: [(u16, FailsafeAction); 5] = [(0, FailsafeAction::None); 5];
        let mut n = 0usize;
        let mut push = |bit: u16, act: FailsafeAction| {
            if let Some(e) = events.get_mut(n) {
                *e = (bit, act);
                n += 1;
            }
        };
        match battery.level {
            BatteryLevel::Critical => push(fault::BATTERY_CRITICAL, p.batt_fs_crt_act),
            BatteryLevel::Low => push(fault::BATTERY_LOW, p.batt_fs_low_act),
            BatteryLevel::Normal => {}
        }
        if p.fs_leak_enable != FailsafeAction::None && self.leak.update(now_us, s.leak_wet) {
            push(fault::LEAK, p.fs_leak_enable);
        }
        let over = |v: Option<f32>, lim: f32| lim > 0.0 && v.is_some_and(|v| v > lim);
        let press = self.press.update(
            now_us,
            over(s.enclosure_pa, p.fs_press_max_pa),
            ENCLOSURE_CONFIRM_US,
        );
        let temp = self.temp.update(
            now_us,
            over(s.enclosure_c, p.fs_temp_max_c),
            ENCLOSURE_CONFIRM_US,
        );
        if press || temp {
            push(fault::ENCLOSURE, FailsafeAction::Warn);
        }
        if let (Some(lim), Some(d)) = (self.depth_limit(), s.depth_m) {
            if lim.warning(d) {
                push(fault::DEPTH_LIMIT, FailsafeAction::Warn);
            }
        }
        let faults = events.iter().fold(0u16, |f, (bit, _)| f | bit);
        let action = events
            .iter()
            .filter(|(bit, _)| bit & !self.prev_faults != 0)
            .fold(FailsafeAction::None, |a, (_, act)| a.max(*act));
        self.prev_faults = faults;
        self.latest = HealthReport {
            faults,
            action,
            battery,
        };
        self.latest
    }
}

#[cfg(test)]
mod tests;
