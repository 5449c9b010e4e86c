//! The vehicle's health on the wire: its parameters ([`HealthParams`], sent by
//! `Command::SetHealth`; ArduSub's names where ArduSub has one) and the battery's figures
//! reported in `Status` ([`BatteryStatus`]). The health fault bits are in
//! [`fault`](crate::fault) with the others.

use crate::nack::NackReason;
use serde::{Deserialize, Serialize};

/// What a failsafe does (ArduSub's numbering for the battery's actions: 0 none, 1 warn,
/// 2 disarm, 3 surface).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum FailsafeAction {
    /// Nothing.
    #[default]
    None,
    /// Report only (the fault bit; the surface shows a CRITICAL text).
    Warn,
    /// Disarm.
    Disarm,
    /// Switch to the SURFACE mode.
    Surface,
}

impl FailsafeAction {
    /// From ArduSub's battery action number (`BATT_FS_LOW_ACT`, `BATT_FS_CRT_ACT`).
    pub const fn from_batt_act(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::None),
            1 => Some(Self::Warn),
            2 => Some(Self::Disarm),
            3 => Some(Self::Surface),
            _ => None,
        }
    }

    /// ArduSub's battery action number.
    pub const fn batt_act(self) -> u8 {
        match self {
            Self::None => 0,
            Self::Warn => 1,
            Self::Disarm => 2,
            Self::Surface => 3,
        }
    }

    /// From ArduSub's `FS_LEAK_ENABLE` (0 disabled, 1 warn only, 2 surface).
    pub const fn from_leak_enable(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::None),
            1 => Some(Self::Warn),
            2 => Some(Self::Surface),
            _ => None,
        }
    }

    /// The stronger of two actions (disarm over surface over warn over none).
    pub fn max(self, other: Self) -> Self {
        if other.rank() > self.rank() {
            other
        } else {
            self
        }
    }

    const fn rank(self) -> u8 {
        match self {
            Self::None => 0,
            Self::Warn => 1,
            Self::Surface => 2,
            Self::Disarm => 3,
        }
    }
}

/// What the SURFACE mode does once the vehicle is within its arrival depth of the surface
/// (`SURFACE_END`: 0 hold that depth, 1 disarm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum SurfaceEnd {
    /// Hold that depth (the depth law), horizontal thrusters neutral.
    #[default]
    Hold,
    /// Disarm.
    Disarm,
}

/// The health parameters. A zero threshold is off, as in ArduSub.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HealthParams {
    /// `BATT_VOLT_MULT`: battery volts per volt on the voltage pin.
    pub batt_volt_mult: f32,
    /// `BATT_AMP_PERVLT`: amperes per volt on the current pin.
    pub batt_amp_pervlt: f32,
    /// `BATT_AMP_OFFSET`: current pin voltage at zero current, V.
    pub batt_amp_offset_v: f32,
    /// `BATT_CAPACITY`: full charge, mAh.
    pub batt_capacity_mah: f32,
    /// `BATT_EMPTY_VOLT`: the battery's voltage under load when empty (this vehicle's own:
    /// ArduSub has none), V. The remaining time is the energy left over the power drawn,
    /// with the mean voltage to come taken halfway between now and empty (0: the charge
    /// over the current, as ArduPilot gives it).
    pub batt_empty_volt: f32,
    /// `BATT_LOW_VOLT`: low below this voltage, V (0: off).
    pub batt_low_volt: f32,
    /// `BATT_CRT_VOLT`: critical below this voltage, V (0: off).
    pub batt_crt_volt: f32,
    /// `BATT_LOW_MAH`: low when less than this is left, mAh (0: off).
    pub batt_low_mah: f32,
    /// `BATT_CRT_MAH`: critical when less than this is left, mAh (0: off).
    pub batt_crt_mah: f32,
    /// `BATT_LOW_TIMER`: how long a voltage must stay under its threshold (the sag of a
    /// burst of thrust is not a flat battery), s. ArduPilot's default is 10 s; here 0.5 s,
    /// so that a critical battery starts the surfacing within 1 s.
    pub batt_low_timer_s: f32,
    /// `BATT_FS_LOW_ACT`.
    pub batt_fs_low_act: FailsafeAction,
    /// `BATT_FS_CRT_ACT`.
    pub batt_fs_crt_act: FailsafeAction,
    /// `FS_LEAK_ENABLE`: the leak action (none, warn or surface).
    pub fs_leak_enable: FailsafeAction,
    /// `LEAK1_PIN`: the probe's GPIO in the board's numbering (-1: no probe).
    pub leak1_pin: i8,
    /// `FS_PRESS_MAX`: enclosure pressure limit, Pa (0: off).
    pub fs_press_max_pa: f32,
    /// `FS_TEMP_MAX`: enclosure temperature limit, degrees C (0: off).
    pub fs_temp_max_c: f32,
    /// `DEPTH_LIMIT_M`: the deepest the vehicle may go, m (0: off).
    pub depth_limit_m: f32,
    /// `SURFACE_END`: what SURFACE does at the top.
    pub surface_end: SurfaceEnd,
}

impl HealthParams {
    /// The Blue Robotics power-sense module's scales (ArduSub's values for it), an 18 Ah
    /// battery empty at 12 V (4 lithium-ion cells at 3.0 V), voltage and mAh thresholds off, the leak probe on pin 0 with the surface
    /// action, ArduSub's enclosure limits (105 kPa, 62 C), no depth limit.
    pub const DEFAULT: Self = Self {
        batt_volt_mult: 11.0,
        batt_amp_pervlt: 37.8788,
        batt_amp_offset_v: 0.330,
        batt_capacity_mah: 18_000.0,
        batt_empty_volt: 12.0,
        batt_low_volt: 0.0,
        batt_crt_volt: 0.0,
        batt_low_mah: 0.0,
        batt_crt_mah: 0.0,
        batt_low_timer_s: 0.5,
        batt_fs_low_act: FailsafeAction::Warn,
        batt_fs_crt_act: FailsafeAction::Surface,
        fs_leak_enable: FailsafeAction::Surface,
        leak1_pin: 0,
        fs_press_max_pa: 105_000.0,
        fs_temp_max_c: 62.0,
        depth_limit_m: 0.0,
        surface_end: SurfaceEnd::Hold,
    };

    /// Longest `BATT_LOW_TIMER` accepted, s.
    pub const MAX_LOW_TIMER_S: f32 = 10.0;
    /// Deepest `DEPTH_LIMIT_M` accepted, m (the vehicle's reference bound).
    pub const MAX_DEPTH_LIMIT_M: f32 = 100.0;

    /// Every value finite; scales and capacity positive; thresholds non-negative; each
    /// critical threshold no higher than its low one; the low mAh within the capacity; the
    /// timer and the depth limit within their maxima; the leak action not disarm.
    pub fn validate(&self) -> Result<(), NackReason> {
        let all = [
            self.batt_volt_mult,
            self.batt_amp_pervlt,
            self.batt_amp_offset_v,
            self.batt_capacity_mah,
            self.batt_empty_volt,
            self.batt_low_volt,
            self.batt_crt_volt,
            self.batt_low_mah,
            self.batt_crt_mah,
            self.batt_low_timer_s,
            self.fs_press_max_pa,
            self.fs_temp_max_c,
            self.depth_limit_m,
        ];
        if all.iter().any(|v| !v.is_finite()) {
            return Err(NackReason::NonFinite);
        }
        let crit_below_low = |crt: f32, low: f32| crt == 0.0 || low == 0.0 || crt <= low;
        let ok = all.iter().all(|v| *v >= 0.0)
            && self.batt_volt_mult > 0.0
            && self.batt_amp_pervlt > 0.0
            && self.batt_capacity_mah > 0.0
            && crit_below_low(self.batt_crt_volt, self.batt_low_volt)
            // The mAh thresholds are what is left: the critical one is the smaller.
            && crit_below_low(self.batt_crt_mah, self.batt_low_mah)
            && self.batt_low_mah <= self.batt_capacity_mah
            && self.batt_low_timer_s <= Self::MAX_LOW_TIMER_S
            && self.depth_limit_m <= Self::MAX_DEPTH_LIMIT_M
            && self.fs_leak_enable != FailsafeAction::Disarm;
        if ok {
            Ok(())
        } else {
            Err(NackReason::OutOfRange)
        }
    }
}

impl Default for HealthParams {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// The battery's figures, reported in `Status` (what the surface puts in MAVLink's
/// `SYS_STATUS` and `BATTERY_STATUS`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BatteryStatus {
    /// Voltage, V (0: not measured).
    pub voltage_v: f32,
    /// Current, A (negative: not measured).
    pub current_a: f32,
    /// Charge used since boot, mAh.
    pub consumed_mah: f32,
    /// What is left, % of `BATT_CAPACITY`.
    pub remaining_pct: f32,
    /// Time left at the mean draw, s (0: unknown, at rest or without current sensing).
    pub time_remaining_s: f32,
}

/// One reading of the health inputs (the App's `Sensors::health`).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct HealthSample {
    /// Voltage on the power-sense module's voltage pin, V (None: no ADC).
    pub volt_pin_v: Option<f32>,
    /// Voltage on its current pin, V (None: no current sensing).
    pub curr_pin_v: Option<f32>,
    /// The leak probe reads wet.
    pub leak_wet: bool,
    /// Enclosure pressure, Pa (None: no sensor).
    pub enclosure_pa: Option<f32>,
    /// Enclosure temperature, degrees C (None: no sensor).
    pub enclosure_c: Option<f32>,
    /// Depth, m (None: unknown).
    pub depth_m: Option<f32>,
}
