//! The paper's vertical-plane (XZ) law. PLACEHOLDER: being written (issue 2).

use super::LawOutput;
use crate::error::{positive, Error};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::XzState;
use serde::{Deserialize, Serialize};

/// Gains of the paper's XZ law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PaperXzGains {
    /// `k` of eq. (9).
    pub k: f32,
    /// `c_1w` of eq. (12).
    pub c1w: f32,
    /// `c_2w` of eq. (12).
    pub c2w: f32,
    /// `c_1q` of eq. (22).
    pub c1q: f32,
    /// `c_2q` of eq. (22).
    pub c2q: f32,
    /// `c_q` of step 3.
    pub cq: f32,
    /// `c_1` of eq. (24) (not given in the paper).
    pub c1: f32,
    /// `c_2` of eq. (24) (not given in the paper).
    pub c2: f32,
}

impl PaperXzGains {
    /// The paper's gains (Section IV) plus the chosen `c_1`, `c_2`.
    pub const PAPER: Self = Self {
        k: 0.1,
        c1w: 10.0,
        c2w: 10.0,
        c1q: 1.0,
        c2q: 1.0,
        cq: 10.0,
        c1: 1.0,
        c2: 1.0,
    };

    /// Refuse non-finite or non-positive gains.
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("k", self.k),
            ("c1w", self.c1w),
            ("c2w", self.c2w),
            ("c1q", self.c1q),
            ("c2q", self.c2q),
            ("cq", self.cq),
            ("c1", self.c1),
            ("c2", self.c2),
        ] {
            positive(n, v)?;
        }
        Ok(())
    }
}

impl Default for PaperXzGains {
    fn default() -> Self {
        Self::PAPER
    }
}

/// One step of the law. PLACEHOLDER.
pub fn step(_v: &Vehicle, _g: &PaperXzGains, _s: &XzState, _r: &RefSample) -> LawOutput {
    LawOutput::default()
}
