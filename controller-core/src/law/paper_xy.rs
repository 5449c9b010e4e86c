//! The paper's horizontal-plane (XY) law. PLACEHOLDER: being written (issue 2).

use super::LawOutput;
use crate::error::{positive, Error};
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::XyState;
use serde::{Deserialize, Serialize};

/// Gains of the paper's XY law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PaperXyGains {
    /// `k` of eq. (39).
    pub k: f32,
    /// `c_1u` of eq. (43).
    pub c1u: f32,
    /// `c_2u` of eq. (43).
    pub c2u: f32,
    /// `c_1r` of eq. (54).
    pub c1r: f32,
    /// `c_2r` of eq. (54).
    pub c2r: f32,
    /// `c_r` of step 3.
    pub cr: f32,
    /// `c_3` of eq. (56) (not given in the paper).
    pub c3: f32,
    /// `c_4` of eq. (56) (not given in the paper).
    pub c4: f32,
}

impl PaperXyGains {
    /// The paper's gains (Section IV) plus the chosen `c_3`, `c_4`.
    pub const PAPER: Self = Self {
        k: 0.1,
        c1u: 10.0,
        c2u: 10.0,
        c1r: 1.0,
        c2r: 1.0,
        cr: 10.0,
        c3: 1.0,
        c4: 1.0,
    };

    /// Refuse non-finite or non-positive gains.
    pub fn validate(&self) -> Result<(), Error> {
        for (n, v) in [
            ("k", self.k),
            ("c1u", self.c1u),
            ("c2u", self.c2u),
            ("c1r", self.c1r),
            ("c2r", self.c2r),
            ("cr", self.cr),
            ("c3", self.c3),
            ("c4", self.c4),
        ] {
            positive(n, v)?;
        }
        Ok(())
    }
}

impl Default for PaperXyGains {
    fn default() -> Self {
        Self::PAPER
    }
}

/// One step of the law. PLACEHOLDER.
pub fn step(_v: &Vehicle, _g: &PaperXyGains, _s: &XyState, _r: &RefSample) -> LawOutput {
    LawOutput::default()
}
