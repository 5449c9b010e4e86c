//! The installed thrusters' published curve (a thruster file, `host-sim identify
//! --thrusters FILE`): the force scale a builder knows without weighing anything. The
//! record's pulses become thrust through this curve instead of the prior's, and the
//! identification takes its thrust ahead as right within the datasheet's stated error, so
//! that the net buoyancy, the masses and the drags come out in newtons.
//!
//! ```toml
//! max_forward_n = 13.5   # thrust at the longest pulse (N), the datasheet's
//! max_reverse_n = 10.1   # thrust magnitude at the shortest pulse (N)
//! error = 0.05           # the datasheet's stated error, a 95 % bound (+-5 %)
//! # [pulse]              # the ESCs' pulse curve; the prior's when absent
//! ```

use super::physical::Anchor;
use super::regression::Z_95;
use anyhow::{anyhow, bail, Context, Result};
use controller_core::params::{PulseCurve, VehicleParams};
use serde::Deserialize;
use std::path::Path;

/// Largest datasheet error taken (a fraction): beyond it the curve fixes nothing.
pub const MAX_ERROR: f64 = 0.5;

/// A thruster file.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThrustCurve {
    /// Thrust at the longest pulse (N).
    pub max_forward_n: f64,
    /// Thrust magnitude at the shortest pulse (N).
    pub max_reverse_n: f64,
    /// The datasheet's stated error of the thrust, a 95 % bound as a fraction (0.05 is
    /// +-5 %).
    pub error: f64,
    /// The ESCs' pulse curve, when it is not the prior's.
    #[serde(default)]
    pub pulse: Option<PulseCurve>,
}

impl ThrustCurve {
    /// Parse a thruster file's text (`name` for the errors).
    pub fn parse(text: &str, name: &str) -> Result<Self> {
        let c: Self = toml::from_str(text).with_context(|| format!("thruster file {name}"))?;
        c.check().with_context(|| format!("thruster file {name}"))?;
        Ok(c)
    }

    /// Read a thruster file.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        Self::parse(&text, &path.display().to_string())
    }

    /// Positive finite thrusts, an error in (0, [`MAX_ERROR`]].
    pub fn check(&self) -> Result<()> {
        for (name, v) in [
            ("max_forward_n", self.max_forward_n),
            ("max_reverse_n", self.max_reverse_n),
        ] {
            if !(v.is_finite() && v > 0.0) {
                bail!("{name} = {v}: a thrust in newtons, > 0");
            }
        }
        if !(self.error.is_finite() && self.error > 0.0 && self.error <= MAX_ERROR) {
            bail!(
                "error = {}: the datasheet's stated error as a fraction, in (0, {MAX_ERROR}] \
                 (0.05 is +-5 %)",
                self.error
            );
        }
        Ok(())
    }

    /// The prior with this curve's thrusters (and pulse curve, when given): the record's
    /// thrust is computed with it. Refused when the result is not a valid vehicle.
    pub fn installed_in(&self, prior: &VehicleParams) -> Result<VehicleParams> {
        let mut p = *prior;
        p.thrust_max_forward_n = self.max_forward_n as f32;
        p.thrust_max_reverse_n = self.max_reverse_n as f32;
        if let Some(pulse) = self.pulse {
            p.pulse = pulse;
        }
        p.validate()
            .map_err(|e| anyhow!("the prior with these thrusters: {e}"))?;
        Ok(p)
    }

    /// The anchor this curve gives: its thrust ahead, one standard deviation the stated
    /// 95 % bound over 1.96; with a weighed net buoyancy `(value, std)` too, both.
    pub fn anchor(&self, net_buoyancy: Option<(f64, f64)>) -> Anchor {
        let rel_std = self.error / Z_95;
        match net_buoyancy {
            None => Anchor::ThrustCurve { rel_std },
            Some((value_n, std_n)) => Anchor::Both {
                curve_rel_std: rel_std,
                value_n,
                std_n,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thruster_file_is_read_and_bad_values_are_refused() {
        let c = ThrustCurve::parse(
            "max_forward_n = 13.5\nmax_reverse_n = 10.1\nerror = 0.05\n",
            "t",
        )
        .unwrap();
        let p = c.installed_in(&VehicleParams::OBSERVER).unwrap();
        assert_eq!(p.thrust_max_forward_n, 13.5);
        assert_eq!(p.thrust_max_reverse_n, 10.1);
        assert_eq!(p.pulse, VehicleParams::OBSERVER.pulse);
        match c.anchor(None) {
            Anchor::ThrustCurve { rel_std } => assert!((rel_std - 0.05 / 1.96).abs() < 1e-4),
            a => panic!("{a:?}"),
        }
        for bad in [
            "max_forward_n = 0.0\nmax_reverse_n = 10.1\nerror = 0.05\n",
            "max_forward_n = 13.5\nmax_reverse_n = -1.0\nerror = 0.05\n",
            "max_forward_n = 13.5\nmax_reverse_n = 10.1\nerror = 0.0\n",
            "max_forward_n = 13.5\nmax_reverse_n = 10.1\nerror = 0.9\n",
            "max_forward_n = 13.5\nmax_reverse_n = 10.1\n",
            "max_forward_n = 13.5\nmax_reverse_n = 10.1\nerror = 0.05\nvolts = 16\n",
        ] {
            assert!(ThrustCurve::parse(bad, "t").is_err(), "{bad}");
        }
    }
}
