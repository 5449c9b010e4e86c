//! ArduSub's parameters kept at the surface: the ground station's heartbeat failsafe
//! (`FS_GCS_ENABLE`, `FS_GCS_TIMEOUT`), the pilot's depth rates in ALT_HOLD
//! (`PILOT_SPEED_UP`, `PILOT_SPEED_DN`) and the surface's MAVLink system id
//! (`SYSID_THISMAV`, taken at the next start).

use anyhow::{bail, Result};

/// The surface's own ArduSub parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSettings {
    /// `FS_GCS_ENABLE`: 0 disabled, 1 warn only, 2 disarm, 3 depth hold, 4 surface.
    pub gcs_enable: f32,
    /// `FS_GCS_TIMEOUT`: heartbeat silence that trips it, s.
    pub gcs_timeout_s: f32,
    /// `PILOT_SPEED_UP`: fastest ascent the heave stick asks in ALT_HOLD, cm/s.
    pub pilot_speed_up_cm_s: f32,
    /// `PILOT_SPEED_DN`: fastest descent, cm/s (0: `PILOT_SPEED_UP`).
    pub pilot_speed_dn_cm_s: f32,
    /// `SYSID_THISMAV`: the surface's MAVLink system id (taken at the next start).
    pub sysid_thismav: f32,
}

/// The ground station failsafe's action (`FS_GCS_ENABLE`, ArduSub's numbers).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GcsFailsafe {
    /// 0: nothing.
    Disabled,
    /// 1: said only.
    Warn,
    /// 2: disarm.
    Disarm,
    /// 3: ALT_HOLD (the depth held, sticks centred).
    DepthHold,
    /// 4: SURFACE.
    Surface,
}

/// Shortest `FS_GCS_TIMEOUT` taken (s): stations send a heartbeat a second.
pub const MIN_GCS_TIMEOUT_S: f32 = 2.0;
/// Longest `FS_GCS_TIMEOUT` taken (s).
pub const MAX_GCS_TIMEOUT_S: f32 = 120.0;
/// `PILOT_SPEED_UP` / `PILOT_SPEED_DN` range (cm/s), ArduSub's.
pub const MIN_PILOT_SPEED_CM_S: f32 = 20.0;
/// Fastest pilot depth rate taken (cm/s), ArduSub's.
pub const MAX_PILOT_SPEED_CM_S: f32 = 500.0;

impl Default for SurfaceSettings {
    /// The failsafe off (the tether's own heartbeat failsafe covers a lost surface), ArduSub's
    /// 5 s timeout and 500 cm/s pilot rates, system id 1.
    fn default() -> Self {
        Self {
            gcs_enable: 0.0,
            gcs_timeout_s: 5.0,
            pilot_speed_up_cm_s: MAX_PILOT_SPEED_CM_S,
            pilot_speed_dn_cm_s: 0.0,
            sysid_thismav: 1.0,
        }
    }
}

impl SurfaceSettings {
    /// Every value within its range, with a reason naming the parameter.
    pub fn check(&self) -> Result<()> {
        let whole =
            |v: f32, lo: f32, hi: f32| v.is_finite() && v.fract() == 0.0 && (lo..=hi).contains(&v);
        if !whole(self.gcs_enable, 0.0, 4.0) {
            bail!("FS_GCS_ENABLE must be one of 0 disabled, 1 warn only, 2 disarm, 3 depth hold, 4 surface");
        }
        let t = self.gcs_timeout_s;
        if !(t.is_finite() && (MIN_GCS_TIMEOUT_S..=MAX_GCS_TIMEOUT_S).contains(&t)) {
            bail!("FS_GCS_TIMEOUT must be {MIN_GCS_TIMEOUT_S}-{MAX_GCS_TIMEOUT_S} s");
        }
        let up = self.pilot_speed_up_cm_s;
        if !(up.is_finite() && (MIN_PILOT_SPEED_CM_S..=MAX_PILOT_SPEED_CM_S).contains(&up)) {
            bail!("PILOT_SPEED_UP must be {MIN_PILOT_SPEED_CM_S}-{MAX_PILOT_SPEED_CM_S} cm/s");
        }
        let dn = self.pilot_speed_dn_cm_s;
        if !(dn.is_finite()
            && (dn == 0.0 || (MIN_PILOT_SPEED_CM_S..=MAX_PILOT_SPEED_CM_S).contains(&dn)))
        {
            bail!(
                "PILOT_SPEED_DN must be 0 (as PILOT_SPEED_UP) or {MIN_PILOT_SPEED_CM_S}-{MAX_PILOT_SPEED_CM_S} cm/s"
            );
        }
        if !whole(self.sysid_thismav, 1.0, 255.0) {
            bail!("SYSID_THISMAV must be a whole number from 1 to 255");
        }
        Ok(())
    }

    /// The ground station failsafe's action.
    pub fn gcs_failsafe(&self) -> GcsFailsafe {
        match self.gcs_enable as u8 {
            1 => GcsFailsafe::Warn,
            2 => GcsFailsafe::Disarm,
            3 => GcsFailsafe::DepthHold,
            4 => GcsFailsafe::Surface,
            _ => GcsFailsafe::Disabled,
        }
    }

    /// The system id `SYSID_THISMAV` names (None when out of range).
    pub fn system_id(&self) -> Option<u8> {
        let v = self.sysid_thismav;
        (v.is_finite() && v.fract() == 0.0 && (1.0..=255.0).contains(&v)).then_some(v as u8)
    }

    /// The heave stick in ALT_HOLD as ArduSub flies it: the stick (fraction of the largest
    /// heave force, positive down) asks a depth rate in proportion, at most `PILOT_SPEED_DN`
    /// down and `PILOT_SPEED_UP` up; the heave sent is the stick's, lessened as the measured
    /// depth rate (`depth_rate_m_s`, positive down) passes half the rate asked, to none at
    /// the rate asked. Never more than the stick, never the other way.
    pub fn limit_heave(&self, stick: f32, depth_rate_m_s: f32) -> f32 {
        if stick == 0.0 || !stick.is_finite() || !depth_rate_m_s.is_finite() {
            return if stick.is_finite() { stick } else { 0.0 };
        }
        let dn = if self.pilot_speed_dn_cm_s > 0.0 {
            self.pilot_speed_dn_cm_s
        } else {
            self.pilot_speed_up_cm_s
        };
        let max_m_s = if stick > 0.0 {
            dn
        } else {
            self.pilot_speed_up_cm_s
        } * 0.01;
        let asked = stick.abs() * max_m_s;
        // The rate along the stick's direction.
        let along = depth_rate_m_s * stick.signum();
        // Full stick up to half the rate asked, none at the rate asked and beyond: the
        // telemetry's delay and the vehicle's inertia carry it on past the point it eases.
        let margin = 0.5 * asked;
        let scale = ((asked - along) / margin).clamp(0.0, 1.0);
        stick * scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_pass_and_bad_values_are_refused_naming_the_parameter() {
        let d = SurfaceSettings::default();
        d.check().unwrap();
        let cases = [
            (
                SurfaceSettings {
                    gcs_enable: 5.0,
                    ..d
                },
                "FS_GCS_ENABLE must be one of",
            ),
            (
                SurfaceSettings {
                    gcs_timeout_s: 0.5,
                    ..d
                },
                "FS_GCS_TIMEOUT must be 2-120 s",
            ),
            (
                SurfaceSettings {
                    pilot_speed_up_cm_s: 10.0,
                    ..d
                },
                "PILOT_SPEED_UP must be 20-500",
            ),
            (
                SurfaceSettings {
                    pilot_speed_dn_cm_s: 600.0,
                    ..d
                },
                "PILOT_SPEED_DN must be 0",
            ),
            (
                SurfaceSettings {
                    sysid_thismav: 0.0,
                    ..d
                },
                "SYSID_THISMAV must be a whole number",
            ),
            (
                SurfaceSettings {
                    sysid_thismav: 2.5,
                    ..d
                },
                "SYSID_THISMAV must be a whole number",
            ),
        ];
        for (s, words) in cases {
            let e = format!("{:#}", s.check().unwrap_err());
            assert!(e.contains(words), "{e} (wanted {words})");
        }
    }

    #[test]
    fn the_heave_stick_asks_at_most_the_pilot_speeds() {
        let s = SurfaceSettings {
            pilot_speed_up_cm_s: 20.0,
            pilot_speed_dn_cm_s: 10.0,
            ..SurfaceSettings::default()
        };
        // At rest: the stick as given, either way.
        assert_eq!(s.limit_heave(1.0, 0.0), 1.0);
        assert_eq!(s.limit_heave(-0.5, 0.0), -0.5);
        // Full stick down asks 0.10 m/s: full thrust until 0.05, none at 0.10 or faster.
        assert_eq!(s.limit_heave(1.0, 0.04), 1.0);
        let mid = s.limit_heave(1.0, 0.075);
        assert!(mid > 0.0 && mid < 1.0, "{mid}");
        assert_eq!(s.limit_heave(1.0, 0.10), 0.0);
        assert_eq!(s.limit_heave(1.0, 0.5), 0.0);
        // Half stick down asks 0.05 m/s.
        assert_eq!(s.limit_heave(0.5, 0.05), 0.0);
        assert_eq!(s.limit_heave(0.5, 0.02), 0.5);
        // Up: PILOT_SPEED_UP (0.20 m/s), the depth rate negative.
        assert_eq!(s.limit_heave(-1.0, -0.09), -1.0);
        assert_eq!(s.limit_heave(-1.0, -0.20), 0.0);
        // Going the other way than asked: the stick whole.
        assert_eq!(s.limit_heave(1.0, -0.3), 1.0);
        // Never more than the stick, never reversed.
        for rate in [-1.0, -0.1, 0.0, 0.05, 0.2, 1.0] {
            for stick in [-1.0f32, -0.3, 0.3, 1.0] {
                let h = s.limit_heave(stick, rate);
                assert!(
                    h.abs() <= stick.abs() && h * stick >= 0.0,
                    "{stick} {rate} {h}"
                );
            }
        }
        // PILOT_SPEED_DN 0: down as fast as up.
        let same = SurfaceSettings {
            pilot_speed_dn_cm_s: 0.0,
            ..s
        };
        assert_eq!(same.limit_heave(1.0, 0.20), 0.0);
        assert_eq!(same.limit_heave(1.0, 0.09), 1.0);
    }

    #[test]
    fn the_gcs_failsafe_reads_ardusubs_numbers() {
        let mut s = SurfaceSettings::default();
        assert_eq!(s.gcs_failsafe(), GcsFailsafe::Disabled);
        for (v, a) in [
            (1.0, GcsFailsafe::Warn),
            (2.0, GcsFailsafe::Disarm),
            (3.0, GcsFailsafe::DepthHold),
            (4.0, GcsFailsafe::Surface),
        ] {
            s.gcs_enable = v;
            assert_eq!(s.gcs_failsafe(), a);
        }
        s.sysid_thismav = 2.0;
        assert_eq!(s.system_id(), Some(2));
    }
}
