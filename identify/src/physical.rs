//! The identified model in physical units: the three axes' parameters (each divided by its
//! axis's mass) given newtons by an anchor, with 95 % intervals from draws of the fits'
//! covariances and of the anchor.
//!
//! One dive fixes the model only up to a force scale (scaling every mass, drag, thrust and
//! the buoyancy together changes no motion), so one force must be known. The anchors:
//!
//! - the thrust curve (the record's nominal thrust: the prior's curve, or the installed
//!   thrusters' published one): the thrust scale ahead is `k_a = 1` within the curve's
//!   error; every mass, drag, the astern scale and the net buoyancy follow from it;
//! - the net buoyancy measured by weighing the vehicle in water: `m_z = (B - W) / theta`,
//!   and `k_a` follows (so the thrust curve is identified);
//! - both: the two values of `k_a` combined by their variances.

use super::fit::AxisFits;
use super::regression::LinearFit;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Draws of the parameters' distribution that give the derived values' intervals.
const DRAWS: usize = 4000;

/// What gives the fit its force scale.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Anchor {
    /// The thrust curve the record's thrust is computed with is right ahead within
    /// `rel_std` (one standard deviation, a fraction; 0 takes it as exact).
    ThrustCurve {
        /// Relative standard deviation of the curve's thrust ahead.
        rel_std: f64,
    },
    /// The net buoyancy `B - W` (N, positive floats up) measured by weighing in water,
    /// with its standard deviation (N).
    NetBuoyancy {
        /// The measured value.
        value_n: f64,
        /// Its standard deviation.
        std_n: f64,
    },
    /// The thrust curve and the weighed net buoyancy together.
    Both {
        /// Relative standard deviation of the curve's thrust ahead.
        curve_rel_std: f64,
        /// The measured net buoyancy (N).
        value_n: f64,
        /// Its standard deviation (N).
        std_n: f64,
    },
}

impl Anchor {
    /// The curve's relative standard deviation, when the curve anchors.
    fn curve_rel_std(self) -> Option<f64> {
        match self {
            Anchor::ThrustCurve { rel_std } => Some(rel_std),
            Anchor::Both { curve_rel_std, .. } => Some(curve_rel_std),
            Anchor::NetBuoyancy { .. } => None,
        }
    }

    /// The weighed net buoyancy and its standard deviation, when it anchors.
    fn net_buoyancy(self) -> Option<(f64, f64)> {
        match self {
            Anchor::ThrustCurve { .. } => None,
            Anchor::NetBuoyancy { value_n, std_n } | Anchor::Both { value_n, std_n, .. } => {
                Some((value_n, std_n))
            }
        }
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
    /// Thrust scale ahead against the record's thrust curve.
    pub thrust_scale_ahead: f64,
    /// Thrust scale astern against the record's thrust curve.
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

    /// The physical model from the three axes' parameters and the thrust scale ahead. The
    /// astern/ahead ratio is each axis's `theta_1 / theta_0`, combined with `weights`.
    fn from_thetas(th: [&[f64]; 3], ahead: f64, weights: [f64; 3]) -> Self {
        let g = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(f64::NAN);
        let [s, y, h] = th;
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
    /// The thruster time constant the fits were made with (s).
    pub thruster_time_constant_s: f64,
    /// The anchor that gave the force scale.
    pub anchor: Anchor,
}

/// Draws of a fit's parameters: `theta + L z`, `L L^T` the covariance.
pub(crate) fn draws(fit: &LinearFit, rng: &mut ChaCha8Rng) -> Vec<Vec<f64>> {
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
pub(crate) fn percentile(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(f64::total_cmp);
    let i = ((v.len() as f64 - 1.0) * q).round() as usize;
    v.get(i).copied().unwrap_or(f64::NAN)
}

/// Mean and variance of `v`.
fn mean_var(v: &[f64]) -> (f64, f64) {
    let n = v.len().max(1) as f64;
    let mean = v.iter().sum::<f64>() / n;
    (mean, v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n)
}

/// The thrust scale ahead from the anchor: the curve's draw `curve` (1 at the point), the
/// weighed buoyancy's draw `buoyancy_n` with the heave parameters `h`, combined with the
/// inverse-variance weight `w_curve` of the curve (the buoyancy's is `1 - w_curve`).
fn ahead_scale(curve: Option<f64>, buoyancy_n: Option<f64>, h: &[f64], w_curve: f64) -> f64 {
    let from_buoyancy = buoyancy_n.map(|b| {
        h.first().copied().unwrap_or(f64::NAN) * b / h.get(4).copied().unwrap_or(f64::NAN)
    });
    match (curve, from_buoyancy) {
        (Some(c), Some(b)) => w_curve * c + (1.0 - w_curve) * b,
        (Some(c), None) => c,
        (None, Some(b)) => b,
        (None, None) => 1.0,
    }
}

/// The physical model and its intervals from the axes' fits.
pub fn physical(axes: AxisFits, anchor: Anchor) -> Identified {
    let mut rng = ChaCha8Rng::seed_from_u64(0x1D);
    let d: Vec<Vec<Vec<f64>>> = axes.fits.iter().map(|f| draws(f, &mut rng)).collect();
    let curve_std = anchor.curve_rel_std();
    let weighed = anchor.net_buoyancy();
    let curve_draws: Vec<Option<f64>> = (0..DRAWS)
        .map(|_| curve_std.map(|s| 1.0 + s * gauss(&mut rng)))
        .collect();
    let buoyancy_draws: Vec<Option<f64>> = (0..DRAWS)
        .map(|_| weighed.map(|(v, s)| v + s * gauss(&mut rng)))
        .collect();
    let heave = |k: usize| {
        d.get(2)
            .and_then(|a| a.get(k))
            .map_or(&[][..], Vec::as_slice)
    };
    // The curve's weight against the buoyancy's: their variances of `k_a`.
    let w_curve = match (curve_std, weighed) {
        (Some(s), Some(_)) => {
            let kb: Vec<f64> = (0..DRAWS)
                .map(|k| ahead_scale(None, buoyancy_draws[k], heave(k), 0.0))
                .collect();
            let var_b = mean_var(&kb).1;
            if s > 0.0 {
                var_b / (var_b + s * s)
            } else {
                1.0
            }
        }
        _ => 1.0,
    };
    // Inverse-variance weights of the three astern/ahead ratios, from the draws.
    let mut weights = [1.0; 3];
    for (w, axis_draws) in weights.iter_mut().zip(&d) {
        let r: Vec<f64> = axis_draws
            .iter()
            .map(|t| t.get(1).copied().unwrap_or(0.0) / t.first().copied().unwrap_or(1.0))
            .collect();
        *w = 1.0 / mean_var(&r).1.max(1e-12);
    }
    let point = [
        axes.fits[0].theta.as_slice(),
        axes.fits[1].theta.as_slice(),
        axes.fits[2].theta.as_slice(),
    ];
    let ahead = ahead_scale(
        curve_std.map(|_| 1.0),
        weighed.map(|(v, _)| v),
        point[2],
        w_curve,
    );
    let model = Model::from_thetas(point, ahead, weights);
    let mut cols: Vec<Vec<f64>> = (0..12).map(|_| Vec::with_capacity(DRAWS)).collect();
    for (k, (c, b)) in curve_draws.iter().zip(&buoyancy_draws).enumerate() {
        let th = [
            d[0].get(k).map_or(&[][..], Vec::as_slice),
            d[1].get(k).map_or(&[][..], Vec::as_slice),
            heave(k),
        ];
        let m = Model::from_thetas(th, ahead_scale(*c, *b, th[2], w_curve), weights);
        for (col, v) in cols.iter_mut().zip(m.values()) {
            col.push(v);
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
        thruster_time_constant_s: f64::NAN,
        anchor,
    }
}

/// Standard normal draw (Box-Muller; one of the pair is dropped), the simulator's own draw
/// (`sim_world::noise::gauss`), so that a seed gives the same fit there and here.
pub(crate) fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
