//! The ground station's parameter list (`PARAM_*`): every control-law gain, the failsafe
//! timeouts and the vehicle's description, by names of at most 16 characters. A change is
//! checked here first (the core's validation, the firmware's rules) and then sent to the
//! vehicle (`SetTrackingGains` / `SetPaperGains` / `SetFailsafe` / `SetVehicle`), which checks
//! again and may refuse; nothing changes on a refusal. Accepted changes are saved to a JSON
//! file and restored at the next start.
//!
//! Names: `TRK_*` the tracking laws ([`TrackingGains`](controller_core::law::tracking::TrackingGains)),
//! `PXZ_*` / `PXY_*` the paper's XZ / XY laws, `FS_*` the failsafe timeouts in seconds,
//! `VEH_*` the vehicle ([`VehicleParams`], a vehicle file's keys; `VEH_PWM_*` its pulse curve),
//! `MIS_SPEED` the speed along a mission's path (kept here, sent with the next mission),
//! `COMPASS_DEV_SIN` / `COMPASS_DEV_COS` the compass's heading-dependent deviation in
//! **degrees** (it reads `psi + sin_deg sin(psi) + cos_deg cos(psi)`; sent as
//! `SetCompassCal` in radians, refused beyond 30 degrees of amplitude and while armed). The
//! constant part of a compass's error has no parameter: the estimator learns it.
//! `CTRL_PASSKEY` is the passkey another ground station gives in `CHANGE_OPERATOR_CONTROL` to
//! take control (`commander`): a whole number from 1 to 999,999, its decimal digits the
//! passkey; 0 (the default) refuses every takeover (the holder releases control or falls
//! silent). Kept at the surface; ArduSub has no such parameter.
//!
//! At start the saved file is restored only where it differs from what the vehicle holds and
//! the vehicle takes it now; a group the vehicle refuses now (a new description while its
//! estimator runs or while armed) waits and is applied when the vehicle takes it (`start`).

pub mod health;
pub mod surface;

pub use health::HealthSettings;
pub use surface::SurfaceSettings;

use super::joystick::JoystickSettings;
use anyhow::{anyhow, bail, Result};
use controller_core::controller::Gains;
use controller_core::nav::compass_cal::{CalRefusal, CompassCalibration, MAX_DEVIATION_RAD};
use controller_core::params::VehicleParams;
use protocol::Failsafe;

/// The failsafe timeouts in seconds, as a ground station shows them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FailsafeSeconds {
    /// Heartbeat age at which thrust goes neutral.
    pub heartbeat_neutral_s: f32,
    /// Heartbeat age at which the vehicle disarms.
    pub heartbeat_disarm_s: f32,
    /// Navigation age at which the laws stop.
    pub nav_stale_s: f32,
    /// Pilot-input age at which manual thrust goes neutral.
    pub pilot_stale_s: f32,
}

impl FailsafeSeconds {
    /// The firmware's timeouts in seconds.
    pub fn of(f: &Failsafe) -> Self {
        let s = |us: u64| (us as f64 * 1e-6) as f32;
        Self {
            heartbeat_neutral_s: s(f.heartbeat_neutral_us),
            heartbeat_disarm_s: s(f.heartbeat_disarm_us),
            nav_stale_s: s(f.nav_stale_us),
            pilot_stale_s: s(f.manual_stale_us),
        }
    }

    /// The firmware's timeouts (microseconds), refused with a reason naming the parameter
    /// where the firmware would refuse them ([`Failsafe::validate`]).
    pub fn to_firmware(&self) -> Result<Failsafe> {
        let us = |name: &str, s: f32, max_us: u64| -> Result<u64> {
            let range = (Failsafe::MIN_US as f64 * 1e-6, max_us as f64 * 1e-6);
            let v = (f64::from(s) * 1e6).round();
            if s.is_finite() && (Failsafe::MIN_US as f64..=max_us as f64).contains(&v) {
                Ok(v as u64)
            } else {
                bail!("{name} must be {}-{} s", range.0, range.1)
            }
        };
        let f = Failsafe {
            heartbeat_neutral_us: us(
                "FS_HB_NEUTRAL",
                self.heartbeat_neutral_s,
                Failsafe::MAX_NEUTRAL_US,
            )?,
            heartbeat_disarm_us: us(
                "FS_HB_DISARM",
                self.heartbeat_disarm_s,
                Failsafe::MAX_DISARM_US,
            )?,
            nav_stale_us: us("FS_NAV_STALE", self.nav_stale_s, Failsafe::MAX_NAV_STALE_US)?,
            manual_stale_us: us(
                "FS_PILOT_STALE",
                self.pilot_stale_s,
                Failsafe::MAX_NEUTRAL_US,
            )?,
        };
        if f.heartbeat_neutral_us > f.heartbeat_disarm_us {
            bail!("FS_HB_NEUTRAL must not exceed FS_HB_DISARM");
        }
        // The firmware's own rule, in case the two ever differ.
        f.validate()
            .map_err(|why| anyhow!("the firmware's check: {}", super::words::nack(why)))?;
        Ok(f)
    }
}

/// Everything the parameter list shows: what is in force on the vehicle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// The laws' gains.
    pub gains: Gains,
    /// The failsafe timeouts.
    pub failsafe: FailsafeSeconds,
    /// The vehicle's description.
    pub vehicle: VehicleParams,
    /// Speed along a mission's path (m/s), sent with the next mission uploaded.
    pub mission_speed_m_s: f32,
    /// The compass's deviation (degrees).
    pub compass: CompassDeviationDeg,
    /// The passkey for `CHANGE_OPERATOR_CONTROL` (0: no takeover).
    pub control_passkey: f32,
    /// The joystick's buttons and gain (`BTNn_*`, `JS_GAIN_*`).
    pub joystick: JoystickSettings,
    /// The vehicle's health parameters (`BATT_*`, `FS_LEAK_*`, `FS_PRESS_*`, `FS_TEMP_*`,
    /// `DEPTH_LIMIT_M`).
    pub health: HealthSettings,
    /// ArduSub's parameters kept at the surface (`FS_GCS_*`, `PILOT_SPEED_*`,
    /// `SYSID_THISMAV`).
    pub surface: SurfaceSettings,
}

/// The compass's heading-dependent deviation as the ground station shows it, in degrees
/// (`COMPASS_DEV_SIN`, `COMPASS_DEV_COS`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CompassDeviationDeg {
    /// Coefficient of `sin(psi)` (degrees).
    pub sin_deg: f32,
    /// Coefficient of `cos(psi)` (degrees).
    pub cos_deg: f32,
}

impl CompassDeviationDeg {
    /// The calibration the vehicle takes (radians).
    pub fn to_calibration(self) -> CompassCalibration {
        CompassCalibration {
            sin_rad: self.sin_deg.to_radians(),
            cos_rad: self.cos_deg.to_radians(),
        }
    }

    /// A calibration (radians) as degrees.
    pub fn of(cal: &CompassCalibration) -> Self {
        Self {
            sin_deg: cal.sin_rad.to_degrees(),
            cos_deg: cal.cos_rad.to_degrees(),
        }
    }
}

/// The mission speed unless a ground station sets `MIS_SPEED`: the scenarios' survey speed.
pub const MISSION_SPEED_M_S: f32 = 0.25;
/// Slowest mission speed taken (m/s): slower, the laws' feasible references stall.
pub const MIN_MISSION_SPEED_M_S: f32 = 0.05;

impl Settings {
    /// Default gains and timeouts on `vehicle`.
    pub fn new(vehicle: VehicleParams) -> Self {
        Self {
            gains: Gains::default(),
            failsafe: FailsafeSeconds::of(&Failsafe::DEFAULT),
            vehicle,
            mission_speed_m_s: MISSION_SPEED_M_S,
            compass: CompassDeviationDeg::default(),
            control_passkey: 0.0,
            joystick: JoystickSettings::default(),
            health: HealthSettings::default(),
            surface: SurfaceSettings::default(),
        }
    }

    /// The checks the vehicle will make, here first, with a reason naming the value.
    pub fn check(&self, group: Group) -> Result<()> {
        match group {
            Group::Tracking | Group::Paper => {
                self.gains.validate().map_err(|e| anyhow!("{e}"))?;
            }
            Group::Failsafe => {
                self.failsafe.to_firmware()?;
            }
            Group::Vehicle => {
                crate::vehicle_file::check(&self.vehicle)?;
            }
            Group::Mission => {
                let max = protocol::limits::MAX_MISSION_SPEED_M_S;
                let v = self.mission_speed_m_s;
                if !(v.is_finite() && (MIN_MISSION_SPEED_M_S..=max).contains(&v)) {
                    bail!("MIS_SPEED must be {MIN_MISSION_SPEED_M_S}-{max} m/s");
                }
            }
            Group::Control => {
                let k = self.control_passkey;
                if !(k.is_finite() && k.fract() == 0.0 && (0.0..=MAX_PASSKEY).contains(&k)) {
                    bail!("CTRL_PASSKEY must be a whole number from 0 to {MAX_PASSKEY}");
                }
            }
            Group::Joystick => self.joystick.check()?,
            Group::Health => {
                self.health.to_vehicle()?;
            }
            Group::Surface => self.surface.check()?,
            Group::Compass => {
                let c = self.compass;
                let max_deg = MAX_DEVIATION_RAD.to_degrees();
                match c.to_calibration().validate() {
                    Ok(_) => {}
                    Err(CalRefusal::OutOfRange) => bail!(
                        "COMPASS_DEV_SIN, COMPASS_DEV_COS: deviation {:.1} deg is over {max_deg:.0} deg",
                        c.sin_deg.hypot(c.cos_deg)
                    ),
                    Err(why) => bail!(
                        "COMPASS_DEV_SIN, COMPASS_DEV_COS: {}",
                        super::words::compass(why)
                    ),
                }
            }
        }
        Ok(())
    }
}

/// One parameter: its name and how to read and write it.
pub struct Param {
    /// MAVLink `param_id` (<= 16 characters).
    pub name: &'static str,
    /// Read it.
    pub get: fn(&Settings) -> f32,
    /// Write it.
    pub set: fn(&mut Settings, f32),
}

/// Which tether command carries a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// `SetTrackingGains`.
    Tracking,
    /// `SetPaperGains`.
    Paper,
    /// `SetFailsafe`.
    Failsafe,
    /// `SetVehicle` (refused by the vehicle while armed).
    Vehicle,
    /// Kept at the surface and sent with the next mission (`MissionItem`).
    Mission,
    /// `SetCompassCal` (refused by the vehicle while armed).
    Compass,
    /// Kept at the surface: who may take control.
    Control,
    /// Kept at the surface: the joystick's buttons and gain.
    Joystick,
    /// `SetHealth` (refused by the vehicle while armed, but for a depth limit made
    /// shallower or switched on).
    Health,
    /// Kept at the surface: the ground station failsafe, the pilot's depth rates, the
    /// system id.
    Surface,
}

/// The groups in the order a restart restores them: the vehicle first (the others are
/// checked against it on board), then the timeouts and the gains.
pub const GROUPS: [Group; 10] = [
    Group::Vehicle,
    Group::Health,
    Group::Compass,
    Group::Failsafe,
    Group::Tracking,
    Group::Paper,
    Group::Mission,
    Group::Control,
    Group::Joystick,
    Group::Surface,
];

impl Group {
    /// The parameters of this group as a ground station lists them.
    pub fn names(self) -> &'static str {
        match self {
            Group::Tracking => "TRK_*",
            Group::Paper => "PXZ_*, PXY_*",
            Group::Failsafe => "FS_*",
            Group::Vehicle => "VEH_*",
            Group::Mission => "MIS_SPEED",
            Group::Compass => "COMPASS_DEV_*",
            Group::Control => "CTRL_PASSKEY",
            Group::Joystick => "BTN*, JS_GAIN_*",
            Group::Health => "BATT_*, FS_LEAK_*, FS_PRESS_*, FS_TEMP_*, DEPTH_LIMIT_M",
            Group::Surface => "FS_GCS_*, PILOT_SPEED_*, SYSID_THISMAV",
        }
    }
}

/// Several groups' parameters, as a ground station lists them.
pub fn group_names(groups: &[Group]) -> String {
    groups
        .iter()
        .map(|g| g.names())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The values of `param` the checks take with every other parameter as in `settings`: the
/// interval around its value in force, found by search (the checks are the firmware's, so
/// the bounds are what the vehicle takes, not a copy of them). `None` when the value in
/// force itself is refused.
pub fn allowed_range(settings: &Settings, param: &Param) -> Option<(f32, f32)> {
    let group = group(param);
    let ok = |v: f32| {
        let mut s = *settings;
        (param.set)(&mut s, v);
        s.check(group).is_ok()
    };
    let v0 = (param.get)(settings);
    if !ok(v0) {
        return None;
    }
    // Out from the value in force by doubling steps to the first value refused (or the
    // search's end), then halving the gap between the last taken and the first refused.
    let edge = |dir: f32| -> f32 {
        const FARTHEST: f32 = 1.0e9;
        let mut taken = v0;
        let mut step = v0.abs().max(1.0) * 1e-3;
        let refused = loop {
            let next = v0 + dir * step;
            if next.abs() > FARTHEST {
                return dir * FARTHEST;
            }
            if !ok(next) {
                break next;
            }
            taken = next;
            step *= 2.0;
        };
        let (mut a, mut b) = (taken, refused);
        for _ in 0..48 {
            let mid = 0.5 * (a + b);
            if mid == a || mid == b {
                break;
            }
            if ok(mid) {
                a = mid;
            } else {
                b = mid;
            }
        }
        a
    };
    Some((edge(-1.0), edge(1.0)))
}

/// A number as an operator reads it: up to 4 significant digits, no trailing zeros.
pub fn show(v: f32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 6) as usize;
    let s = format!("{v:.digits$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Largest `CTRL_PASSKEY` (six digits: exact in the parameter's 32-bit float).
pub const MAX_PASSKEY: f32 = 999_999.0;

impl Settings {
    /// `group`'s values taken from `from`; the others stay.
    pub fn take_group(&mut self, from: &Settings, group: Group) {
        match group {
            Group::Tracking => self.gains.tracking = from.gains.tracking,
            Group::Paper => {
                self.gains.paper_xz = from.gains.paper_xz;
                self.gains.paper_xy = from.gains.paper_xy;
            }
            Group::Failsafe => self.failsafe = from.failsafe,
            Group::Vehicle => self.vehicle = from.vehicle,
            Group::Mission => self.mission_speed_m_s = from.mission_speed_m_s,
            Group::Compass => self.compass = from.compass,
            Group::Control => self.control_passkey = from.control_passkey,
            Group::Joystick => self.joystick = from.joystick,
            Group::Health => self.health = from.health,
            Group::Surface => self.surface = from.surface,
        }
    }

    /// True when `other` holds the same values of `group`.
    pub fn same_group(&self, other: &Settings, group: Group) -> bool {
        let mut mixed = *self;
        mixed.take_group(other, group);
        mixed == *self
    }

    /// The passkey `CHANGE_OPERATOR_CONTROL` must carry, none while `CTRL_PASSKEY` is 0.
    pub fn passkey(&self) -> Option<String> {
        let k = self.control_passkey;
        (k >= 1.0 && k.is_finite()).then(|| format!("{}", k as u32))
    }
}

macro_rules! params {
    ($($name:literal => $($field:ident).+),* $(,)?) => {
        &[$(Param {
            name: $name,
            get: |s| s.$($field).+,
            set: |s, v| s.$($field).+ = v,
        }),*]
    };
}

/// Every parameter, in the order of `PARAM_REQUEST_LIST`.
pub const PARAMS: &[Param] = params![
    "TRK_HAND_M" => gains.tracking.hand_m,
    "TRK_XY_KP" => gains.tracking.xy_kp,
    "TRK_XY_KD" => gains.tracking.xy_kd,
    "TRK_XY_KI" => gains.tracking.xy_ki,
    "TRK_XZ_KP" => gains.tracking.xz_kp,
    "TRK_XZ_KD" => gains.tracking.xz_kd,
    "TRK_XZ_KI" => gains.tracking.xz_ki,
    "TRK_PITCH_KP" => gains.tracking.pitch_kp,
    "TRK_PITCH_KD" => gains.tracking.pitch_kd,
    "TRK_PITCH_MAX" => gains.tracking.pitch_max_rad,
    "TRK_DEPTH_KP" => gains.tracking.depth_kp,
    "TRK_DEPTH_KD" => gains.tracking.depth_kd,
    "TRK_DEPTH_KI" => gains.tracking.depth_ki,
    "TRK_YAW_KP" => gains.tracking.yaw_kp,
    "TRK_YAW_KD" => gains.tracking.yaw_kd,
    "TRK_ERR_LIM_M" => gains.tracking.error_limit_m,
    "TRK_INT_LIM" => gains.tracking.integral_limit_m_s2,
    "TRK_CUR_OBS" => gains.tracking.current_observer_rad_s,
    "PXZ_K" => gains.paper_xz.k,
    "PXZ_C1W" => gains.paper_xz.c1w,
    "PXZ_C2W" => gains.paper_xz.c2w,
    "PXZ_C1Q" => gains.paper_xz.c1q,
    "PXZ_C2Q" => gains.paper_xz.c2q,
    "PXZ_CQ" => gains.paper_xz.cq,
    "PXZ_C1" => gains.paper_xz.c1,
    "PXZ_C2" => gains.paper_xz.c2,
    "PXY_K" => gains.paper_xy.k,
    "PXY_C1U" => gains.paper_xy.c1u,
    "PXY_C2U" => gains.paper_xy.c2u,
    "PXY_C1R" => gains.paper_xy.c1r,
    "PXY_C2R" => gains.paper_xy.c2r,
    "PXY_CR" => gains.paper_xy.cr,
    "PXY_C3" => gains.paper_xy.c3,
    "PXY_C4" => gains.paper_xy.c4,
    "FS_HB_NEUTRAL" => failsafe.heartbeat_neutral_s,
    "FS_HB_DISARM" => failsafe.heartbeat_disarm_s,
    "FS_NAV_STALE" => failsafe.nav_stale_s,
    "FS_PILOT_STALE" => failsafe.pilot_stale_s,
    "VEH_MASS" => vehicle.mass_kg,
    "VEH_XUDOT" => vehicle.x_udot_kg,
    "VEH_YVDOT" => vehicle.y_vdot_kg,
    "VEH_ZWDOT" => vehicle.z_wdot_kg,
    "VEH_MQDOT" => vehicle.m_qdot_kg_m2,
    "VEH_NRDOT" => vehicle.n_rdot_kg_m2,
    "VEH_XU" => vehicle.x_u,
    "VEH_YV" => vehicle.y_v,
    "VEH_ZW" => vehicle.z_w,
    "VEH_MQ" => vehicle.m_q,
    "VEH_NR" => vehicle.n_r,
    "VEH_XUU" => vehicle.x_uu,
    "VEH_YVV" => vehicle.y_vv,
    "VEH_ZWW" => vehicle.z_ww,
    "VEH_MQQ" => vehicle.m_qq,
    "VEH_NRR" => vehicle.n_rr,
    "VEH_IX" => vehicle.i_x_kg_m2,
    "VEH_IY" => vehicle.i_y_kg_m2,
    "VEH_IZ" => vehicle.i_z_kg_m2,
    "VEH_ZG" => vehicle.z_g_m,
    "VEH_GRAVITY" => vehicle.gravity_m_s2,
    "VEH_BUOY" => vehicle.buoyancy_offset_n,
    "VEH_THR_ARM" => vehicle.thruster_lever_arm_m,
    "VEH_THR_FWD" => vehicle.thrust_max_forward_n,
    "VEH_THR_REV" => vehicle.thrust_max_reverse_n,
    "VEH_THR_TAU" => vehicle.thruster_time_constant_s,
    "VEH_PWM_MIN" => vehicle.pulse.min_us,
    "VEH_PWM_NEUTRAL" => vehicle.pulse.neutral_us,
    "VEH_PWM_MAX" => vehicle.pulse.max_us,
    "VEH_PWM_DEADBAND" => vehicle.pulse.deadband_us,
    "VEH_PWM_LINEAR" => vehicle.pulse.linear_fraction,
    "MIS_SPEED" => mission_speed_m_s,
    "COMPASS_DEV_SIN" => compass.sin_deg,
    "COMPASS_DEV_COS" => compass.cos_deg,
    "CTRL_PASSKEY" => control_passkey,
    // ArduSub's names where the meaning is the same: the same settings.
    "FS_PILOT_TIMEOUT" => failsafe.pilot_stale_s,
];

macro_rules! buttons {
    ($($i:literal),*) => {
        &[$(
            Param {
                name: concat!("BTN", stringify!($i), "_FUNCTION"),
                get: |s| s.joystick.buttons[$i][0],
                set: |s, v| s.joystick.buttons[$i][0] = v,
            },
            Param {
                name: concat!("BTN", stringify!($i), "_SFUNCTION"),
                get: |s| s.joystick.buttons[$i][1],
                set: |s, v| s.joystick.buttons[$i][1] = v,
            },
        )*]
    };
}

/// ArduSub's joystick parameters (`joystick`): the buttons' functions and the gain. Kept at
/// the surface and saved with the project's.
pub const JOYSTICK: &[Param] = buttons![0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];
/// The joystick gain's parameters.
pub const JOYSTICK_GAIN: &[Param] = params![
    "JS_GAIN_DEFAULT" => joystick.gain_default,
    "JS_GAIN_MAX" => joystick.gain_max,
    "JS_GAIN_MIN" => joystick.gain_min,
    "JS_GAIN_STEPS" => joystick.gain_steps,
];

/// The vehicle's health parameters (`SetHealth`), ArduSub's names where ArduSub has one.
pub const HEALTH: &[Param] = params![
    "BATT_CAPACITY" => health.capacity_mah,
    "BATT_LOW_VOLT" => health.low_volt,
    "BATT_CRT_VOLT" => health.crt_volt,
    "BATT_LOW_MAH" => health.low_mah,
    "BATT_CRT_MAH" => health.crt_mah,
    "BATT_FS_LOW_ACT" => health.fs_low_act,
    "BATT_FS_CRT_ACT" => health.fs_crt_act,
    "BATT_LOW_TIMER" => health.low_timer_s,
    "BATT_VOLT_MULT" => health.volt_mult,
    "BATT_AMP_PERVLT" => health.amp_pervlt,
    "BATT_AMP_OFFSET" => health.amp_offset_v,
    "BATT_EMPTY_VOLT" => health.empty_volt,
    "FS_LEAK_ENABLE" => health.leak_enable,
    "LEAK1_PIN" => health.leak1_pin,
    "FS_PRESS_ENABLE" => health.press_enable,
    "FS_PRESS_MAX" => health.press_max_pa,
    "FS_TEMP_ENABLE" => health.temp_enable,
    "FS_TEMP_MAX" => health.temp_max_c,
    "DEPTH_LIMIT_M" => health.depth_limit_m,
    "SURFACE_END" => health.surface_end,
];

/// ArduSub's parameters kept at the surface.
pub const SURFACE: &[Param] = params![
    "FS_GCS_ENABLE" => surface.gcs_enable,
    "FS_GCS_TIMEOUT" => surface.gcs_timeout_s,
    "PILOT_SPEED_UP" => surface.pilot_speed_up_cm_s,
    "PILOT_SPEED_DN" => surface.pilot_speed_dn_cm_s,
    "SYSID_THISMAV" => surface.sysid_thismav,
];

/// The parameters saved: the project's, ArduSub's joystick ones, the vehicle's health and
/// the surface's own.
pub fn saved() -> impl Iterator<Item = &'static Param> {
    PARAMS
        .iter()
        .chain(JOYSTICK)
        .chain(JOYSTICK_GAIN)
        .chain(HEALTH)
        .chain(SURFACE)
}

/// ArduSub's parameters whose meaning here is the same, under their own names: the same
/// settings as the project's (`FS_PILOT_TIMEOUT` is `FS_PILOT_STALE`; `WPNAV_SPEED` is
/// `MIS_SPEED` in cm/s), and `ARMING_CHECK`, read-only 1: the vehicle's pre-arm checks
/// always run (ground stations warn "Arming checks disabled" without it).
pub const ARDUSUB: &[Param] = &[
    Param {
        name: "WPNAV_SPEED",
        get: |s| s.mission_speed_m_s * 100.0,
        set: |s, v| s.mission_speed_m_s = v / 100.0,
    },
    Param {
        name: "ARMING_CHECK",
        get: |_| 1.0,
        set: |_, _| {},
    },
];

/// Parameters shown but not settable, with the reason: the ESCs' neutral pulse is
/// the ESC's constant, not part of a description a ground station may move.
pub const READ_ONLY: &[(&str, &str)] = &[
    (
        "VEH_PWM_NEUTRAL",
        "neutral is the ESC's constant, not a setting",
    ),
    (
        "ARMING_CHECK",
        "the vehicle's pre-arm checks always run (1: all)",
    ),
];

/// Why a parameter is read-only, if it is.
pub fn read_only(name: &str) -> Option<&'static str> {
    READ_ONLY
        .iter()
        .find(|(n, _)| *n == name)
        .map(|(_, why)| *why)
}

/// Every parameter listed: the project's, then ArduSub's names.
pub fn all() -> impl Iterator<Item = &'static Param> {
    saved().chain(ARDUSUB)
}

/// How many parameters are listed.
pub fn count() -> usize {
    PARAMS.len()
        + JOYSTICK.len()
        + JOYSTICK_GAIN.len()
        + HEALTH.len()
        + SURFACE.len()
        + ARDUSUB.len()
}

/// Parameter `index` of the list.
pub fn at(index: usize) -> Option<&'static Param> {
    all().nth(index)
}

/// A parameter by name, with its index.
pub fn find(name: &str) -> Option<(usize, &'static Param)> {
    all().enumerate().find(|(_, p)| p.name == name)
}

/// The tether command group of a parameter.
pub fn group(p: &Param) -> Group {
    if HEALTH.iter().any(|h| h.name == p.name) {
        return Group::Health;
    }
    if SURFACE.iter().any(|h| h.name == p.name) {
        return Group::Surface;
    }
    match p.name.split('_').next() {
        Some("TRK") => Group::Tracking,
        Some("FS") => Group::Failsafe,
        Some("VEH") => Group::Vehicle,
        Some("MIS") => Group::Mission,
        Some("COMPASS") => Group::Compass,
        Some("CTRL") | Some("ARMING") => Group::Control,
        Some("WPNAV") => Group::Mission,
        Some("JS") => Group::Joystick,
        Some(b) if b.starts_with("BTN") => Group::Joystick,
        _ => Group::Paper,
    }
}

#[cfg(test)]
mod tests;
