//! Horizontal plane: an extended Kalman filter over `[N, E, u_r, v_r, c_N, c_E]` whose
//! prediction is the vehicle's own model (eq. (34), [`crate::model::xy::derivative`]):
//!
//! ```text
//! N_dot = cos(psi) u_r - sin(psi) v_r + c_N     E_dot = sin(psi) u_r + cos(psi) v_r + c_E
//! u_r_dot = alpha1 u_r - alpha2 |u_r| u_r - alpha3 v_r r + tau_1 / m_11
//! v_r_dot = -beta1 v_r - beta2 |v_r| v_r - beta3 u_r r
//! c_dot = w_c (random walk)
//! ```
//!
//! `psi` and `r` come from the heading filter, `tau_1` from the thrust commands through the
//! thrusters' lag. The model is exact in the velocity through the water for a constant,
//! irrotational current, which is why the current is a state of its own.
//!
//! A DVL measures the velocity over the bottom in body axes, `[u_r, v_r] + R(psi)^T c`; a USBL
//! fix measures `[N, E]` at its time of validity (see the module docs of [`super`]).

use super::kf::{dot, nis2, unit, within_gate, Kf, Mat};
use super::{NavConfig, Refusal, GATE_CHI2_2DOF};
use crate::math::{max, sin_cos};
use crate::model::xy;
use crate::params::Vehicle;
use crate::state::{BodyForces, NavState, XyState};
use heapless::HistoryBuffer;

const N: usize = 0;
const E: usize = 1;
const U: usize = 2;
const V: usize = 3;
const CN: usize = 4;
const CE: usize = 5;

/// Interval between two entries of the position history (us).
pub const HISTORY_STEP_US: u64 = 20_000;
/// Entries in the position history: 128 x 20 ms = 2.56 s, the oldest fix accepted.
pub const HISTORY_LEN: usize = 128;

/// Process noise on the position itself (m^2/s): what the kinematics miss (pitch, the
/// plant's small sway from roll).
const POSITION_NOISE_M2_S: f32 = 1.0e-6;

/// One history entry: the position estimate at `t_us` minus the corrections applied up to
/// then.
#[derive(Debug, Clone, Copy, Default)]
struct Past {
    t_us: u64,
    pos: [f32; 2],
}

#[derive(Debug, Clone)]
pub(super) struct Horizontal {
    kf: Kf<6>,
    /// Sum of every position correction applied so far `[N, E]`.
    correction: [f32; 2],
    history: HistoryBuffer<Past, HISTORY_LEN>,
}

impl Horizontal {
    pub(super) fn new(initial: &NavState, cfg: &NavConfig, t_us: u64) -> Self {
        let sp = cfg.initial_position_std_m;
        let sc = cfg.initial_current_std_m_s;
        let sv = 0.1;
        let kf = Kf::new(
            [
                initial.x_m,
                initial.y_m,
                initial.u_m_s,
                initial.v_m_s,
                0.0,
                0.0,
            ],
            [sp * sp, sp * sp, sv * sv, sv * sv, sc * sc, sc * sc],
        );
        let mut history = HistoryBuffer::new();
        history.write(Past {
            t_us,
            pos: [initial.x_m, initial.y_m],
        });
        Self {
            kf,
            correction: [0.0; 2],
            history,
        }
    }

    pub(super) fn position(&self) -> [f32; 2] {
        [self.kf.x[N], self.kf.x[E]]
    }

    pub(super) fn current(&self) -> [f32; 2] {
        [self.kf.x[CN], self.kf.x[CE]]
    }

    pub(super) fn position_covariance(&self) -> [[f32; 2]; 2] {
        [
            [self.kf.var(N), self.kf.cov(N, E)],
            [self.kf.cov(E, N), self.kf.var(E)],
        ]
    }

    /// Body-axis velocity over the ground: through the water plus the current.
    pub(super) fn velocity_over_ground(&self, yaw_rad: f32) -> [f32; 2] {
        let (hu, hv) = dvl_rows(yaw_rad);
        [dot(&hu, &self.kf.x), dot(&hv, &self.kf.x)]
    }

    /// Time of the oldest history entry (us).
    pub(super) fn oldest_us(&self) -> u64 {
        self.history
            .oldest_ordered()
            .next()
            .map_or(u64::MAX, |p| p.t_us)
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn predict(
        &mut self,
        vehicle: &Vehicle,
        cfg: &NavConfig,
        yaw_rad: f32,
        r_rad_s: f32,
        surge_n: f32,
        dt: f32,
        t_us: u64,
    ) {
        let x = &mut self.kf.x;
        let (u, v) = (x[U], x[V]);
        let d = xy::derivative(
            vehicle,
            &XyState {
                x_m: x[N],
                y_m: x[E],
                yaw_rad,
                u_m_s: u,
                v_m_s: v,
                r_rad_s,
            },
            &BodyForces {
                surge_n,
                yaw_n_m: 0.0,
                heave_n: 0.0,
            },
        );
        x[N] += (d.x_m + x[CN]) * dt;
        x[E] += (d.y_m + x[CE]) * dt;
        x[U] += d.u_m_s * dt;
        x[V] += d.v_m_s * dt;

        let c = &vehicle.xy;
        let (s, co) = sin_cos(yaw_rad);
        let mut phi: Mat<6> = [[0.0; 6]; 6];
        phi[N] = [1.0, 0.0, co * dt, -s * dt, dt, 0.0];
        phi[E] = [0.0, 1.0, s * dt, co * dt, 0.0, dt];
        phi[U] = [
            0.0,
            0.0,
            1.0 + (c.alpha1 - 2.0 * c.alpha2 * u.abs()) * dt,
            -c.alpha3 * r_rad_s * dt,
            0.0,
            0.0,
        ];
        phi[V] = [
            0.0,
            0.0,
            -c.beta3 * r_rad_s * dt,
            1.0 - (c.beta1 + 2.0 * c.beta2 * v.abs()) * dt,
            0.0,
            0.0,
        ];
        phi[CN] = unit(CN);
        phi[CE] = unit(CE);
        let m = cfg.model_accel_noise_m_s2_sqrt_hz;
        let w = cfg.current_walk_m_s_sqrt_s;
        let qp = POSITION_NOISE_M2_S * dt;
        let (qm, qc) = (m * m * dt, w * w * dt);
        self.kf.propagate(&phi, &[qp, qp, qm, qm, qc, qc]);

        let due = self
            .history
            .recent()
            .is_none_or(|p| t_us >= p.t_us + HISTORY_STEP_US);
        if due {
            let pos = [
                self.kf.x[N] - self.correction[0],
                self.kf.x[E] - self.correction[1],
            ];
            self.history.write(Past { t_us, pos });
        }
    }

    /// Run `f` on the filter and add the position change it makes to the correction sum.
    fn corrected(&mut self, f: impl FnOnce(&mut Kf<6>)) {
        let before = self.position();
        f(&mut self.kf);
        self.correction[0] += self.kf.x[N] - before[0];
        self.correction[1] += self.kf.x[E] - before[1];
    }

    /// Velocity through the water to the DVL's velocity less the current estimate.
    pub(super) fn reset_velocity(&mut self, yaw_rad: f32, velocity_m_s: [f32; 2], std_m_s: f32) {
        let (s, c) = sin_cos(yaw_rad);
        let (cn, ce) = (self.kf.x[CN], self.kf.x[CE]);
        let var = std_m_s * std_m_s;
        self.kf
            .reset_state(U, velocity_m_s[0] - (c * cn + s * ce), var);
        self.kf
            .reset_state(V, velocity_m_s[1] - (-s * cn + c * ce), var);
    }

    /// Position to the fix (moved on by the displacement since its time of validity).
    pub(super) fn reset_position(&mut self, t_us: u64, now_us: u64, fix: [f32; 2], std_m: f32) {
        let Some(past) = self.past_position(t_us, now_us) else {
            return;
        };
        let var = std_m * std_m;
        let now = self.position();
        self.corrected(|kf| {
            kf.reset_state(N, fix[0] + (now[0] - past[0]), var);
            kf.reset_state(E, fix[1] + (now[1] - past[1]), var);
        });
    }

    pub(super) fn fuse_dvl(
        &mut self,
        yaw_rad: f32,
        velocity_m_s: [f32; 2],
        std_m_s: f32,
    ) -> Result<(), Refusal> {
        let (hu, hv) = dvl_rows(yaw_rad);
        let r = std_m_s * std_m_s;
        let nu = [
            velocity_m_s[0] - dot(&hu, &self.kf.x),
            velocity_m_s[1] - dot(&hv, &self.kf.x),
        ];
        let s00 = self.kf.cross(&hu, &hu) + r;
        let s01 = self.kf.cross(&hu, &hv);
        let s11 = self.kf.cross(&hv, &hv) + r;
        if !within_gate(nis2(nu, s00, s01, s11), GATE_CHI2_2DOF) {
            return Err(Refusal::Outlier);
        }
        self.corrected(|kf| {
            kf.update(&hu, nu[0], r);
            let nu_v = velocity_m_s[1] - dot(&hv, &kf.x);
            kf.update(&hv, nu_v, r);
        });
        Ok(())
    }

    /// The position estimate at `t_us` as corrected since: the history interpolated, plus
    /// the corrections. `None` outside the history.
    fn past_position(&self, t_us: u64, now_us: u64) -> Option<[f32; 2]> {
        let now = Past {
            t_us: now_us,
            pos: [
                self.kf.x[N] - self.correction[0],
                self.kf.x[E] - self.correction[1],
            ],
        };
        let mut prev: Option<Past> = None;
        for p in self
            .history
            .oldest_ordered()
            .copied()
            .chain(core::iter::once(now))
        {
            if p.t_us >= t_us {
                let lo = prev.unwrap_or(p);
                let span = p.t_us.saturating_sub(lo.t_us);
                let a = if span == 0 {
                    1.0
                } else {
                    (t_us - lo.t_us) as f32 / span as f32
                };
                let at = |i: usize| {
                    let (l, h) = (
                        lo.pos.get(i).copied().unwrap_or(0.0),
                        p.pos.get(i).copied().unwrap_or(0.0),
                    );
                    l + a * (h - l)
                };
                if prev.is_none() && p.t_us > t_us {
                    return None;
                }
                return Some([at(0) + self.correction[0], at(1) + self.correction[1]]);
            }
            prev = Some(p);
        }
        None
    }

    pub(super) fn fuse_position(
        &mut self,
        t_us: u64,
        now_us: u64,
        fix: [f32; 2],
        std_m: f32,
    ) -> Result<(), Refusal> {
        let past = self.past_position(t_us, now_us).ok_or(Refusal::TooOld)?;
        let nu = [fix[0] - past[0], fix[1] - past[1]];
        // The displacement since the time of validity is known up to the velocity's
        // uncertainty over the latency.
        let latency_s = now_us.saturating_sub(t_us) as f32 * 1.0e-6;
        let var_v = max(self.kf.var(U), self.kf.var(V)) + max(self.kf.var(CN), self.kf.var(CE));
        let r = std_m * std_m + var_v * latency_s * latency_s;
        let s00 = self.kf.var(N) + r;
        let s01 = self.kf.cov(N, E);
        let s11 = self.kf.var(E) + r;
        if !within_gate(nis2(nu, s00, s01, s11), GATE_CHI2_2DOF) {
            return Err(Refusal::Outlier);
        }
        self.corrected(|kf| {
            let e_before = kf.x[E];
            kf.update(&unit(N), nu[0], r);
            // The first update moved today's east estimate, and the past one with it.
            let nu_e = nu[1] - (kf.x[E] - e_before);
            kf.update(&unit(E), nu_e, r);
        });
        Ok(())
    }
}

/// Rows of the DVL measurement `[u, v]_ground = [u_r, v_r] + R(psi)^T [c_N, c_E]`.
fn dvl_rows(yaw_rad: f32) -> ([f32; 6], [f32; 6]) {
    let (s, c) = sin_cos(yaw_rad);
    ([0.0, 0.0, 1.0, 0.0, c, s], [0.0, 0.0, 0.0, 1.0, -s, c])
}
