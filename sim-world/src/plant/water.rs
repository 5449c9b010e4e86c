//! The water around the vehicle beyond a constant current: a current that changes
//! in time and with depth, and the seabed. The `[water]` table of a scenario:
//!
//! ```toml
//! [water]
//! seabed_depth_m = 20.0                        # the plant cannot go deeper; the DVL loses
//!                                              # bottom lock above its max_altitude_m
//! current_time_profile = [[0.0, 0.0, 0.0, 0.0], [100.0, 0.0, 0.2, 0.0]]   # [t_s, cx, cy, cz]
//! current_depth_profile = [[0.0, 0.05, 0.0, 0.0], [10.0, 0.0, 0.0, 0.0]]  # [z_m, dcx, dcy, dcz]
//! ```
//!
//! The current at `(t, z)` is the time profile interpolated linearly at `t` (held at its
//! ends; `disturbance.current_m_s` when the profile is empty) plus the depth profile
//! interpolated at `z` (held at its ends; zero when empty). The plant is given the current
//! at each control tick (piecewise constant over a 10 ms period).
//!
//! `surface = true` puts the surface at `z = 0`: the plant cannot rise above it. It is off by
//! default so that the earlier scenarios (the paper's XZ law leaves the water in its failing
//! runs) keep their figures; a seabed is always a bound when given. A bound met is inelastic
//! (the velocity through it is removed) and reported in the summary's `boundary_contact`.

use crate::checks::{fin, pos};
use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};

/// `[water]`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WaterSpec {
    /// The surface `z = 0` bounds the plant.
    pub surface: bool,
    /// Depth of the seabed (m, down); none: deep water.
    pub seabed_depth_m: Option<f64>,
    /// `[[t_s, cx, cy, cz], ...]`: the current (inertial, m/s) at times, strictly increasing.
    pub current_time_profile: Vec<[f64; 4]>,
    /// `[[z_m, dcx, dcy, dcz], ...]`: added to the current at depths, strictly increasing.
    pub current_depth_profile: Vec<[f64; 4]>,
}

fn profile(key: &str, p: &[[f64; 4]]) -> Result<()> {
    for (i, row) in p.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            fin(&format!("{key}[{i}][{j}]"), *v)?;
        }
        if i > 0 && row[0] <= p[i - 1][0] {
            bail!(
                "{key}[{i}][0] must be after {key}[{}][0] (got {} <= {})",
                i - 1,
                row[0],
                p[i - 1][0]
            );
        }
        let speed = (row[1] * row[1] + row[2] * row[2] + row[3] * row[3]).sqrt();
        if speed > 5.0 {
            bail!("{key}[{i}] is a current of {speed:.2} m/s: more than 5 m/s");
        }
    }
    Ok(())
}

/// Linear interpolation of `[x, a, b, c]` rows at `x`, held at the ends.
fn interpolate(p: &[[f64; 4]], x: f64) -> Option<[f64; 3]> {
    let first = p.first()?;
    let last = p.last()?;
    if x <= first[0] {
        return Some([first[1], first[2], first[3]]);
    }
    if x >= last[0] {
        return Some([last[1], last[2], last[3]]);
    }
    p.windows(2).find_map(|w| {
        let (a, b) = (w[0], w[1]);
        (x >= a[0] && x <= b[0]).then(|| {
            let s = (x - a[0]) / (b[0] - a[0]);
            [1, 2, 3].map(|i| a[i] + s * (b[i] - a[i]))
        })
    })
}

impl WaterSpec {
    /// Check every key; the error names it.
    pub fn validate(&self) -> Result<()> {
        if let Some(d) = self.seabed_depth_m {
            pos("water.seabed_depth_m", d)?;
        }
        profile("water.current_time_profile", &self.current_time_profile)?;
        profile("water.current_depth_profile", &self.current_depth_profile)?;
        Ok(())
    }

    /// A start depth `z_m` must be in the water: between the surface and the seabed.
    pub fn check_start_depth(&self, z_m: f64) -> Result<()> {
        if self.surface && z_m < 0.0 {
            bail!("initial.z_m = {z_m} is above the surface (z = 0)");
        }
        if let Some(d) = self.seabed_depth_m {
            if z_m > d {
                bail!("initial.z_m = {z_m} is below water.seabed_depth_m = {d}");
            }
        }
        Ok(())
    }

    /// Does the current change in time or with depth?
    pub fn current_varies(&self) -> bool {
        !self.current_time_profile.is_empty() || !self.current_depth_profile.is_empty()
    }

    /// The current (inertial, m/s) at time `t_s` and depth `z_m`; `constant_m_s` is the
    /// scenario's `disturbance.current_m_s`, used when there is no time profile.
    pub fn current_at(&self, constant_m_s: [f64; 3], t_s: f64, z_m: f64) -> [f64; 3] {
        let base = interpolate(&self.current_time_profile, t_s).unwrap_or(constant_m_s);
        let shear = interpolate(&self.current_depth_profile, z_m).unwrap_or([0.0; 3]);
        [0, 1, 2].map(|i| base[i] + shear[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_current_is_interpolated_in_time_and_depth_and_held_at_the_ends() {
        let w = WaterSpec {
            surface: true,
            seabed_depth_m: None,
            current_time_profile: vec![[10.0, 0.0, 0.0, 0.0], [110.0, 0.0, 0.2, 0.0]],
            current_depth_profile: vec![[0.0, 0.1, 0.0, 0.0], [10.0, 0.0, 0.0, 0.0]],
        };
        w.validate().unwrap();
        let c = w.current_at([9.0; 3], 60.0, 5.0);
        assert!((c[0] - 0.05).abs() < 1e-12 && (c[1] - 0.1).abs() < 1e-12 && c[2] == 0.0);
        assert_eq!(w.current_at([9.0; 3], 0.0, 20.0), [0.0; 3]);
        assert_eq!(w.current_at([9.0; 3], 500.0, -1.0), [0.1, 0.2, 0.0]);
        let constant = WaterSpec::default();
        assert!(!constant.current_varies());
        assert_eq!(
            constant.current_at([0.1, 0.2, 0.0], 5.0, 3.0),
            [0.1, 0.2, 0.0]
        );
    }

    #[test]
    fn bad_profiles_and_seabeds_are_refused_with_the_key_named() {
        let w = WaterSpec {
            current_time_profile: vec![[10.0, 0.0, 0.0, 0.0], [5.0, 0.0, 0.0, 0.0]],
            ..WaterSpec::default()
        };
        let e = format!("{:#}", w.validate().unwrap_err());
        assert!(e.contains("water.current_time_profile[1][0]"), "{e}");
        let w = WaterSpec {
            seabed_depth_m: Some(-1.0),
            ..WaterSpec::default()
        };
        let e = format!("{:#}", w.validate().unwrap_err());
        assert!(e.contains("water.seabed_depth_m"), "{e}");
        let w = WaterSpec {
            current_depth_profile: vec![[0.0, 9.0, 0.0, 0.0]],
            ..WaterSpec::default()
        };
        let e = format!("{:#}", w.validate().unwrap_err());
        assert!(e.contains("water.current_depth_profile[0]"), "{e}");
    }
}
