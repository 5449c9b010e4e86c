//! `[health]`: the vehicle's health events in the simulation (a leak, an enclosure pressure
//! rise) and its health parameters (ArduSub's names in lower case where ArduSub has one),
//! which the in-process firmware boots with. With `[battery]` (`world::battery`):
//!
//! ```toml
//! [health]
//! leak_at_s = 30.0                      # the leak probe reads wet from then on
//! enclosure_pressure_rise_at_s = 10.0   # the enclosure's pressure rises from then on
//! enclosure_pressure_rise_pa_s = 500.0  # ... at this rate
//! enclosure_temp_c = 30.0
//! batt_low_volt = 14.0                  # BATT_LOW_VOLT (0: off)
//! batt_crt_volt = 13.5                  # BATT_CRT_VOLT
//! batt_low_mah = 0.0                    # BATT_LOW_MAH: left (0: off)
//! batt_crt_mah = 0.0                    # BATT_CRT_MAH
//! batt_fs_low_act = 1                   # BATT_FS_LOW_ACT: 0 none, 1 warn, 2 disarm, 3 surface
//! batt_fs_crt_act = 3                   # BATT_FS_CRT_ACT
//! fs_leak_enable = 2                    # FS_LEAK_ENABLE: 0 off, 1 warn, 2 surface
//! fs_press_max = 105000.0               # FS_PRESS_MAX, Pa
//! fs_temp_max = 62.0                    # FS_TEMP_MAX, C
//! depth_limit_m = 0.0                   # DEPTH_LIMIT_M (0: off)
//! surface_end = "hold"                  # SURFACE_END: "hold" or "disarm"
//! ```
//!
//! `BATT_CAPACITY` is the `[battery]`'s capacity; the power-sense module's scales are
//! ArduSub's for the Blue Robotics module (the simulated module is that one).

use anyhow::{anyhow, bail, Result};
use firmware::protocol::{FailsafeAction, HealthParams, SurfaceEnd};
use serde::{Deserialize, Serialize};
use sim_world::battery::{BatterySpec, HealthEvents};
use sim_world::checks::fin;

/// `SURFACE_END` in a scenario.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SurfaceEndSpec {
    /// Hold the arrival depth.
    #[default]
    Hold,
    /// Disarm at the top.
    Disarm,
}

/// `[health]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HealthSpec {
    /// The leak probe is wet from this simulated time on, s.
    pub leak_at_s: Option<f64>,
    /// The enclosure's pressure rises from this time on, s.
    pub enclosure_pressure_rise_at_s: Option<f64>,
    /// ... at this rate, Pa/s.
    pub enclosure_pressure_rise_pa_s: f64,
    /// Enclosure temperature, C.
    pub enclosure_temp_c: f64,
    /// `BATT_LOW_VOLT`.
    pub batt_low_volt: f32,
    /// `BATT_CRT_VOLT`.
    pub batt_crt_volt: f32,
    /// `BATT_LOW_MAH`.
    pub batt_low_mah: f32,
    /// `BATT_CRT_MAH`.
    pub batt_crt_mah: f32,
    /// `BATT_FS_LOW_ACT`.
    pub batt_fs_low_act: u8,
    /// `BATT_FS_CRT_ACT`.
    pub batt_fs_crt_act: u8,
    /// `FS_LEAK_ENABLE`.
    pub fs_leak_enable: u8,
    /// `FS_PRESS_MAX`, Pa.
    pub fs_press_max: f32,
    /// `FS_TEMP_MAX`, C.
    pub fs_temp_max: f32,
    /// `DEPTH_LIMIT_M`.
    pub depth_limit_m: f32,
    /// `SURFACE_END`.
    pub surface_end: SurfaceEndSpec,
}

impl Default for HealthSpec {
    /// No events; the firmware's default parameters.
    fn default() -> Self {
        let p = HealthParams::DEFAULT;
        Self {
            leak_at_s: None,
            enclosure_pressure_rise_at_s: None,
            enclosure_pressure_rise_pa_s: 0.0,
            enclosure_temp_c: 30.0,
            batt_low_volt: p.batt_low_volt,
            batt_crt_volt: p.batt_crt_volt,
            batt_low_mah: p.batt_low_mah,
            batt_crt_mah: p.batt_crt_mah,
            batt_fs_low_act: p.batt_fs_low_act.batt_act(),
            batt_fs_crt_act: p.batt_fs_crt_act.batt_act(),
            fs_leak_enable: 2,
            fs_press_max: p.fs_press_max_pa,
            fs_temp_max: p.fs_temp_max_c,
            depth_limit_m: p.depth_limit_m,
            surface_end: SurfaceEndSpec::Hold,
        }
    }
}

impl HealthSpec {
    /// The events for the simulation (checked).
    pub fn events(&self) -> Result<HealthEvents> {
        for (name, v) in [
            ("health.leak_at_s", self.leak_at_s),
            (
                "health.enclosure_pressure_rise_at_s",
                self.enclosure_pressure_rise_at_s,
            ),
        ] {
            if let Some(v) = v {
                fin(name, v)?;
                if v < 0.0 {
                    bail!("{name} = {v} must not be negative");
                }
            }
        }
        fin(
            "health.enclosure_pressure_rise_pa_s",
            self.enclosure_pressure_rise_pa_s,
        )?;
        fin("health.enclosure_temp_c", self.enclosure_temp_c)?;
        Ok(HealthEvents {
            leak_at_s: self.leak_at_s,
            pressure_rise_at_s: self.enclosure_pressure_rise_at_s,
            pressure_rise_pa_s: self.enclosure_pressure_rise_pa_s,
            enclosure_c: self.enclosure_temp_c,
        })
    }

    /// The vehicle's health parameters (checked as the firmware checks them), with
    /// `BATT_CAPACITY` from `battery`.
    pub fn params(&self, battery: &BatterySpec) -> Result<HealthParams> {
        let act = |name: &str, v: u8| {
            FailsafeAction::from_batt_act(v).ok_or_else(|| {
                anyhow!("health.{name} = {v} must be 0-3 (none, warn, disarm, surface)")
            })
        };
        let p = HealthParams {
            batt_capacity_mah: battery.capacity_mah as f32,
            batt_low_volt: self.batt_low_volt,
            batt_crt_volt: self.batt_crt_volt,
            batt_low_mah: self.batt_low_mah,
            batt_crt_mah: self.batt_crt_mah,
            batt_fs_low_act: act("batt_fs_low_act", self.batt_fs_low_act)?,
            batt_fs_crt_act: act("batt_fs_crt_act", self.batt_fs_crt_act)?,
            fs_leak_enable: FailsafeAction::from_leak_enable(self.fs_leak_enable).ok_or_else(
                || {
                    anyhow!(
                        "health.fs_leak_enable = {} must be 0-2 (off, warn, surface)",
                        self.fs_leak_enable
                    )
                },
            )?,
            fs_press_max_pa: self.fs_press_max,
            fs_temp_max_c: self.fs_temp_max,
            depth_limit_m: self.depth_limit_m,
            surface_end: match self.surface_end {
                SurfaceEndSpec::Hold => SurfaceEnd::Hold,
                SurfaceEndSpec::Disarm => SurfaceEnd::Disarm,
            },
            ..HealthParams::DEFAULT
        };
        p.validate().map_err(|r| {
            anyhow!("[health] parameters refused by the firmware's check ({r:?}): thresholds finite and non-negative, critical at or under low, low mAh within the capacity, depth limit 0-100 m")
        })?;
        Ok(p)
    }

    /// Every check.
    pub fn check(&self, battery: &BatterySpec) -> Result<()> {
        battery.check()?;
        self.events()?;
        self.params(battery).map(|_| ())
    }
}
