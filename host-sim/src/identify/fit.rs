//! The fit: per axis (surge, yaw, heave) a linear regression of the velocity change over
//! short disjoint windows on the integrals of the model's terms (the integral form of the
//! equation error: no differentiated velocity, and the windows' errors are independent, so
//! the regression's covariance holds). Sway, pitch and the coupling terms are the prior's.
//!
//! With `m_11 = m - X_udot`, `m_33 = I_z - N_rdot`, `m_z = m - Z_wdot`, the nominal thrust
//! of each thruster split into its ahead part `F+` and astern part `F-` (the prior's curve,
//! which the vehicle's scales `k_a`, `k_s` correct):
//!
//! ```text
//! u_dot = (k_a X+ + k_s X-)/m_11 - (X_u u + X_uu |u| u)/m_11 + (m_22/m_11) v r
//! r_dot = (k_a N+ + k_s N-)/m_33 - (N_r r + N_rr |r| r)/m_33 + ((m_11 - m_22)/m_33) u v
//! w_dot = (k_a Z+ + k_s Z-)/m_z  - (Z_w w + Z_ww |w| w)/m_z - ((B - W)/m_z) cos(phi) cos(theta)
//!         + (m_11/m_z) u q
//! ```
//! with `X = F1x + F2x`, `N = l (F1x - F2x)`, `Z = F3z`. Each axis gives its parameters
//! divided by its mass: one force has to be known to give them in newtons. The anchor is
//! either the prior's thrust curve ahead (`k_a = 1`), or the net buoyancy measured by
//! weighing the vehicle in water (then `m_z = (B - W) / theta`, and `k_a` follows).

use super::record::Record;
use super::regression::{least_squares, FitError, LinearFit};
use crate::world::noise::gauss;
use anyhow::{bail, Result};
use controller_core::params::VehicleParams;
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Length of one regression window (s): several thruster time constants, short against
/// the vehicle's 1-5 s time constants.
pub const WINDOW_S: f64 = 0.5;
/// Length of a validation block (s); every [`HOLD_OUT_EVERY`]th block is held out.
pub const BLOCK_S: f64 = 10.0;
/// One block in this many is kept from the fit for the validation.
pub const HOLD_OUT_EVERY: usize = 4;
/// Draws of the parameters' distribution that give the derived values' intervals.
const DRAWS: usize = 4000;

/// What gives the fit its force scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// The prior's thrust curve ahead is right (`k_a = 1`).
    ThrustAhead,
    /// The net buoyancy `B - W` (N, positive floats up) measured by weighing in water,
    /// with its standard deviation (N).
    NetBuoyancy {
        /// The measured value.
        value_n: f64,
        /// Its standard deviation.
        std_n: f64,
    },
}

/// One of the three fitted axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Surge (`u`, the horizontal pair together).
    Surge,
    /// Yaw (`r`, the horizontal pair in opposition).
    Yaw,
    /// Heave (`w`, the vertical thruster).
    Heave,
}

impl Axis {
    /// All three, in fit order.
    pub const ALL: [Axis; 3] = [Axis::Surge, Axis::Yaw, Axis::Heave];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Axis::Surge => "surge",
            Axis::Yaw => "yaw",
            Axis::Heave => "heave",
        }
    }

    /// Names of its regressors (the parameters over the axis's mass).
    pub fn regressors(self) -> &'static [&'static str] {
        match self {
            Axis::Surge => &[
                "surge thrust ahead",
                "surge thrust astern",
                "surge u",
                "surge |u|u",
            ],
            Axis::Yaw => &["yaw moment ahead", "yaw moment astern", "yaw r", "yaw |r|r"],
            Axis::Heave => &[
                "heave thrust ahead",
                "heave thrust astern",
                "heave w",
                "heave |w|w",
                "heave buoyancy",
            ],
        }
    }

    /// Smallest span of the axis's velocity (m/s or rad/s) that counts as excited.
    fn min_span(self) -> f64 {
        match self {
            Axis::Surge => 0.15,
            Axis::Yaw => 0.2,
            Axis::Heave => 0.1,
        }
    }
}

/// The prior's coupling coefficients (not fitted).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Couplings {
    /// `m_22 / m_11`.
    pub m22_over_m11: f64,
    /// `(m_11 - m_22) / m_33`.
    pub munk_over_m33: f64,
    /// `m_11 / m_z`.
    pub m11_over_mz: f64,
    /// Lever arm `l` (m).
    pub lever_arm_m: f64,
}

impl Couplings {
    /// From the prior.
    pub fn of(p: &VehicleParams) -> Self {
        let m11 = f64::from(p.mass_kg - p.x_udot_kg);
        let m22 = f64::from(p.mass_kg - p.y_vdot_kg);
        let m33 = f64::from(p.i_z_kg_m2 - p.n_rdot_kg_m2);
        let mz = f64::from(p.mass_kg - p.z_wdot_kg);
        Self {
            m22_over_m11: m22 / m11,
            munk_over_m33: (m11 - m22) / m33,
            m11_over_mz: m11 / mz,
            lever_arm_m: f64::from(p.thruster_lever_arm_m),
        }
    }
}

/// Per sample, for one axis: the velocity, the regressors and the known (prior) part of
/// the acceleration.
pub struct AxisSeries {
    /// The axis.
    pub axis: Axis,
    /// Its velocity at each sample.
    pub vel: Vec<f64>,
    /// Its regressors at each sample.
    pub phi: Vec<Vec<f64>>,
    /// The coupling acceleration at each sample (known from the prior).
    pub known: Vec<f64>,
}

/// Split a thrust into its ahead and astern parts.
fn split(f: f64) -> (f64, f64) {
    (f.max(0.0), f.min(0.0))
}

/// The series of one axis from a record and its nominal thrusts.
pub fn axis_series(axis: Axis, rec: &Record, thrust: &[[f64; 3]], c: &Couplings) -> AxisSeries {
    let mut out = AxisSeries {
        axis,
        vel: Vec::with_capacity(thrust.len()),
        phi: Vec::with_capacity(thrust.len()),
        known: Vec::with_capacity(thrust.len()),
    };
    for (s, f) in rec.samples.iter().zip(thrust) {
        let [u, v, w] = s.vel_m_s;
        let [q, r] = s.rate_rad_s;
        let [roll, pitch] = s.tilt_rad;
        let (f1a, f1s) = split(f[0]);
        let (f2a, f2s) = split(f[1]);
        let (f3a, f3s) = split(f[2]);
        let (vel, phi, known) = match axis {
            Axis::Surge => (
                u,
                vec![f1a + f2a, f1s + f2s, -u, -u.abs() * u],
                c.m22_over_m11 * v * r,
            ),
            Axis::Yaw => (
                r,
                vec![
                    c.lever_arm_m * (f1a - f2a),
                    c.lever_arm_m * (f1s - f2s),
                    -r,
                    -r.abs() * r,
                ],
                c.munk_over_m33 * u * v,
            ),
            Axis::Heave => (
                w,
                vec![f3a, f3s, -w, -w.abs() * w, -roll.cos() * pitch.cos()],
                c.m11_over_mz * u * q,
            ),
        };
        out.vel.push(vel);
        out.phi.push(phi);
        out.known.push(known);
    }
    out
}

/// Which samples the fit may use: those outside the held-out blocks.
pub fn in_fit_part(t_s: f64, t0_s: f64) -> bool {
    let block = ((t_s - t0_s) / BLOCK_S).floor().max(0.0) as usize;
    block % HOLD_OUT_EVERY != HOLD_OUT_EVERY - 1
}

/// The windowed regression of one axis over the samples that `keep` accepts.
pub fn windowed(
    s: &AxisSeries,
    times: &[f64],
    dt_s: f64,
    keep: impl Fn(f64) -> bool,
) -> (DMatrix<f64>, DVector<f64>) {
    let len = ((WINDOW_S / dt_s).round() as usize).max(2);
    let p = s.phi.first().map_or(0, Vec::len);
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut ys = Vec::new();
    let mut a = 0usize;
    while a + len < s.vel.len() {
        let b = a + len;
        let inside =
            times.get(a).is_some_and(|&t| keep(t)) && times.get(b).is_some_and(|&t| keep(t));
        if inside {
            let mut row = vec![0.0; p];
            let mut known = 0.0;
            for k in a..b {
                if let (Some(p0), Some(p1)) = (s.phi.get(k), s.phi.get(k + 1)) {
                    for ((acc, x0), x1) in row.iter_mut().zip(p0).zip(p1) {
                        *acc += 0.5 * (x0 + x1) * dt_s;
                    }
                }
                if let (Some(k0), Some(k1)) = (s.known.get(k), s.known.get(k + 1)) {
                    known += 0.5 * (k0 + k1) * dt_s;
                }
            }
            let dv = s.vel.get(b).copied().unwrap_or(0.0) - s.vel.get(a).copied().unwrap_or(0.0);
            ys.push(dv - known);
            rows.push(row);
        }
        // Disjoint windows: the next starts one sample after this one ends.
        a = b + 1;
    }
    let phi = DMatrix::from_fn(rows.len(), p, |i, j| {
        rows.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
    });
    (phi, DVector::from_vec(ys))
}

/// Refuse a record whose axes were not excited: each axis's velocity must span
/// [`Axis::min_span`] and each thruster group must have pushed both ways.
pub fn check_excitation(rec: &Record, thrust: &[[f64; 3]], prior: &VehicleParams) -> Result<()> {
    let mut missing = Vec::new();
    let span = |f: &dyn Fn(&super::record::RecordSample) -> f64| {
        let (lo, hi) = rec
            .samples
            .iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        hi - lo
    };
    let spans = [
        span(&|s| s.vel_m_s[0]),
        span(&|s| s.rate_rad_s[1]),
        span(&|s| s.vel_m_s[2]),
    ];
    let fwd = 0.1 * f64::from(prior.thrust_max_forward_n);
    let rev = 0.1 * f64::from(prior.thrust_max_reverse_n);
    let pushed = |g: &dyn Fn(&[f64; 3]) -> f64| {
        (
            thrust.iter().any(|f| g(f) > fwd),
            thrust.iter().any(|f| g(f) < -rev),
        )
    };
    let groups = [
        pushed(&|f| 0.5 * (f[0] + f[1])),
        pushed(&|f| 0.5 * (f[0] - f[1])),
        pushed(&|f| f[2]),
    ];
    for ((axis, span), (ahead, astern)) in Axis::ALL.iter().zip(spans).zip(groups) {
        if span < axis.min_span() {
            missing.push(format!(
                "{} (velocity span {span:.3}, needs {})",
                axis.name(),
                axis.min_span()
            ));
        } else if !(ahead && astern) {
            missing.push(format!(
                "{} (thrust {})",
                axis.name(),
                if ahead {
                    "astern missing"
                } else {
                    "ahead missing"
                }
            ));
        }
    }
    if !missing.is_empty() {
        bail!("the record does not excite: {}", missing.join(", "));
    }
    Ok(())
}

/// The three axes' regressions.
#[derive(Debug, Clone)]
pub struct AxisFits {
    /// Surge, yaw, heave, in [`Axis::ALL`]'s order.
    pub fits: [LinearFit; 3],
}

/// Fit the three axes on the record's fit part.
pub fn fit_axes(rec: &Record, thrust: &[[f64; 3]], prior: &VehicleParams) -> Result<AxisFits> {
    check_excitation(rec, thrust, prior)?;
    let c = Couplings::of(prior);
    let times: Vec<f64> = rec.samples.iter().map(|s| s.t_s).collect();
    let t0 = times.first().copied().unwrap_or(0.0);
    let dt = rec.period_s();
    let fit = |axis: Axis| -> Result<LinearFit, FitError> {
        let s = axis_series(axis, rec, thrust, &c);
        let (phi, y) = windowed(&s, &times, dt, |t| in_fit_part(t, t0));
        least_squares(&phi, &y, axis.regressors())
    };
    let mut out = Vec::new();
    for axis in Axis::ALL {
        out.push(fit(axis).map_err(|e| anyhow::anyhow!("{} fit: {e}", axis.name()))?);
    }
    match <[LinearFit; 3]>::try_from(out) {
        Ok(fits) => Ok(AxisFits { fits }),
        Err(_) => bail!("three axes expected"),
    }
}

/// The identified model in physical units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Model {
    /// `m - X_udot` (kg).
    pub m11_kg: f64,
    /// `I_z - N_rdot` (kg m^2).
    pub m33_kg_m2: f64,
    /// `m - Z_wdot` (kg).
    pub mz_kg: f64,
    /// `X_u`, `X_uu`.
    pub x_u: f64,
    /// Quadratic surge drag.
    pub x_uu: f64,
    /// `N_r`.
    pub n_r: f64,
    /// `N_rr`.
    pub n_rr: f64,
    /// `Z_w`.
    pub z_w: f64,
    /// `Z_ww`.
    pub z_ww: f64,
    /// `B - W` (N).
    pub net_buoyancy_n: f64,
    /// Thrust scale ahead against the prior's curve.
    pub thrust_scale_ahead: f64,
    /// Thrust scale astern against the prior's curve.
    pub thrust_scale_astern: f64,
}

/// Names and units of [`Model`]'s values, in [`Model::values`]'s order.
pub const MODEL_NAMES: [(&str, &str); 12] = [
    ("m11 = m - X_udot", "kg"),
    ("m33 = I_z - N_rdot", "kg m^2"),
    ("mz = m - Z_wdot", "kg"),
    ("X_u", "N s/m"),
    ("X_uu", "N s^2/m^2"),
    ("N_r", "N m s/rad"),
    ("N_rr", "N m s^2/rad^2"),
    ("Z_w", "N s/m"),
    ("Z_ww", "N s^2/m^2"),
    ("B - W", "N"),
    ("thrust scale ahead", "-"),
    ("thrust scale astern", "-"),
];

impl Model {
    /// The values in [`MODEL_NAMES`]' order.
    pub fn values(&self) -> [f64; 12] {
        [
            self.m11_kg,
            self.m33_kg_m2,
            self.mz_kg,
            self.x_u,
            self.x_uu,
            self.n_r,
            self.n_rr,
            self.z_w,
            self.z_ww,
            self.net_buoyancy_n,
            self.thrust_scale_ahead,
            self.thrust_scale_astern,
        ]
    }

    /// The physical model from the three axes' parameters and the anchor's value. The
    /// astern/ahead ratio is each axis's `theta_1 / theta_0`, combined with `weights`.
    fn from_thetas(th: [&[f64]; 3], anchor_n: Option<f64>, weights: [f64; 3]) -> Self {
        let g = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(f64::NAN);
        let [s, y, h] = th;
        let ahead = match anchor_n {
            None => 1.0,
            Some(b) => g(h, 0) * b / g(h, 4),
        };
        let ratios = [g(s, 1) / g(s, 0), g(y, 1) / g(y, 0), g(h, 1) / g(h, 0)];
        let wsum: f64 = weights.iter().sum();
        let ratio = ratios.iter().zip(weights).map(|(r, w)| r * w).sum::<f64>() / wsum;
        let m11 = ahead / g(s, 0);
        let m33 = ahead / g(y, 0);
        let mz = ahead / g(h, 0);
        Self {
            m11_kg: m11,
            m33_kg_m2: m33,
            mz_kg: mz,
            x_u: g(s, 2) * m11,
            x_uu: g(s, 3) * m11,
            n_r: g(y, 2) * m33,
            n_rr: g(y, 3) * m33,
            z_w: g(h, 2) * mz,
            z_ww: g(h, 3) * mz,
            net_buoyancy_n: g(h, 4) * mz,
            thrust_scale_ahead: ahead,
            thrust_scale_astern: ahead * ratio,
        }
    }
}

/// The identified model with 95 % intervals.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The point estimate.
    pub model: Model,
    /// Lower ends of the 95 % intervals, in [`MODEL_NAMES`]' order.
    pub lo: [f64; 12],
    /// Upper ends.
    pub hi: [f64; 12],
    /// The axes' regressions.
    pub axes: AxisFits,
}

/// Draws of a fit's parameters: `theta + L z`, `L L^T` the covariance.
fn draws(fit: &LinearFit, rng: &mut ChaCha8Rng) -> Vec<Vec<f64>> {
    let p = fit.theta.len();
    let l = fit
        .covariance
        .clone()
        .cholesky()
        .map(|c| c.l())
        .unwrap_or_else(|| {
            DMatrix::from_diagonal(&fit.covariance.diagonal().map(|v| v.max(0.0).sqrt()))
        });
    (0..DRAWS)
        .map(|_| {
            let z = DVector::from_fn(p, |_, _| gauss(rng));
            (&fit.theta + &l * z).iter().copied().collect()
        })
        .collect()
}

/// Percentile `q` (0-1) of `v` (sorted in place).
fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let i = ((v.len() as f64 - 1.0) * q).round() as usize;
    v.get(i).copied().unwrap_or(f64::NAN)
}

/// The physical model and its intervals from the axes' fits.
pub fn physical(axes: AxisFits, anchor: Anchor) -> Identified {
    let mut rng = ChaCha8Rng::seed_from_u64(0x1D);
    let d: Vec<Vec<Vec<f64>>> = axes.fits.iter().map(|f| draws(f, &mut rng)).collect();
    let anchor_draws: Vec<Option<f64>> = (0..DRAWS)
        .map(|_| match anchor {
            Anchor::ThrustAhead => None,
            Anchor::NetBuoyancy { value_n, std_n } => Some(value_n + std_n * gauss(&mut rng)),
        })
        .collect();
    // Inverse-variance weights of the three astern/ahead ratios, from the draws.
    let mut weights = [1.0; 3];
    for (w, axis_draws) in weights.iter_mut().zip(&d) {
        let r: Vec<f64> = axis_draws
            .iter()
            .map(|t| t.get(1).copied().unwrap_or(0.0) / t.first().copied().unwrap_or(1.0))
            .collect();
        let mean = r.iter().sum::<f64>() / r.len() as f64;
        let var = r.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / r.len() as f64;
        *w = 1.0 / var.max(1e-12);
    }
    let point = [
        axes.fits[0].theta.as_slice(),
        axes.fits[1].theta.as_slice(),
        axes.fits[2].theta.as_slice(),
    ];
    let anchor_n = match anchor {
        Anchor::ThrustAhead => None,
        Anchor::NetBuoyancy { value_n, .. } => Some(value_n),
    };
    let model = Model::from_thetas(point, anchor_n, weights);
    let mut cols: Vec<Vec<f64>> = vec![Vec::with_capacity(DRAWS); 12];
    for (k, a) in anchor_draws.iter().enumerate() {
        let th = [
            d[0].get(k).map_or(&[][..], Vec::as_slice),
            d[1].get(k).map_or(&[][..], Vec::as_slice),
            d[2].get(k).map_or(&[][..], Vec::as_slice),
        ];
        let m = Model::from_thetas(th, *a, weights);
        for (c, v) in cols.iter_mut().zip(m.values()) {
            c.push(v);
        }
    }
    let mut lo = [0.0; 12];
    let mut hi = [0.0; 12];
    for ((c, l), h) in cols.iter_mut().zip(lo.iter_mut()).zip(hi.iter_mut()) {
        *l = percentile(c, 0.025);
        *h = percentile(c, 0.975);
    }
    Identified {
        model,
        lo,
        hi,
        axes,
    }
}
