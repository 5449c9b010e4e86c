//! The scenario's `[expect]` table: the targets its runs are judged against, and their checks.

use anyhow::{bail, Result};
use serde::{Deserialize, Serialize};
use sim_world::checks::{nonneg, pos};

fn d_settle() -> f64 {
    10.0
}

/// The `[expect]` table: what the scenario is for, as targets its runs are judged against
/// (the verdict of `summary.json`, the main table and the exit code). Every key is optional;
/// without the table a run shows its figures and no judgement. Errors are the true position
/// against the reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExpectSpec {
    /// The run is expected to diverge or lose control (the paper's XZ law unlimited); no
    /// other key may be given with it.
    #[serde(default)]
    pub diverges: bool,
    /// `true`: final error and last-20 % RMS under 10 cm; `false`: the law is expected not to
    /// track (over 10 cm, or diverged), as the paper's laws with the real limits.
    #[serde(default)]
    pub tracks: Option<bool>,
    /// Largest final position error (m).
    #[serde(default)]
    pub final_m: Option<f64>,
    /// Largest position error after `settle_s` (m).
    #[serde(default)]
    pub max_m: Option<f64>,
    /// The start transient left out of `max_m` (s), default 10.
    #[serde(default = "d_settle")]
    pub settle_s: f64,
    /// Largest RMS position error over the whole run (m).
    #[serde(default)]
    pub rms_m: Option<f64>,
    /// Largest RMS position error over the last 80 % of the run (m).
    #[serde(default)]
    pub rms_last80_m: Option<f64>,
    /// Largest RMS position error over the last 20 % of the run (m).
    #[serde(default)]
    pub tail_rms_m: Option<f64>,
    /// Largest RMS of the navigation position against the truth after 10 s (m).
    #[serde(default)]
    pub estimation_rms_m: Option<f64>,
    /// Every USBL outlier the estimator received was rejected on its gate.
    #[serde(default)]
    pub outliers_rejected: bool,
}

impl Default for ExpectSpec {
    fn default() -> Self {
        Self {
            diverges: false,
            tracks: None,
            final_m: None,
            max_m: None,
            settle_s: d_settle(),
            rms_m: None,
            rms_last80_m: None,
            tail_rms_m: None,
            estimation_rms_m: None,
            outliers_rejected: false,
        }
    }
}

impl ExpectSpec {
    /// The numeric bounds given: `(key, bound)`.
    pub fn bounds(&self) -> Vec<(&'static str, f64)> {
        [
            ("final_m", self.final_m),
            ("max_m", self.max_m),
            ("rms_m", self.rms_m),
            ("rms_last80_m", self.rms_last80_m),
            ("tail_rms_m", self.tail_rms_m),
            ("estimation_rms_m", self.estimation_rms_m),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .collect()
    }

    pub(super) fn validate(&self, duration_s: f64) -> Result<()> {
        for (k, v) in self.bounds() {
            pos(&format!("expect.{k}"), v)?;
        }
        nonneg("expect.settle_s", self.settle_s)?;
        if self.settle_s >= duration_s {
            bail!(
                "expect.settle_s ({} s) leaves nothing of the run ({} s) to judge",
                self.settle_s,
                duration_s
            );
        }
        if self.diverges
            && (self.tracks.is_some() || !self.bounds().is_empty() || self.outliers_rejected)
        {
            bail!("expect.diverges = true takes no other target (a diverging run has no figures to bound)");
        }
        if self.tracks == Some(false) && !self.bounds().is_empty() {
            bail!("expect.tracks = false takes no bounds (they would be upper bounds on errors the run is expected to exceed)");
        }
        Ok(())
    }
}
