//! Control laws. Each is a pure function of (vehicle, gains, [law state], navigation state,
//! reference sample) returning the generalized forces it asks for and the tracking errors.
//!
//! - [`paper_xz`]: the paper's vertical-plane backstepping law, eqs. (6), (9), (12), (22), (24).
//! - [`paper_xy`]: the paper's horizontal-plane law, eqs. (37), (39), (43), (54), (56).
//! - [`tracking`]: laws that really track, in XZ, XY and 3-D.
//! - [`pilot`]: pilot-assisted flying: the sticks' forces with heading and depth hold.

pub mod gain_bounds;
pub mod paper_xy;
pub mod paper_xz;
pub mod pilot;
pub mod tracking;

use crate::state::{BodyForces, TrackingErrors};

/// What a law returns every step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LawOutput {
    /// Generalized forces requested (before allocation and saturation).
    pub forces: BodyForces,
    /// Tracking errors of the body origin and the plane's angle.
    pub errors: TrackingErrors,
}
