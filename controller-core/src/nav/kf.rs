//! A small Kalman filter over `N` states with fixed-size arrays: covariance propagation
//! `P <- Phi P Phi^T + Q` and sequential scalar measurement updates.
//!
//! Scalar updates need no matrix inverse: a measurement with uncorrelated components is
//! fused one component at a time, which is exact for a diagonal `R`. The update
//! `P <- P - (P h)(P h)^T / s` is symmetric by construction; the propagation is symmetrized
//! and every variance is kept above [`VAR_FLOOR`] so that rounding in `f32` cannot make
//! `P` indefinite. All loops run over the arrays themselves, so there is no index to go out
//! of bounds.

/// An `N x N` matrix, row-major.
pub type Mat<const N: usize> = [[f32; N]; N];

/// Smallest variance kept on the diagonal.
pub const VAR_FLOOR: f32 = 1.0e-12;

/// `a . b`.
pub fn dot<const N: usize>(a: &[f32; N], b: &[f32; N]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `a b^T` (row `i` of `a` dotted with row `j` of `b`).
fn mul_abt<const N: usize>(a: &Mat<N>, b: &Mat<N>) -> Mat<N> {
    let mut out = [[0.0; N]; N];
    for (o_row, a_row) in out.iter_mut().zip(a) {
        for (o, b_row) in o_row.iter_mut().zip(b) {
            *o = dot(a_row, b_row);
        }
    }
    out
}

/// `m[i][j]`, or 0 outside (never, for `i, j < N`).
fn at<const N: usize>(m: &Mat<N>, i: usize, j: usize) -> f32 {
    m.get(i).and_then(|r| r.get(j)).copied().unwrap_or(0.0)
}

/// State and covariance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Kf<const N: usize> {
    /// State.
    pub x: [f32; N],
    /// Covariance.
    pub p: Mat<N>,
}

impl<const N: usize> Kf<N> {
    /// A filter at `x` with a diagonal covariance `var`.
    pub fn new(x: [f32; N], var: [f32; N]) -> Self {
        let mut p = [[0.0; N]; N];
        for (i, (row, v)) in p.iter_mut().zip(var).enumerate() {
            if let Some(d) = row.get_mut(i) {
                *d = v;
            }
        }
        Self { x, p }
    }

    /// `P <- Phi P Phi^T + diag(q)` (the state is propagated by the caller, through the
    /// nonlinear model).
    pub fn propagate(&mut self, phi: &Mat<N>, q: &[f32; N]) {
        // P is symmetric, so Phi P = Phi P^T = mul_abt(Phi, P).
        let p = mul_abt(&mul_abt(phi, &self.p), phi);
        for (i, row) in self.p.iter_mut().enumerate() {
            for (j, o) in row.iter_mut().enumerate() {
                *o = 0.5 * (at(&p, i, j) + at(&p, j, i));
            }
        }
        for (i, (row, qi)) in self.p.iter_mut().zip(q).enumerate() {
            if let Some(d) = row.get_mut(i) {
                *d += qi;
            }
        }
        self.floor();
    }

    /// `P h`.
    pub fn p_h(&self, h: &[f32; N]) -> [f32; N] {
        let mut out = [0.0; N];
        for (o, row) in out.iter_mut().zip(&self.p) {
            *o = dot(row, h);
        }
        out
    }

    /// `h_a^T P h_b`.
    pub fn cross(&self, h_a: &[f32; N], h_b: &[f32; N]) -> f32 {
        dot(h_a, &self.p_h(h_b))
    }

    /// Fuse one scalar measurement with row `h`, innovation `innovation` and variance `r`.
    /// Returns `false` (and changes nothing) when the innovation variance is not positive
    /// and finite.
    pub fn update(&mut self, h: &[f32; N], innovation: f32, r: f32) -> bool {
        let ph = self.p_h(h);
        let s = dot(h, &ph) + r;
        if !(s.is_finite() && s > 0.0 && innovation.is_finite()) {
            return false;
        }
        let inv_s = 1.0 / s;
        for (x, phi) in self.x.iter_mut().zip(&ph) {
            *x += phi * inv_s * innovation;
        }
        for (row, phi) in self.p.iter_mut().zip(&ph) {
            for (o, phj) in row.iter_mut().zip(&ph) {
                *o -= phi * phj * inv_s;
            }
        }
        self.floor();
        true
    }

    /// Set state `i` to `value` with variance `var` and no correlation with the others.
    pub fn reset_state(&mut self, i: usize, value: f32, var: f32) {
        if let Some(x) = self.x.get_mut(i) {
            *x = value;
        }
        for (r, row) in self.p.iter_mut().enumerate() {
            for (c, o) in row.iter_mut().enumerate() {
                if r == i || c == i {
                    *o = if r == c { var } else { 0.0 };
                }
            }
        }
        self.floor();
    }

    /// Variance of state `i`.
    pub fn var(&self, i: usize) -> f32 {
        at(&self.p, i, i)
    }

    /// Covariance of states `i` and `j`.
    pub fn cov(&self, i: usize, j: usize) -> f32 {
        at(&self.p, i, j)
    }

    fn floor(&mut self) {
        for (i, row) in self.p.iter_mut().enumerate() {
            if let Some(d) = row.get_mut(i) {
                if d.is_nan() || *d < VAR_FLOOR {
                    *d = VAR_FLOOR;
                }
            }
        }
    }
}

/// True when a normalized innovation squared is inside the gate (false for NaN).
pub fn within_gate(nis: f32, gate: f32) -> bool {
    nis <= gate
}

/// Unit row `e_i`.
pub fn unit<const N: usize>(i: usize) -> [f32; N] {
    let mut h = [0.0; N];
    if let Some(v) = h.get_mut(i) {
        *v = 1.0;
    }
    h
}

/// Normalized innovation squared of a 2-D innovation `nu` with covariance
/// `[[s00, s01], [s01, s11]]`; infinite when the covariance is not positive definite.
pub fn nis2(nu: [f32; 2], s00: f32, s01: f32, s11: f32) -> f32 {
    let det = s00 * s11 - s01 * s01;
    if !(det > 0.0 && s00 > 0.0) {
        return f32::INFINITY;
    }
    (nu[0] * nu[0] * s11 - 2.0 * nu[0] * nu[1] * s01 + nu[1] * nu[1] * s00) / det
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalar_update_matches_the_closed_form() {
        // Two states, measure the first: K = P h / (h P h + r).
        let mut kf = Kf::new([0.0, 0.0], [4.0, 1.0]);
        kf.p[0][1] = 1.0;
        kf.p[1][0] = 1.0;
        assert!(kf.update(&unit(0), 2.0, 4.0));
        // s = 8, K = [0.5, 0.125].
        assert!((kf.x[0] - 1.0).abs() < 1e-6);
        assert!((kf.x[1] - 0.25).abs() < 1e-6);
        assert!((kf.p[0][0] - 2.0).abs() < 1e-6);
        assert!((kf.p[0][1] - 0.5).abs() < 1e-6);
        assert!((kf.p[1][1] - 0.875).abs() < 1e-6);
        assert_eq!(kf.p[0][1], kf.p[1][0]);
    }

    #[test]
    fn propagation_is_phi_p_phi_t_plus_q() {
        let mut kf = Kf::new([0.0, 0.0], [1.0, 2.0]);
        let phi = [[1.0, 0.5], [0.0, 1.0]];
        kf.propagate(&phi, &[0.1, 0.2]);
        // [[1 + 0.25*2 + 0.1, 0.5*2], [1, 2 + 0.2]]
        assert!((kf.p[0][0] - 1.6).abs() < 1e-6);
        assert!((kf.p[0][1] - 1.0).abs() < 1e-6);
        assert!((kf.p[1][0] - 1.0).abs() < 1e-6);
        assert!((kf.p[1][1] - 2.2).abs() < 1e-6);
    }

    #[test]
    fn a_non_finite_innovation_changes_nothing() {
        let mut kf = Kf::new([1.0, 2.0], [1.0, 1.0]);
        let before = kf;
        assert!(!kf.update(&unit(0), f32::NAN, 1.0));
        assert!(!kf.update(&unit(0), 1.0, f32::NAN));
        assert_eq!(kf, before);
    }

    #[test]
    fn nis_of_a_diagonal_covariance() {
        assert!((nis2([3.0, 4.0], 1.0, 0.0, 4.0) - (9.0 + 4.0)).abs() < 1e-5);
        assert!(nis2([1.0, 1.0], 0.0, 0.0, 1.0).is_infinite());
    }
}
