//! The fit: per axis (surge, yaw, heave) a linear regression of the velocity change over
//! short disjoint windows on the integrals of the model's terms (the integral form of the
//! equation error: no differentiated velocity, and the windows' errors are independent, so
//! the regression's covariance holds). Sway and pitch are the prior's.
//!
//! With `m_11 = m - X_udot`, `m_33 = I_z - N_rdot`, `m_z = m - Z_wdot`, the nominal thrust
//! of each thruster split into its ahead part `F+` and astern part `F-` (the prior's curve,
//! which the vehicle's scales `k_a`, `k_s` correct):
//!
//! ```text
//! u_dot = (k_a X+ + k_s X-)/m_11 - (X_u u + X_uu |u| u)/m_11 + (m_22/m_11) v r
//!         - (m_z/m_11) w q - (m z_g/m_11) q_dot
//! r_dot = (k_a N+ + k_s N-)/m_33 - (N_r r + N_rr |r| r)/m_33 + ((m_11 - m_22)/m_33) u v
//! w_dot = (k_a Z+ + k_s Z-)/m_z  - (Z_w w + Z_ww |w| w)/m_z - ((B - W)/m_z) cos(phi) cos(theta)
//!         + (m_11/m_z) u q - (m_22/m_z) v p + (m z_g/m_z) (p^2 + q^2)
//! ```
//! (the 6-DOF plant's rigid-body and added-mass Coriolis terms and the surge-pitch mass
//! coupling, each coefficient fitted free: left out or taken from the prior, they biased
//! the heave mass by 11 % on the heavy vehicle).
//! with `X = F1x + F2x`, `N = l (F1x - F2x)`, `Z = F3z`. Each axis gives its parameters
//! divided by its mass: one force has to be known to give them in newtons. The anchor is
//! either the prior's thrust curve ahead (`k_a = 1`), or the net buoyancy measured by
//! weighing the vehicle in water (then `m_z = (B - W) / theta`, and `k_a` follows).

use super::record::Record;
use super::regression::{least_squares, FitError, LinearFit};
use anyhow::{bail, Result};
use controller_core::params::VehicleParams;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Length of one regression window (s): many thruster time constants. A longer window
/// raises the velocity change against the DVL's noise at its two ends (measured on
/// heavy-slow, the heave quadratic drag's standard error: 8 % at 0.5 s, 6 % at 1 s).
pub const WINDOW_S: f64 = 1.0;
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

/// The regression parameters of `axis` that the vehicle `p` has (the prior's, scales 1),
/// in [`Axis::regressors`]' order.
pub fn prior_theta(axis: Axis, p: &VehicleParams) -> Vec<f64> {
    let f = f64::from;
    let m = f(p.mass_kg);
    let m11 = f(p.mass_kg - p.x_udot_kg);
    let m22 = f(p.mass_kg - p.y_vdot_kg);
    let m33 = f(p.i_z_kg_m2 - p.n_rdot_kg_m2);
    let mz = f(p.mass_kg - p.z_wdot_kg);
    let a_uq = m * f(p.z_g_m);
    match axis {
        Axis::Surge => vec![
            1.0 / m11,
            1.0 / m11,
            f(p.x_u) / m11,
            f(p.x_uu) / m11,
            m22 / m11,
            -mz / m11,
            -a_uq / m11,
        ],
        Axis::Yaw => vec![
            1.0 / m33,
            1.0 / m33,
            f(p.n_r) / m33,
            f(p.n_rr) / m33,
            (m11 - m22) / m33,
        ],
        Axis::Heave => vec![
            1.0 / mz,
            1.0 / mz,
            f(p.z_w) / mz,
            f(p.z_ww) / mz,
            f(p.buoyancy_offset_n) / mz,
            m11 / mz,
            -m22 / mz,
            a_uq / mz,
        ],
    }
}

/// Per sample, for one axis: the velocity and the regressors.
pub struct AxisSeries {
    /// The axis.
    pub axis: Axis,
    /// Its velocity at each sample.
    pub vel: Vec<f64>,
    /// Its integrated regressors at each sample.
    pub phi: Vec<Vec<f64>>,
    /// A regressor that enters through its change over a window rather than its integral
    /// (surge: the pitch rate, whose derivative the surge-pitch mass couples in); empty for
    /// the other axes.
    pub diff: Vec<f64>,
}

/// Split a thrust into its ahead and astern parts.
fn split(f: f64) -> (f64, f64) {
    (f.max(0.0), f.min(0.0))
}

/// The series of one axis from a record, its nominal thrusts and the thrusters' lever arm.
pub fn axis_series(axis: Axis, rec: &Record, thrust: &[[f64; 3]], lever_arm_m: f64) -> AxisSeries {
    let mut out = AxisSeries {
        axis,
        vel: Vec::with_capacity(thrust.len()),
        phi: Vec::with_capacity(thrust.len()),
        diff: Vec::new(),
    };
    for (s, f) in rec.samples.iter().zip(thrust) {
        let [u, v, w] = s.vel_m_s;
        let [p, q, r] = s.rate_rad_s;
        let [roll, pitch] = s.tilt_rad;
        let (f1a, f1s) = split(f[0]);
        let (f2a, f2s) = split(f[1]);
        let (f3a, f3s) = split(f[2]);
        let (vel, phi) = match axis {
            Axis::Surge => {
                out.diff.push(q);
                (
                    u,
                    vec![f1a + f2a, f1s + f2s, -u, -u.abs() * u, v * r, w * q],
                )
            }
            Axis::Yaw => (
                r,
                vec![
                    lever_arm_m * (f1a - f2a),
                    lever_arm_m * (f1s - f2s),
                    -r,
                    -r.abs() * r,
                    u * v,
                ],
            ),
            Axis::Heave => (
                w,
                vec![
                    f3a,
                    f3s,
                    -w,
                    -w.abs() * w,
                    -roll.cos() * pitch.cos(),
                    u * q,
                    v * p,
                    p * p + q * q,
                ],
            ),
        };
        out.vel.push(vel);
        out.phi.push(phi);
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
    let p = s.phi.first().map_or(0, Vec::len) + usize::from(!s.diff.is_empty());
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut ys = Vec::new();
    let mut a = 0usize;
    while a + len < s.vel.len() {
        let b = a + len;
        let inside =
            times.get(a).is_some_and(|&t| keep(t)) && times.get(b).is_some_and(|&t| keep(t));
        if inside {
            let mut row = vec![0.0; s.phi.first().map_or(0, Vec::len)];
            for k in a..b {
                if let (Some(p0), Some(p1)) = (s.phi.get(k), s.phi.get(k + 1)) {
                    for ((acc, x0), x1) in row.iter_mut().zip(p0).zip(p1) {
                        *acc += 0.5 * (x0 + x1) * dt_s;
                    }
                }
            }
            if let (Some(d0), Some(d1)) = (s.diff.get(a), s.diff.get(b)) {
                row.push(d1 - d0);
            }
            let dv = s.vel.get(b).copied().unwrap_or(0.0) - s.vel.get(a).copied().unwrap_or(0.0);
            ys.push(dv);
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
        span(&|s| s.rate_rad_s[2]),
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
    let lever = f64::from(prior.thruster_lever_arm_m);
    let times: Vec<f64> = rec.samples.iter().map(|s| s.t_s).collect();
    let t0 = times.first().copied().unwrap_or(0.0);
    let dt = rec.period_s();
    let fit = |axis: Axis| -> Result<LinearFit, FitError> {
        let s = axis_series(axis, rec, thrust, lever);
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

/// Thruster time constants tried (s): the lag is the one nonlinear parameter; each value
/// is tried and the one whose three fits leave the least residual is kept (a grid search
/// on the output of linear fits).
pub const TIME_CONSTANTS_S: (f64, f64, f64) = (0.02, 0.40, 0.01);

/// The three axes' fits at the thruster time constant that explains the record best
/// (the sum over the axes of the log of the residual variance), and that constant.
pub fn fit_axes_with_lag(rec: &Record, prior: &VehicleParams) -> Result<(AxisFits, f64)> {
    let (lo, hi, step) = TIME_CONSTANTS_S;
    let mut best: Option<(f64, AxisFits, f64)> = None;
    let n = ((hi - lo) / step).round() as usize;
    for i in 0..=n {
        let tc = lo + step * i as f64;
        let thrust = rec.nominal_thrust_lagged_n(prior, tc)?;
        let fits = fit_axes(rec, &thrust, prior)?;
        let cost: f64 = fits
            .fits
            .iter()
            .map(|f| f.residual_rms.max(1e-300).ln())
            .sum();
        if best.as_ref().is_none_or(|(c, ..)| cost < *c) {
            best = Some((cost, fits, tc));
        }
    }
    match best {
        Some((_, fits, tc)) => Ok((fits, tc)),
        None => bail!("no thruster time constant tried"),
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
    /// The thruster time constant the fits were made with (s).
    pub thruster_time_constant_s: f64,
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
    let mut cols: Vec<Vec<f64>> = (0..12).map(|_| Vec::with_capacity(DRAWS)).collect();
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
        thruster_time_constant_s: f64::NAN,
    }
}

/// Standard normal draw (Box-Muller; one of the pair is dropped), the simulator's own draw
/// (`sim_world::noise::gauss`), so that a seed gives the same fit there and here.
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}
