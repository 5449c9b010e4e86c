//! Sway from the turns: the vehicle has no sway thruster, but a turn under way drives sway
//! through the rigid and added masses (`m_11 u r`), and the DVL measures the sway velocity
//! it makes. From the 6-DOF plant's sway row (CG at `(0, 0, z_g)`, no current):
//!
//! ```text
//! m_22 v_dot = -m_11 u r + m_z p w - (B - W) cos(theta) sin(phi)
//!              - Y_v v - Y_vv |v| v + m z_g (p_dot - q r)
//! ```
//!
//! The first three forces are known once the thrust axes are identified (`m_11`, `m_z`,
//! `B - W` in newtons): sway is regressed, in the same integral form as the thrust axes
//! (disjoint 1 s windows outside the held-out blocks), on their sum, the two drags and the
//! roll inertia term, four parameters: `1/m_22`, `Y_v/m_22`, `Y_vv/m_22`, `m z_g/m_22`. Fitting
//! each force's coefficient free instead leaves the roll terms collinear with the drags
//! (correlation 0.98 on heavy-slow: `Y_vv` +-37 % at one standard deviation), and taking
//! `m z_g` from the prior biases `Y_vv` (+17 % on heavy-slow, whose `m z_g` is twice the
//! Observer's), so `m z_g` is fitted here. Sway takes the force scale of the thrust axes.
//!
//! Not determined (the velocity span below [`MIN_SPAN_M_S`], a regressor not excited, or a
//! 95 % interval of `m_22` wider than [`MAX_REL_HALF_WIDTH`] of its value), the vehicle file
//! keeps the prior's ratios to surge, and the reason is given; `m_22` determined but `Y_vv`'s
//! interval wider than that, the file takes `m_22` and keeps the prior's drag ratios
//! ([`SwayModel::drags_not_determined`]).

use super::fit::{axis_series, in_fit_part, prior_theta, windowed, Axis};
use super::physical::Model;
use super::physical::{draws, gauss, percentile};
use super::record::Record;
use super::regression::{least_squares, LinearFit, Z_95};
use super::validate::{predict_axis, trace_rms};
use controller_core::params::VehicleParams;
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Smallest span of the sway velocity (m/s) that counts as excited.
pub const MIN_SPAN_M_S: f64 = 0.1;
/// Widest 95 % half-interval of `m_22` and `Y_vv`, relative to the value, for a fit to
/// replace the prior's ratios.
pub const MAX_REL_HALF_WIDTH: f64 = 0.3;

/// Names of the regression's four columns.
pub const REGRESSORS: [&str; 4] = [
    "sway known forces (m11 u r, mz p w, buoyancy in roll)",
    "sway v",
    "sway |v|v",
    "sway roll inertia (p_dot - q r)",
];

/// Names and units of the sway values, in [`SwayModel::values`]' order.
pub const SWAY_NAMES: [(&str, &str); 3] = [
    ("m22 = m - Y_vdot", "kg"),
    ("Y_v", "N s/m"),
    ("Y_vv", "N s^2/m^2"),
];

/// The sway model fitted from the turns.
#[derive(Debug, Clone)]
pub struct SwayModel {
    /// `m - Y_vdot` (kg).
    pub m22_kg: f64,
    /// Linear sway drag.
    pub y_v: f64,
    /// Quadratic sway drag.
    pub y_vv: f64,
    /// `m z_g` (kg m), the sway-roll coupling.
    pub m_zg_kg_m: f64,
    /// Why the drags are not taken (their interval too wide); `None` when they are.
    pub drags_not_determined: Option<String>,
    /// Lower ends of the 95 % intervals, in [`SWAY_NAMES`]' order.
    pub lo: [f64; 3],
    /// Upper ends.
    pub hi: [f64; 3],
    /// The regression.
    pub fit: LinearFit,
    /// Held-out RMS of the sway velocity (m/s) with this model.
    pub held_out_rms_m_s: f64,
    /// The same with the prior's ratios to the identified surge (what the file would hold
    /// without this fit).
    pub ratios_held_out_rms_m_s: f64,
}

impl SwayModel {
    /// The values in [`SWAY_NAMES`]' order.
    pub fn values(&self) -> [f64; 3] {
        [self.m22_kg, self.y_v, self.y_vv]
    }
}

/// What the record says of sway.
#[derive(Debug, Clone)]
pub enum Sway {
    /// Fitted from the turns.
    Fitted(SwayModel),
    /// Not determined: the prior's ratios to surge are kept, for this reason.
    Prior {
        /// Why the record does not determine sway.
        reason: String,
    },
}

/// The identified thrust axes as sway uses them: the known forces' coefficients and the
/// force scale's uncertainty.
#[derive(Debug, Clone, Copy)]
pub struct Known {
    /// `m_11` (kg).
    pub m11_kg: f64,
    /// `m_z` (kg).
    pub mz_kg: f64,
    /// `B - W` (N).
    pub net_buoyancy_n: f64,
    /// Relative standard deviation of the force scale (from `m_11`'s 95 % interval): the
    /// anchor scales the three known forces together.
    pub scale_rel_std: f64,
}

impl Known {
    /// From the identified model and `m_11`'s 95 % interval.
    pub fn from_model(m: &Model, m11_lo: f64, m11_hi: f64) -> Self {
        Self {
            m11_kg: m.m11_kg,
            mz_kg: m.mz_kg,
            net_buoyancy_n: m.net_buoyancy_n,
            scale_rel_std: (m11_hi - m11_lo) / (2.0 * Z_95 * m.m11_kg),
        }
    }
}

/// Fit sway from `rec` (thrust `thrust` only aligns the series; sway has none). `ratios`
/// is the vehicle file the prior's ratios give (for the validation's comparison).
pub fn fit_sway(
    rec: &Record,
    thrust: &[[f64; 3]],
    lever_arm_m: f64,
    known: Known,
    ratios: &VehicleParams,
) -> Sway {
    let (lo, hi) = rec
        .samples
        .iter()
        .map(|s| s.vel_m_s[1])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let span = hi - lo;
    if span.is_nan() || span < MIN_SPAN_M_S {
        return Sway::Prior {
            reason: format!(
                "the sway velocity spans {span:.3} m/s, needs {MIN_SPAN_M_S}: the turns did not \
                 excite sway"
            ),
        };
    }
    let times: Vec<f64> = rec.samples.iter().map(|s| s.t_s).collect();
    let t0 = times.first().copied().unwrap_or(0.0);
    let series = axis_series(Axis::Sway, rec, thrust, lever_arm_m);
    let (raw, y) = windowed(&series, &times, rec.period_s(), |t| in_fit_part(t, t0));
    // Raw columns (Axis::Sway's regressors): u r, p w, roll buoyancy, v, |v|v, q r, then
    // the change of p. Combined: the known forces, the drags, the roll inertia term.
    let col = |i: usize, j: usize| raw.get((i, j)).copied().unwrap_or(f64::NAN);
    let phi = DMatrix::from_fn(raw.nrows(), 4, |i, j| match j {
        0 => known.m11_kg * col(i, 0) + known.mz_kg * col(i, 1) + known.net_buoyancy_n * col(i, 2),
        1 => col(i, 3),
        2 => col(i, 4),
        _ => col(i, 5) + col(i, 6),
    });
    let fit = match least_squares(&phi, &y, &REGRESSORS) {
        Ok(f) => f,
        Err(e) => {
            return Sway::Prior {
                reason: format!("sway fit: {e}"),
            }
        }
    };
    let (point, lo, hi) = physical(&fit, known.scale_rel_std);
    let [m22, y_v, y_vv] = point;
    let rel = |i: usize| 0.5 * (hi[i] - lo[i]) / point[i].abs();
    // Positive and its interval within the bound (a NaN is neither).
    let determined = |i: usize| {
        point[i].is_finite() && point[i] > 0.0 && rel(i).is_finite() && rel(i) <= MAX_REL_HALF_WIDTH
    };
    if !determined(0) {
        return Sway::Prior {
            reason: format!(
                "sway not determined by the turns: m22 {m22:.3} kg +-{:.0} % (95 %; at most \
                 +-{:.0} % and positive taken)",
                rel(0) * 100.0,
                MAX_REL_HALF_WIDTH * 100.0
            ),
        };
    }
    let drags_not_determined = (!determined(2)).then(|| {
        format!(
            "the sway drags are not determined by the turns: Y_vv {y_vv:.3} +-{:.0} % (95 %; at \
             most +-{:.0} % and positive taken); the prior's drag ratios kept",
            rel(2) * 100.0,
            MAX_REL_HALF_WIDTH * 100.0
        )
    });
    let g = |i: usize| fit.theta.get(i).copied().unwrap_or(f64::NAN);
    // The raw coefficients for the held-out simulation.
    let theta = vec![
        known.m11_kg * g(0),
        known.mz_kg * g(0),
        known.net_buoyancy_n * g(0),
        g(1),
        g(2),
        g(3),
        g(3),
    ];
    let m_zg_kg_m = g(3) / g(0);
    let held_out_rms_m_s = trace_rms(&predict_axis(Axis::Sway, &theta, lever_arm_m, rec, thrust));
    let ratios_theta = prior_theta(Axis::Sway, ratios);
    let ratios_held_out_rms_m_s = trace_rms(&predict_axis(
        Axis::Sway,
        &ratios_theta,
        lever_arm_m,
        rec,
        thrust,
    ));
    Sway::Fitted(SwayModel {
        m22_kg: m22,
        y_v,
        y_vv,
        m_zg_kg_m,
        drags_not_determined,
        lo,
        hi,
        fit,
        held_out_rms_m_s,
        ratios_held_out_rms_m_s,
    })
}

/// `[m_22, Y_v, Y_vv]` and their 95 % intervals, from draws of the fit and of the force
/// scale (relative standard deviation `scale_rel_std`: the known forces scale with it).
fn physical(fit: &LinearFit, scale_rel_std: f64) -> ([f64; 3], [f64; 3], [f64; 3]) {
    let values = |th: &[f64], scale: f64| {
        let g = |i: usize| th.get(i).copied().unwrap_or(f64::NAN);
        let m22 = scale / g(0);
        [m22, g(1) * m22, g(2) * m22]
    };
    let theta: Vec<f64> = fit.theta.iter().copied().collect();
    let point = values(&theta, 1.0);
    let mut rng = ChaCha8Rng::seed_from_u64(0x5A);
    let mut cols: [Vec<f64>; 3] = Default::default();
    for th in draws(fit, &mut rng) {
        let scale = 1.0 + scale_rel_std * gauss(&mut rng);
        for (c, v) in cols.iter_mut().zip(values(&th, scale)) {
            c.push(v);
        }
    }
    let mut lo = [0.0; 3];
    let mut hi = [0.0; 3];
    for ((c, l), h) in cols.iter_mut().zip(lo.iter_mut()).zip(hi.iter_mut()) {
        *l = percentile(c, 0.025);
        *h = percentile(c, 0.975);
    }
    (point, lo, hi)
}
