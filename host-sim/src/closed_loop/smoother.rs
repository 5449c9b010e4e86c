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
