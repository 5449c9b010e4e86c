//! The navigation floor: a fixed-interval Rauch-Tung-Striebel smoother in `f64` that sees
//! the run's measurements with hindsight, on the on-board estimator's own model.
//!
//! The on-board filter must answer *now* from what has arrived; the smoother answers, after
//! the run, from everything: every USBL fix at its time of validity (no latency to bridge),
//! every later fix and heading pulling earlier estimates too. On the same model and the same
//! measurements no estimator can do better in the mean, so its RMS error against the truth is
//! the floor the on-board figure is judged against (`summary.json`, `navigation.floor`).
//!
//! [`rts`] is the smoother over a recorded forward pass (any state size);
//! [`crate::closed_loop::floor`] records a run and runs the navigation model through it.
//!
//! Backward recursion (Rauch, Tung and Striebel 1965), with `x_p, P_p` the prediction into
//! epoch `k + 1` and `Phi` the transition from `k` to `k + 1`:
//!
//! ```text
//! C_k   = P_f,k Phi^T P_p,k+1^-1
//! x_s,k = x_f,k + C_k (x_s,k+1 - x_p,k+1)
//! P_s,k = P_f,k + C_k (P_s,k+1 - P_p,k+1) C_k^T
//! ```
//!
//! `P_p^-1` is never formed: `C_k^T` is the Cholesky solve of `P_p C_k^T = Phi P_f`.

use nalgebra::{SMatrix, SVector};

/// One epoch of a forward filter pass.
#[derive(Debug, Clone)]
pub struct Epoch<const D: usize> {
    /// Time (us).
    pub t_us: u64,
    /// Transition from the previous epoch to this one (identity for the first).
    pub phi: SMatrix<f64, D, D>,
    /// Prediction into this epoch, before its measurements.
    pub x_p: SVector<f64, D>,
    /// Its covariance.
    pub p_p: SMatrix<f64, D, D>,
    /// Filtered estimate, after this epoch's measurements.
    pub x_f: SVector<f64, D>,
    /// Its covariance.
    pub p_f: SMatrix<f64, D, D>,
}

/// Smoothed estimates, one per epoch, from a forward pass. `diff(a, b)` is `a - b` in the
/// state's geometry (angles wrapped). `None` when a predicted covariance is not positive
/// definite (a broken forward pass).
pub fn rts<const D: usize>(
    epochs: &[Epoch<D>],
    diff: impl Fn(&SVector<f64, D>, &SVector<f64, D>) -> SVector<f64, D>,
) -> Option<Vec<(SVector<f64, D>, SMatrix<f64, D, D>)>> {
    let last = epochs.last()?;
    let mut out = vec![(last.x_f, last.p_f); epochs.len()];
    for k in (0..epochs.len() - 1).rev() {
        let (now, next) = (&epochs[k], &epochs[k + 1]);
        let chol = next.p_p.cholesky()?;
        let c_t = chol.solve(&(next.phi * now.p_f));
        let c = c_t.transpose();
        let (x_next, p_next) = out[k + 1];
        let x = now.x_f + c * diff(&x_next, &next.x_p);
        let p = now.p_f + c * (p_next - next.p_p) * c_t;
        out[k] = (x, 0.5 * (p + p.transpose()));
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix2, Vector2};

    /// A body moving at constant velocity, its position measured at every epoch: with no
    /// process noise and a diffuse prior the smoothed track is the least-squares line through
    /// the measurements, at every epoch (the forward filter only reaches it at the last).
    #[test]
    fn constant_velocity_smooths_to_the_least_squares_line() {
        let dt = 0.5;
        let r = 0.04;
        let zs = [0.13, 0.41, 1.22, 1.38, 2.05, 2.61, 2.87, 3.66, 3.92, 4.71];
        let phi = Matrix2::new(1.0, dt, 0.0, 1.0);
        let h = nalgebra::RowVector2::new(1.0, 0.0);
        let mut x = Vector2::zeros();
        let mut p = Matrix2::identity() * 1e8;
        let mut epochs = Vec::new();
        for (k, z) in zs.iter().enumerate() {
            let (x_p, p_p, phi_k) = if k == 0 {
                (x, p, Matrix2::identity())
            } else {
                (phi * x, phi * p * phi.transpose(), phi)
            };
            let s = (h * p_p * h.transpose())[0] + r;
            let kg = p_p * h.transpose() / s;
            x = x_p + kg * (z - (h * x_p)[0]);
            p = p_p - kg * s * kg.transpose();
            epochs.push(Epoch {
                t_us: k as u64,
                phi: phi_k,
                x_p,
                p_p,
                x_f: x,
                p_f: p,
            });
        }
        let sm = rts(&epochs, |a, b| a - b).unwrap();
        // Least squares: z = a + b t.
        let n = zs.len() as f64;
        let ts: Vec<f64> = (0..zs.len()).map(|k| k as f64 * dt).collect();
        let (st, sz) = (ts.iter().sum::<f64>(), zs.iter().sum::<f64>());
        let stt: f64 = ts.iter().map(|t| t * t).sum();
        let stz: f64 = ts.iter().zip(&zs).map(|(t, z)| t * z).sum();
        let b = (n * stz - st * sz) / (n * stt - st * st);
        let a = (sz - b * st) / n;
        // Slope variance of the line: r / sum (t - mean)^2.
        let var_b = r / (stt - st * st / n);
        for (k, (xs, ps)) in sm.iter().enumerate() {
            let t = ts[k];
            assert!((xs[0] - (a + b * t)).abs() < 1e-6, "epoch {k}: {}", xs[0]);
            assert!((xs[1] - b).abs() < 1e-6, "epoch {k}: {}", xs[1]);
            // Relative 1e-4: the diffuse prior (1e8) costs digits in the covariance updates.
            assert!((ps[(1, 1)] - var_b).abs() < 1e-4 * var_b, "{}", ps[(1, 1)]);
        }
        // The filter alone is on the line only at the end.
        assert!((epochs[0].x_f[0] - (a + b * ts[0])).abs() > 0.05);
    }

    #[test]
    fn a_broken_prediction_covariance_gives_none() {
        let e = Epoch {
            t_us: 0,
            phi: Matrix2::identity(),
            x_p: Vector2::zeros(),
            p_p: Matrix2::zeros(),
            x_f: Vector2::zeros(),
            p_f: Matrix2::identity(),
        };
        assert!(rts(&[e.clone(), e], |a, b| a - b).is_none());
        assert!(rts::<2>(&[], |a, b| a - b).is_none());
    }
}
