//! The DVL's velocity in the uplink: the node parses and gates its DVL's reports
//! (`sensors::dvl::DvlPort`, as the onboard layout does) and sends only an admitted velocity,
//! in integers: 13 bytes at most in the uplink, where the A50's raw `wrz` lines (150-190 B,
//! up to 15 a second) would keep the link more than half busy at 115,200 Bd.

use controller_core::nav::DvlFix;
use serde::{Deserialize, Serialize};

/// Largest figure of merit the uplink carries, m/s (`u8` millimetres a second): a node's
/// DVL gate may admit no more (checked when the node starts).
pub const MAX_UPLINK_DVL_STD_M_S: f32 = u8::MAX as f32 * 1e-3;

/// Largest age the uplink carries, milliseconds: a report older than this when the uplink is
/// sealed (the A50's own latency is at most 1 s) is not sent.
pub const MAX_UPLINK_DVL_AGE_MS: u16 = u16::MAX;

/// An admitted DVL velocity, as the uplink carries it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct UplinkDvl {
    /// The report's age when the uplink is sealed, milliseconds: the node's clock at the
    /// sealing less the report's time of validity on that clock (its arrival less the DVL's
    /// own latency and the line's time on the wire).
    pub age_ms: u16,
    /// Surge and sway over the bottom, body axes, millimetres a second (the A50 reads to
    /// 20 m/s; an `i16` holds 32.7).
    pub velocity_mm_s: [i16; 2],
    /// The figure of merit (the estimator's standard deviation), millimetres a second, at
    /// most 255.
    pub std_mm_s: u8,
}

impl UplinkDvl {
    /// `fix` (its time of validity on the node's clock) as sent at `now_us`; `None` when it
    /// is older than [`MAX_UPLINK_DVL_AGE_MS`], stamped after `now_us`, or has a value that
    /// does not fit (NaN, a speed over 32.7 m/s, a figure of merit over 0.255 m/s).
    pub fn from_fix(fix: &DvlFix, now_us: u64) -> Option<Self> {
        Self::ageless(fix)?.aged(fix.t_us, now_us)
    }

    /// `fix`'s velocity and figure of merit, its age left at 0 ([`Self::aged`] sets it).
    pub fn ageless(fix: &DvlFix) -> Option<Self> {
        // Rounded to the nearest millimetre a second (half away from zero: the cast
        // truncates), within +-`max`; NaN fails the comparison.
        let mm = |v: f32, max: f32| {
            let x = v * 1e3;
            let r = if x >= 0.0 { x + 0.5 } else { x - 0.5 };
            (r.abs() < max + 1.0).then_some(r)
        };
        let [u, v] = fix.velocity_m_s;
        let max_v = f32::from(i16::MAX);
        Some(Self {
            age_ms: 0,
            velocity_mm_s: [mm(u, max_v)? as i16, mm(v, max_v)? as i16],
            std_mm_s: mm(fix.std_m_s, f32::from(u8::MAX)).filter(|s| *s >= 0.0)? as u8,
        })
    }

    /// With its age at `now_us` of a time of validity `t_us` (rounded to the millisecond,
    /// 32-bit arithmetic: cheap in the pass that seals the uplink); `None` when `t_us` is
    /// after `now_us` or older than [`MAX_UPLINK_DVL_AGE_MS`].
    pub fn aged(self, t_us: u64, now_us: u64) -> Option<Self> {
        let age_us = u32::try_from(now_us.checked_sub(t_us)?).ok()?;
        let age_ms = u16::try_from(age_us.saturating_add(500) / 1_000).ok()?;
        Some(Self { age_ms, ..self })
    }

    /// The fix again, its time of validity `t_us` on the receiver's clock (a figure of
    /// merit of 0 taken as 1 mm/s, the resolution).
    pub fn to_fix(&self, t_us: u64) -> DvlFix {
        let [u, v] = self.velocity_mm_s;
        DvlFix {
            t_us,
            velocity_m_s: [f32::from(u) / 1e3, f32::from(v) / 1e3],
            std_m_s: f32::from(self.std_mm_s.max(1)) / 1e3,
        }
    }
}
