//! Linear least squares with confidence intervals: `y = Phi theta + e`, solved through
//! nalgebra's SVD (no normal equations formed by hand, no hand-written inversion), with the
//! parameter covariance `s^2 (Phi^T Phi)^-1` from the same decomposition and 95 % intervals
//! from the normal approximation (the records hold thousands of samples, so Student's t and
//! the normal quantile agree to three digits).

use nalgebra::{DMatrix, DVector};
use std::fmt;

/// Normal quantile of a two-sided 95 % interval.
pub const Z_95: f64 = 1.959_964;

/// A regression the data cannot support.
#[derive(Debug, Clone, PartialEq)]
pub enum FitError {
    /// Fewer samples than parameters plus one (no residual degree of freedom).
    TooFewSamples {
        /// Samples given.
        samples: usize,
        /// Parameters asked for.
        parameters: usize,
    },
    /// A regressor column does not vary independently of the others: its name and the
    /// ratio of the smallest to the largest singular value of the scaled regressors.
    NotExcited {
        /// The regressor whose direction the data does not span.
        regressor: String,
        /// Smallest over largest singular value of the column-normalised regressors.
        conditioning: f64,
    },
    /// A sample is NaN or infinite.
    NonFinite,
}

impl fmt::Display for FitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooFewSamples {
                samples,
                parameters,
            } => write!(f, "{samples} samples for {parameters} parameters"),
            Self::NotExcited {
                regressor,
                conditioning,
            } => write!(
                f,
                "the record does not excite `{regressor}` (singular value ratio {conditioning:.1e})"
            ),
            Self::NonFinite => write!(f, "a sample is NaN or infinite"),
        }
    }
}

impl std::error::Error for FitError {}

/// The result of one linear regression.
#[derive(Debug, Clone)]
pub struct LinearFit {
    /// Estimated parameters, in the order of the regressor columns.
    pub theta: DVector<f64>,
    /// Their covariance `s^2 (Phi^T Phi)^-1`.
    pub covariance: DMatrix<f64>,
    /// Residual RMS (the equation error's standard deviation estimate `s`).
    pub residual_rms: f64,
    /// Samples used.
    pub samples: usize,
}

impl LinearFit {
    /// Standard error of parameter `i`.
    pub fn std_error(&self, i: usize) -> f64 {
        self.covariance
            .get((i, i))
            .copied()
            .unwrap_or(f64::NAN)
            .max(0.0)
            .sqrt()
    }

    /// 95 % half-width of parameter `i`.
    pub fn half_width_95(&self, i: usize) -> f64 {
        Z_95 * self.std_error(i)
    }
}

/// Smallest singular value ratio accepted for the column-normalised regressors: below it
/// one direction of the parameter space is not seen by the data.
pub const MIN_CONDITIONING: f64 = 1e-4;

/// Solve `y = Phi theta` in the least-squares sense; `names` label the columns for the
/// refusal of a record that does not excite one of them.
pub fn least_squares(
    phi: &DMatrix<f64>,
    y: &DVector<f64>,
    names: &[&str],
) -> Result<LinearFit, FitError> {
    let (n, p) = phi.shape();
    if n <= p || y.len() != n {
        return Err(FitError::TooFewSamples {
            samples: n.min(y.len()),
            parameters: p,
        });
    }
    if phi.iter().chain(y.iter()).any(|v| !v.is_finite()) {
        return Err(FitError::NonFinite);
    }
    // Column scaling: the conditioning test then measures collinearity, not units.
    let scale = DVector::from_iterator(
        p,
        phi.column_iter().map(|c| {
            let norm = c.norm();
            if norm > 0.0 {
                norm
            } else {
                1.0
            }
        }),
    );
    let mut scaled = phi.clone();
    for (mut col, s) in scaled.column_iter_mut().zip(scale.iter()) {
        col /= *s;
    }
    let svd = scaled.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let (imin, smin) = svd.singular_values.argmin();
    let conditioning = if smax > 0.0 { smin / smax } else { 0.0 };
    if conditioning < MIN_CONDITIONING {
        // The weakest direction's largest component names the unexcited regressor.
        let regressor = svd
            .v_t
            .as_ref()
            .map(|vt| vt.row(imin).transpose().iamax())
            .and_then(|j| names.get(j))
            .map_or_else(|| "?".to_string(), |s| (*s).to_string());
        return Err(FitError::NotExcited {
            regressor,
            conditioning,
        });
    }
    let (Some(u), Some(v_t)) = (&svd.u, &svd.v_t) else {
        return Err(FitError::NonFinite);
    };
    let inv_s = svd.singular_values.map(|s| 1.0 / s);
    // theta_scaled = V S^-1 U^T y; covariance_scaled = V S^-2 V^T.
    let uty = u.transpose() * y;
    let theta_scaled = v_t.transpose() * uty.component_mul(&inv_s);
    let theta = theta_scaled.component_div(&scale);
    let residual = y - phi * &theta;
    let dof = (n - p) as f64;
    let s2 = residual.norm_squared() / dof;
    let vs = v_t.transpose() * DMatrix::from_diagonal(&inv_s);
    let cov_scaled = &vs * vs.transpose();
    let inv_scale = scale.map(|s| 1.0 / s);
    let d = DMatrix::from_diagonal(&inv_scale);
    let covariance = &d * cov_scaled * &d * s2;
    Ok(LinearFit {
        theta,
        covariance,
        residual_rms: s2.sqrt(),
        samples: n,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 1-DOF surge: `m u_dot = tau - X_u u - X_uu |u| u`, RK4 at 100 Hz, thrust steps.
    fn surge_record(m: f64, xu: f64, xuu: f64) -> (Vec<f64>, Vec<f64>, f64) {
        let dt = 0.01;
        let f = |u: f64, tau: f64| (tau - xu * u - xuu * u.abs() * u) / m;
        let levels = [10.0, 25.0, -8.0, -20.0, 15.0, 0.0, 30.0, -30.0];
        let mut u = 0.0;
        let (mut us, mut taus) = (Vec::new(), Vec::new());
        for &tau in &levels {
            for _ in 0..400 {
                us.push(u);
                taus.push(tau);
                let k1 = f(u, tau);
                let k2 = f(u + 0.5 * dt * k1, tau);
                let k3 = f(u + 0.5 * dt * k2, tau);
                let k4 = f(u + dt * k3, tau);
                u += dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
            }
        }
        (us, taus, dt)
    }

    #[test]
    fn noise_free_surge_record_gives_mass_and_drag_within_one_percent() {
        let (m, xu, xuu) = (11.92, 0.9613, 4.4674);
        let (u, tau, dt) = surge_record(m, xu, xuu);
        // u_dot = tau/m - (X_u/m) u - (X_uu/m)|u|u; central differences, interior samples
        // whose thrust is the same on both sides.
        let rows: Vec<[f64; 4]> = (1..u.len() - 1)
            .filter(|&k| tau[k - 1] == tau[k])
            .map(|k| {
                let udot = (u[k + 1] - u[k - 1]) / (2.0 * dt);
                [tau[k], -u[k], -u[k].abs() * u[k], udot]
            })
            .collect();
        let phi = DMatrix::from_fn(rows.len(), 3, |i, j| rows[i][j]);
        let y = DVector::from_iterator(rows.len(), rows.iter().map(|r| r[3]));
        let fit = least_squares(&phi, &y, &["thrust", "u", "|u|u"]).unwrap();
        let m_hat = 1.0 / fit.theta[0];
        let xu_hat = fit.theta[1] * m_hat;
        let xuu_hat = fit.theta[2] * m_hat;
        assert!((m_hat / m - 1.0).abs() < 0.01, "mass {m_hat}");
        assert!((xu_hat / xu - 1.0).abs() < 0.01, "X_u {xu_hat}");
        assert!((xuu_hat / xuu - 1.0).abs() < 0.01, "X_uu {xuu_hat}");
    }

    #[test]
    fn a_record_without_thrust_is_refused_naming_it() {
        let (u, _, dt) = surge_record(11.0, 1.0, 4.0);
        let n = u.len() - 2;
        let phi = DMatrix::from_fn(n, 3, |i, j| match j {
            0 => 0.0,
            1 => -u[i + 1],
            _ => -u[i + 1].abs() * u[i + 1],
        });
        let y = DVector::from_fn(n, |i, _| (u[i + 2] - u[i]) / (2.0 * dt));
        let err = least_squares(&phi, &y, &["thrust", "u", "|u|u"]).unwrap_err();
        match err {
            FitError::NotExcited { regressor, .. } => assert_eq!(regressor, "thrust"),
            other => panic!("{other}"),
        }
    }
}
