//! The identification manoeuvre flying, as the surface follows it.

/// A manoeuvre flying: when it started, where, its room, the next progress report (times
/// on the vehicle's clock, s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct IdentRun {
    pub(super) started_s: f64,
    pub(super) start_m: [f32; 3],
    pub(super) radius_m: f32,
    pub(super) depth_band_m: f32,
    pub(super) next_report_s: f64,
}
