//! `[identification]`: the vehicle flies the identification manoeuvre
//! (`firmware::autopilot::IdentFlight`, the tether's `StartIdent`) in `Hold` from the
//! start, then stays in `Hold` at its start point; the run's `timeseries.csv` is what
//! `host-sim identify` reads. Flown by the firmware (`hil`); a software `run` refuses it.
//!
//! The plant is the scenario's vehicle (`vehicle = ...`, the truth); the firmware flies
//! with `prior` (the description a builder has before identifying: the Observer's unless
//! named), as a real vehicle flies with the file the surface gave it.

use anyhow::{bail, Context, Result};
use controller_core::params::VehicleParams;
use firmware::autopilot::IDENT_DURATION_S;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `[identification]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IdentificationSpec {
    /// Radius of the room around the start point (m, 3-100), default 30.
    #[serde(default = "d_radius")]
    pub radius_m: f64,
    /// Half-height of the depth band around the start depth (m, 0.5-20), default 6.
    #[serde(default = "d_band")]
    pub depth_band_m: f64,
    /// The vehicle file the firmware flies with; the Observer's when absent. A relative
    /// path is taken from the scenario file's folder, else the working directory.
    #[serde(default)]
    pub prior: Option<String>,
    /// The prior's parameters (read from `prior` when the scenario is loaded).
    #[serde(skip, default = "observer")]
    pub prior_params: VehicleParams,
}

fn d_radius() -> f64 {
    30.0
}
fn d_band() -> f64 {
    6.0
}
fn observer() -> VehicleParams {
    VehicleParams::OBSERVER
}

impl Default for IdentificationSpec {
    fn default() -> Self {
        Self {
            radius_m: d_radius(),
            depth_band_m: d_band(),
            prior: None,
            prior_params: observer(),
        }
    }
}

impl IdentificationSpec {
    /// Read the prior's file (relative to `dir` when it is there).
    pub fn load_prior(&mut self, dir: Option<&Path>) -> Result<()> {
        if let Some(file) = &self.prior {
            let beside = dir.map(|d| d.join(file)).filter(|p| p.exists());
            let path = beside.unwrap_or_else(|| Path::new(file).to_path_buf());
            self.prior_params =
                topside::vehicle_file::load(&path).context("key `identification.prior`")?;
        }
        Ok(())
    }

    /// The room in range, the start deeper than the band, the run long enough to fly it.
    pub fn check(&self, start_depth_m: f64, duration_s: f64) -> Result<()> {
        if !(3.0..=100.0).contains(&self.radius_m) {
            bail!(
                "identification.radius_m = {} must be 3-100 m",
                self.radius_m
            );
        }
        if !(0.5..=20.0).contains(&self.depth_band_m) {
            bail!(
                "identification.depth_band_m = {} must be 0.5-20 m",
                self.depth_band_m
            );
        }
        if start_depth_m <= self.depth_band_m {
            bail!(
                "identification: the start depth {start_depth_m} m must be deeper than the depth band {} m",
                self.depth_band_m
            );
        }
        let needed = f64::from(IDENT_DURATION_S);
        if duration_s < needed {
            bail!("identification: duration_s = {duration_s} is shorter than the manoeuvre ({needed} s)");
        }
        Ok(())
    }
}
