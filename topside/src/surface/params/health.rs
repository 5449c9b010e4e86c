//! The vehicle's health parameters as a ground station shows them (ArduSub's names where
//! ArduSub has one): the battery's scales, thresholds and actions, the leak, enclosure
//! pressure and temperature failsafes, the depth limit and the end of SURFACE. Each is a
//! number here (a ground station sets numbers); [`HealthSettings::to_vehicle`] checks them
//! with a reason naming the parameter and gives what `Command::SetHealth` carries.

use anyhow::{anyhow, bail, Result};
use protocol::{FailsafeAction, HealthParams, SurfaceEnd};

/// The health parameters, one number each.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HealthSettings {
    /// `BATT_VOLT_MULT`: battery volts per volt on the voltage pin.
    pub volt_mult: f32,
    /// `BATT_AMP_PERVLT`: amperes per volt on the current pin.
    pub amp_pervlt: f32,
    /// `BATT_AMP_OFFSET`: current pin voltage at zero current, V.
    pub amp_offset_v: f32,
    /// `BATT_CAPACITY`: full charge, mAh.
    pub capacity_mah: f32,
    /// `BATT_EMPTY_VOLT`: voltage under load when empty, V (0: time left from charge only).
    pub empty_volt: f32,
    /// `BATT_LOW_VOLT`, V (0: off).
    pub low_volt: f32,
    /// `BATT_CRT_VOLT`, V (0: off).
    pub crt_volt: f32,
    /// `BATT_LOW_MAH`: low when less than this is left, mAh (0: off).
    pub low_mah: f32,
    /// `BATT_CRT_MAH`: critical when less than this is left, mAh (0: off).
    pub crt_mah: f32,
    /// `BATT_LOW_TIMER`: how long a voltage stays under its threshold before it counts, s.
    pub low_timer_s: f32,
    /// `BATT_FS_LOW_ACT`: 0 none, 1 warn, 2 disarm, 3 surface.
    pub fs_low_act: f32,
    /// `BATT_FS_CRT_ACT`: 0 none, 1 warn, 2 disarm, 3 surface.
    pub fs_crt_act: f32,
    /// `FS_LEAK_ENABLE`: 0 disabled, 1 warn only, 2 surface.
    pub leak_enable: f32,
    /// `LEAK1_PIN`: the leak probe's pin (-1: no probe).
    pub leak1_pin: f32,
    /// `FS_PRESS_ENABLE`: 0 disabled, 1 warn only.
    pub press_enable: f32,
    /// `FS_PRESS_MAX`: enclosure pressure limit, Pa.
    pub press_max_pa: f32,
    /// `FS_TEMP_ENABLE`: 0 disabled, 1 warn only.
    pub temp_enable: f32,
    /// `FS_TEMP_MAX`: enclosure temperature limit, degrees C.
    pub temp_max_c: f32,
    /// `DEPTH_LIMIT_M`: the deepest the vehicle may go, m (0: off).
    pub depth_limit_m: f32,
    /// `SURFACE_END`: 0 hold at the top, 1 disarm.
    pub surface_end: f32,
}

/// Highest battery voltage taken (V): a 24-cell pack.
pub const MAX_VOLT: f32 = 100.0;
/// Largest battery capacity taken (mAh).
pub const MAX_CAPACITY_MAH: f32 = 1_000_000.0;
/// Highest enclosure pressure limit taken (Pa): 2 bar, far above any sealed enclosure's.
pub const MAX_PRESS_PA: f32 = 200_000.0;
/// Highest enclosure temperature limit taken (degrees C): electronics' rating.
pub const MAX_TEMP_C: f32 = 125.0;

impl HealthSettings {
    /// The vehicle's parameters as numbers; a limit switched off shows its enable 0 and
    /// ArduSub's default limit.
    pub fn of(p: &HealthParams) -> Self {
        let act = |a: FailsafeAction| f32::from(a.batt_act());
        let leak = match p.fs_leak_enable {
            FailsafeAction::None => 0.0,
            FailsafeAction::Warn => 1.0,
            FailsafeAction::Surface | FailsafeAction::Disarm => 2.0,
        };
        let on = |v: f32| if v > 0.0 { 1.0 } else { 0.0 };
        let or = |v: f32, d: f32| if v > 0.0 { v } else { d };
        let d = HealthParams::DEFAULT;
        Self {
            volt_mult: p.batt_volt_mult,
            amp_pervlt: p.batt_amp_pervlt,
            amp_offset_v: p.batt_amp_offset_v,
            capacity_mah: p.batt_capacity_mah,
            empty_volt: p.batt_empty_volt,
            low_volt: p.batt_low_volt,
            crt_volt: p.batt_crt_volt,
            low_mah: p.batt_low_mah,
            crt_mah: p.batt_crt_mah,
            low_timer_s: p.batt_low_timer_s,
            fs_low_act: act(p.batt_fs_low_act),
            fs_crt_act: act(p.batt_fs_crt_act),
            leak_enable: leak,
            leak1_pin: f32::from(p.leak1_pin),
            press_enable: on(p.fs_press_max_pa),
            press_max_pa: or(p.fs_press_max_pa, d.fs_press_max_pa),
            temp_enable: on(p.fs_temp_max_c),
            temp_max_c: or(p.fs_temp_max_c, d.fs_temp_max_c),
            depth_limit_m: p.depth_limit_m,
            surface_end: match p.surface_end {
                SurfaceEnd::Hold => 0.0,
                SurfaceEnd::Disarm => 1.0,
            },
        }
    }

    /// What `SetHealth` carries, refused with a reason naming the parameter and its range
    /// where the vehicle would refuse it ([`HealthParams::validate`]).
    pub fn to_vehicle(&self) -> Result<HealthParams> {
        let range = |name: &str, v: f32, lo: f32, hi: f32, unit: &str| -> Result<f32> {
            if v.is_finite() && (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                bail!("{name} must be {lo}-{hi}{unit}")
            }
        };
        let positive = |name: &str, v: f32, hi: f32, unit: &str| -> Result<f32> {
            if v.is_finite() && v > 0.0 && v <= hi {
                Ok(v)
            } else {
                bail!("{name} must be above 0, at most {hi}{unit}")
            }
        };
        let whole = |name: &str, v: f32, lo: f32, hi: f32, meaning: &str| -> Result<u8> {
            if v.is_finite() && v.fract() == 0.0 && (lo..=hi).contains(&v) {
                Ok((v - lo) as u8)
            } else {
                bail!("{name} must be one of {meaning}")
            }
        };
        let act = |name: &str, v: f32| -> Result<FailsafeAction> {
            let n = whole(name, v, 0.0, 3.0, "0 none, 1 warn, 2 disarm, 3 surface")?;
            FailsafeAction::from_batt_act(n).ok_or_else(|| anyhow!("{name} must be 0-3"))
        };
        let capacity_mah = positive("BATT_CAPACITY", self.capacity_mah, MAX_CAPACITY_MAH, " mAh")?;
        let low_volt = range("BATT_LOW_VOLT", self.low_volt, 0.0, MAX_VOLT, " V (0: off)")?;
        let crt_volt = range("BATT_CRT_VOLT", self.crt_volt, 0.0, MAX_VOLT, " V (0: off)")?;
        if low_volt > 0.0 && crt_volt > low_volt {
            bail!("BATT_CRT_VOLT must not be above BATT_LOW_VOLT ({low_volt} V)");
        }
        let low_mah = range(
            "BATT_LOW_MAH",
            self.low_mah,
            0.0,
            capacity_mah,
            " mAh (0: off)",
        )?;
        let crt_mah = range(
            "BATT_CRT_MAH",
            self.crt_mah,
            0.0,
            capacity_mah,
            " mAh (0: off)",
        )?;
        if low_mah > 0.0 && crt_mah > low_mah {
            bail!("BATT_CRT_MAH must not be above BATT_LOW_MAH ({low_mah} mAh)");
        }
        let leak = whole(
            "FS_LEAK_ENABLE",
            self.leak_enable,
            0.0,
            2.0,
            "0 disabled, 1 warn only, 2 surface",
        )?;
        let enabled = |name: &str, v: f32| -> Result<bool> {
            Ok(whole(name, v, 0.0, 1.0, "0 disabled, 1 warn only")? == 1)
        };
        let press_max = range("FS_PRESS_MAX", self.press_max_pa, 0.0, MAX_PRESS_PA, " Pa")?;
        let temp_max = range("FS_TEMP_MAX", self.temp_max_c, 0.0, MAX_TEMP_C, " C")?;
        let p = HealthParams {
            batt_volt_mult: positive("BATT_VOLT_MULT", self.volt_mult, 100.0, "")?,
            batt_amp_pervlt: positive("BATT_AMP_PERVLT", self.amp_pervlt, 1000.0, " A/V")?,
            batt_amp_offset_v: range("BATT_AMP_OFFSET", self.amp_offset_v, 0.0, 5.0, " V")?,
            batt_capacity_mah: capacity_mah,
            batt_empty_volt: range("BATT_EMPTY_VOLT", self.empty_volt, 0.0, MAX_VOLT, " V")?,
            batt_low_volt: low_volt,
            batt_crt_volt: crt_volt,
            batt_low_mah: low_mah,
            batt_crt_mah: crt_mah,
            batt_low_timer_s: range(
                "BATT_LOW_TIMER",
                self.low_timer_s,
                0.0,
                HealthParams::MAX_LOW_TIMER_S,
                " s",
            )?,
            batt_fs_low_act: act("BATT_FS_LOW_ACT", self.fs_low_act)?,
            batt_fs_crt_act: act("BATT_FS_CRT_ACT", self.fs_crt_act)?,
            fs_leak_enable: FailsafeAction::from_leak_enable(leak)
                .ok_or_else(|| anyhow!("FS_LEAK_ENABLE must be 0-2"))?,
            leak1_pin: i8::try_from(whole(
                "LEAK1_PIN",
                self.leak1_pin,
                -1.0,
                63.0,
                "-1 (none) to 63",
            )?)
            .map(|n| n - 1)
            .map_err(|_| anyhow!("LEAK1_PIN must be -1 (none) to 63"))?,
            fs_press_max_pa: if enabled("FS_PRESS_ENABLE", self.press_enable)? {
                press_max
            } else {
                0.0
            },
            fs_temp_max_c: if enabled("FS_TEMP_ENABLE", self.temp_enable)? {
                temp_max
            } else {
                0.0
            },
            depth_limit_m: range(
                "DEPTH_LIMIT_M",
                self.depth_limit_m,
                0.0,
                HealthParams::MAX_DEPTH_LIMIT_M,
                " m (0: off)",
            )?,
            surface_end: match whole(
                "SURFACE_END",
                self.surface_end,
                0.0,
                1.0,
                "0 hold, 1 disarm",
            )? {
                0 => SurfaceEnd::Hold,
                _ => SurfaceEnd::Disarm,
            },
        };
        // The vehicle's own rule, in case the two ever differ.
        p.validate()
            .map_err(|_| anyhow!("the vehicle's check refuses these battery and limit settings"))?;
        Ok(p)
    }
}

impl Default for HealthSettings {
    fn default() -> Self {
        Self::of(&HealthParams::DEFAULT)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vehicles_defaults_round_trip() {
        let s = HealthSettings::default();
        assert_eq!(s.to_vehicle().unwrap(), HealthParams::DEFAULT);
        assert_eq!(s.press_enable, 1.0);
        assert_eq!(s.leak_enable, 2.0);
        assert_eq!(s.fs_crt_act, 3.0);
    }

    #[test]
    fn an_enable_of_0_switches_its_limit_off_and_keeps_the_limit_shown() {
        let s = HealthSettings {
            press_enable: 0.0,
            temp_enable: 0.0,
            ..HealthSettings::default()
        };
        let p = s.to_vehicle().unwrap();
        assert_eq!(p.fs_press_max_pa, 0.0);
        assert_eq!(p.fs_temp_max_c, 0.0);
        let back = HealthSettings::of(&p);
        assert_eq!(back.press_enable, 0.0);
        assert_eq!(back.press_max_pa, 105_000.0);
    }

    #[test]
    fn bad_values_are_refused_in_words_naming_the_parameter() {
        let d = HealthSettings::default();
        let cases: [(HealthSettings, &str); 7] = [
            (
                HealthSettings {
                    low_volt: 14.0,
                    crt_volt: 15.0,
                    ..d
                },
                "BATT_CRT_VOLT must not be above",
            ),
            (
                HealthSettings {
                    fs_low_act: 4.0,
                    ..d
                },
                "BATT_FS_LOW_ACT must be one of 0 none",
            ),
            (
                HealthSettings {
                    fs_crt_act: 1.5,
                    ..d
                },
                "BATT_FS_CRT_ACT must be one of",
            ),
            (
                HealthSettings {
                    leak_enable: 3.0,
                    ..d
                },
                "FS_LEAK_ENABLE must be one of",
            ),
            (
                HealthSettings {
                    depth_limit_m: 150.0,
                    ..d
                },
                "DEPTH_LIMIT_M must be 0-100",
            ),
            (
                HealthSettings {
                    low_mah: 20_000.0,
                    ..d
                },
                "BATT_LOW_MAH must be 0-18000",
            ),
            (
                HealthSettings {
                    capacity_mah: 0.0,
                    ..d
                },
                "BATT_CAPACITY must be above 0",
            ),
        ];
        for (s, words) in cases {
            let e = format!("{:#}", s.to_vehicle().unwrap_err());
            assert!(e.contains(words), "{e} (wanted {words})");
        }
    }

    #[test]
    fn the_leak_pin_maps_minus_1_to_no_probe() {
        let s = HealthSettings {
            leak1_pin: -1.0,
            ..HealthSettings::default()
        };
        assert_eq!(s.to_vehicle().unwrap().leak1_pin, -1);
        let s = HealthSettings {
            leak1_pin: 7.0,
            ..HealthSettings::default()
        };
        assert_eq!(s.to_vehicle().unwrap().leak1_pin, 7);
    }
}
