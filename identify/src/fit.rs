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
//! divided by its mass: one force has to be known to give them in newtons
//! ([`crate::physical`]).

use super::record::Record;
use super::regression::{least_squares, FitError, LinearFit};
use anyhow::{bail, Result};
use controller_core::params::VehicleParams;
use nalgebra::{DMatrix, DVector};

/// Length of one regression window (s): many thruster time constants. A longer window
/// raises the velocity change against the DVL's noise at its two ends (measured on
/// heavy-slow, the heave quadratic drag's standard error: 8 % at 0.5 s, 6 % at 1 s).
pub const WINDOW_S: f64 = 1.0;
/// Length of a validation block (s); every [`HOLD_OUT_EVERY`]th block is held out.
pub const BLOCK_S: f64 = 10.0;
/// One block in this many is kept from the fit for the validation.
pub const HOLD_OUT_EVERY: usize = 4;

/// One of the three fitted axes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// Surge (`u`, the horizontal pair together).
    Surge,
    /// Yaw (`r`, the horizontal pair in opposition).
    Yaw,
    /// Heave (`w`, the vertical thruster).
    Heave,
    /// Sway (`v`): no thruster, excited by the turns under way ([`crate::sway`]); not in
    /// [`Axis::ALL`].
    Sway,
}

impl Axis {
    /// The three thrust axes, in fit order.
    pub const ALL: [Axis; 3] = [Axis::Surge, Axis::Yaw, Axis::Heave];

    /// Its name.
    pub fn name(self) -> &'static str {
        match self {
            Axis::Surge => "surge",
            Axis::Yaw => "yaw",
            Axis::Heave => "heave",
            Axis::Sway => "sway",
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
            Axis::Sway => &[
                "sway u r",
                "sway p w",
                "sway roll buoyancy",
                "sway v",
                "sway |v|v",
                "sway q r",
                "sway roll acceleration",
            ],
        }
    }

    /// Smallest span of the axis's velocity (m/s or rad/s) that counts as excited.
    fn min_span(self) -> f64 {
        match self {
            Axis::Surge => 0.15,
            Axis::Yaw => 0.2,
            Axis::Heave => 0.1,
            Axis::Sway => 0.1,
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
        Axis::Sway => vec![
            m11 / m22,
            mz / m22,
            f(p.buoyancy_offset_n) / m22,
            f(p.y_v) / m22,
            f(p.y_vv) / m22,
            a_uq / m22,
            a_uq / m22,
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
    /// (surge: the pitch rate, whose derivative the surge-pitch mass couples in; sway: the
    /// roll rate, likewise); empty for the other axes.
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
            Axis::Sway => {
                out.diff.push(p);
                (
                    v,
                    vec![
                        -u * r,
                        p * w,
                        -pitch.cos() * roll.sin(),
                        -v,
                        -v.abs() * v,
                        -q * r,
                    ],
                )
            }
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
