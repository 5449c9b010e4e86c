//! Horizontal plane: an extended Kalman filter over `[N, E, u_r, v_r, c_N, c_E, psi, b_r, b_c]`
//! whose prediction is the vehicle's own model (eq. (34), [`crate::model::xy::derivative`]):
//!
//! ```text
//! N_dot = cos(psi) u_r - sin(psi) v_r + c_N     E_dot = sin(psi) u_r + cos(psi) v_r + c_E
//! u_r_dot = alpha1 u_r - alpha2 |u_r| u_r - alpha3 v_r r + tau_1 / m_11
//! v_r_dot = -beta1 v_r - beta2 |v_r| v_r - beta3 u_r r
//! c_dot = w_c (random walk)
//! psi_dot = (sin(phi) q + cos(phi) r) / cos(theta),   r = r_gyro - b_r,   b_r_dot = w_b
//! ```
//!
//! `phi`, `theta` and `q` come from the tilt filter, `tau_1` from the thrust commands through
//! the thrusters' lag. The heading is a state of this filter, not of one of its own, because
//! its error rotates every velocity into the position: kept apart, a heading error of a few
//! milliradians drifts the position by centimetres that the covariance does not know about
//! (the position NEES fell to 0.88 on the lawnmower). The model is exact in the velocity through the water for a constant,
//! irrotational current, which is why the current is a state of its own.
//!
//! A DVL measures the velocity over the bottom in body axes, `[u_r, v_r] + R(psi)^T c`; a USBL
//! fix measures `[N, E]` at its time of validity (see the module docs of [`super`]); a
//! compass measures `psi + b_c`.
//!
//! **Compass bias** `b_c`: a magnetometer next to thrusters, batteries and a frame
//! reads a few degrees off. Taken as the heading, that error rotates the DVL's dead reckoning
//! and the filter drifts along the wrong course while refusing the USBL fixes that say so.
//! With `b_c` a state (a slow random walk, like PX4 EKF2's magnetometer bias states), the
//! compass fixes only `psi + b_c`; `psi` itself is fixed by the gyro's integration and by the
//! position: a heading error `d_psi` moves the dead-reckoned position by `d_psi` times the
//! distance run, across the track, which the USBL fixes see. The turns of a survey make the
//! two apart (the error's direction turns with the track, a current's does not).

use super::config::NavConfig;
use super::kf::{nis2, unit, within_gate, Kf, Mat};
use super::refusal::{Refusal, GATE_CHI2_1DOF, GATE_CHI2_2DOF};
use crate::math::{max, sin_cos, wrap_angle};
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
const PSI: usize = 6;
const BR: usize = 7;
/// Compass bias: the compass reads `psi + b_c`.
const BC: usize = 8;
/// States.
const NX: usize = 9;

/// Interval between two entries of the position history (us).
pub const HISTORY_STEP_US: u64 = 20_000;
/// Entries in the position history: 128 x 20 ms = 2.56 s, the oldest fix accepted.
pub const HISTORY_LEN: usize = 128;

/// Refused USBL fixes kept for the cluster test.
pub const CLUSTER_LEN: usize = 8;
/// Refused fixes that must agree with each other before the position is moved to them.
pub const CLUSTER_MIN: usize = 5;
/// The oldest refused fix a cluster may hold, counted back from the newest (us).
pub const CLUSTER_WINDOW_US: u64 = 30_000_000;
/// Two refused fixes agree when their offsets differ by less than this chi-square (99 %,
/// 2 degrees of freedom) times the sum of their variances.
const CLUSTER_CHI2: f32 = 9.21;

/// Gate of a USBL fix's 2-D innovation: chi-square at 99 % (the other sensors' gates are at
/// 99.9 %). Multipath outliers 1-2 m off a fix of 0.3 m passed the 99.9 % gate (radius
/// 3.7 sigma, 1.1 m) one time in ten and pulled the estimate (20 % near outliers
/// cost 2 cm of tracking against 1.3 cm for the same fixes simply missing); at 99 %
/// (3.0 sigma, 0.9 m) none passes, at the price of one good fix in a hundred refused, which
/// the cluster rule never mistakes for a new cluster (they scatter). A Huber down-weighting
/// of the innovations beyond 2 sigma was tried as well and cost the clean runs more than it
/// saved (2026-11-26, docs/navigation.md).
pub const USBL_GATE_CHI2: f32 = 9.21;

/// A USBL fix the gate refused: its offset from the history's (uncorrected) estimate at its
/// time of validity. Offsets of different fixes are comparable with each other whatever
/// corrections were applied in between, because none of them includes a correction.
#[derive(Debug, Clone, Copy, Default)]
struct RefusedFix {
    t_us: u64,
    /// Sequence number of the fix among every fix that reached the gate.
    seq: u32,
    offset: [f32; 2],
    var: f32,
}

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
    kf: Kf<NX>,
    /// Sum of every position correction applied so far `[N, E]`.
    correction: [f32; 2],
    history: HistoryBuffer<Past, HISTORY_LEN>,
    /// The last refused USBL fixes, for the cluster test.
    refused: HistoryBuffer<RefusedFix, CLUSTER_LEN>,
    /// USBL fixes that reached the gate so far.
    fix_seq: u32,
}

impl Horizontal {
    pub(super) fn new(initial: &NavState, cfg: &NavConfig, t_us: u64) -> Self {
        let sp = cfg.initial_position_std_m;
        let sc = cfg.initial_current_std_m_s;
        let sv = 0.1;
        let s_psi = cfg.initial_heading_std_rad;
        let s_b = cfg.initial_gyro_bias_std_rad_s;
        let s_c = cfg.initial_compass_bias_std_rad;
        let kf = Kf::new(
            [
                initial.x_m,
                initial.y_m,
                initial.u_m_s,
                initial.v_m_s,
                0.0,
                0.0,
                initial.yaw_rad,
                0.0,
                0.0,
            ],
            [
                sp * sp,
                sp * sp,
                sv * sv,
                sv * sv,
                sc * sc,
                sc * sc,
                s_psi * s_psi,
                s_b * s_b,
                s_c * s_c,
            ],
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
            refused: HistoryBuffer::new(),
            fix_seq: 0,
        }
    }

    pub(super) fn position(&self) -> [f32; 2] {
        [self.kf.x[N], self.kf.x[E]]
    }

    pub(super) fn yaw(&self) -> f32 {
        self.kf.x[PSI]
    }

    pub(super) fn yaw_variance(&self) -> f32 {
        self.kf.var(PSI)
    }

    /// The compass bias estimate (rad) and its variance.
    pub(super) fn compass_bias(&self) -> (f32, f32) {
        (self.kf.x[BC], self.kf.var(BC))
    }

    /// Take `from`'s current and gyro and compass biases, with their variances (their
    /// correlations with the rest cleared): what a running filter learned of the water and
    /// the instruments, kept across a restart of the position and heading.
    pub(super) fn keep_learned(&mut self, from: &Self) {
        for i in [CN, CE, BR, BC] {
            let x = from.kf.x.get(i).copied().unwrap_or(0.0);
            self.kf.reset_state(i, x, from.kf.var(i));
        }
        // The learned states among themselves keep their correlations.
        for i in [CN, CE, BR, BC] {
            for j in [CN, CE, BR, BC] {
                if i != j {
                    if let Some(o) = self.kf.p.get_mut(i).and_then(|r| r.get_mut(j)) {
                        *o = from.kf.cov(i, j);
                    }
                }
            }
        }
    }

    /// Move the compass bias estimate by `d_rad`.
    pub(super) fn shift_compass_bias(&mut self, d_rad: f32) {
        self.kf.x[BC] = wrap_angle(self.kf.x[BC] + d_rad);
    }

    pub(super) fn gyro_bias_r(&self) -> f32 {
        self.kf.x[BR]
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
    pub(super) fn velocity_over_ground(&self) -> [f32; 2] {
        over_ground(&self.kf.x)
    }

    /// Time of the oldest history entry (us).
    pub(super) fn oldest_us(&self) -> u64 {
        self.history
            .oldest_ordered()
            .next()
            .map_or(u64::MAX, |p| p.t_us)
    }

    /// Propagate by `dt`: `tilt` is `(roll, pitch, q)` with `q` bias-corrected, `r_gyro` the
    /// raw yaw-axis rate, `surge_n` the surge force the thrusters make.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn predict(
        &mut self,
        vehicle: &Vehicle,
        cfg: &NavConfig,
        tilt: (f32, f32, f32),
        r_gyro_rad_s: f32,
        surge_n: f32,
        dt: f32,
        t_us: u64,
    ) {
        let (roll, pitch, q) = tilt;
        let (sr, cr) = sin_cos(roll);
        let (_, cp) = sin_cos(pitch);
        let inv_cp = 1.0 / cp;
        let x = &mut self.kf.x;
        let yaw_rad = x[PSI];
        let r_rad_s = r_gyro_rad_s - x[BR];
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
        x[PSI] = wrap_angle(yaw_rad + (sr * q + cr * r_rad_s) * inv_cp * dt);

        let c = &vehicle.xy;
        let (s, co) = sin_cos(yaw_rad);
        let mut phi: Mat<NX> = [[0.0; NX]; NX];
        let dn_dpsi = -s * u - co * v;
        let de_dpsi = co * u - s * v;
        phi[N] = [1.0, 0.0, co * dt, -s * dt, dt, 0.0, dn_dpsi * dt, 0.0, 0.0];
        phi[E] = [0.0, 1.0, s * dt, co * dt, 0.0, dt, de_dpsi * dt, 0.0, 0.0];
        // r = r_gyro - b_r enters the Coriolis terms: d(u_dot)/d(b_r) = alpha3 v.
        phi[U] = [
            0.0,
            0.0,
            1.0 + (c.alpha1 - 2.0 * c.alpha2 * u.abs()) * dt,
            -c.alpha3 * r_rad_s * dt,
            0.0,
            0.0,
            0.0,
            c.alpha3 * v * dt,
            0.0,
        ];
        phi[V] = [
            0.0,
            0.0,
            -c.beta3 * r_rad_s * dt,
            1.0 - (c.beta1 + 2.0 * c.beta2 * v.abs()) * dt,
            0.0,
            0.0,
            0.0,
            c.beta3 * u * dt,
            0.0,
        ];
        phi[CN] = unit(CN);
        phi[CE] = unit(CE);
        phi[PSI] = unit(PSI);
        phi[PSI][BR] = -cr * inv_cp * dt;
        phi[BR] = unit(BR);
        phi[BC] = unit(BC);
        let m = cfg.model_accel_noise_m_s2_sqrt_hz;
        let w = cfg.current_walk_m_s_sqrt_s;
        let ng = cfg.gyro_noise_rad_s_sqrt_hz;
        let wb = cfg.gyro_bias_walk_rad_s_sqrt_s;
        let wc = cfg.compass_bias_walk_rad_sqrt_s;
        let qp = POSITION_NOISE_M2_S * dt;
        let (qm, qc) = (m * m * dt, w * w * dt);
        self.kf.propagate(
            &phi,
            &[
                qp,
                qp,
                qm,
                qm,
                qc,
                qc,
                ng * ng * dt,
                wb * wb * dt,
                wc * wc * dt,
            ],
        );

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
    fn corrected(&mut self, f: impl FnOnce(&mut Kf<NX>)) {
        let before = self.position();
        f(&mut self.kf);
        self.correction[0] += self.kf.x[N] - before[0];
        self.correction[1] += self.kf.x[E] - before[1];
    }

    /// Velocity through the water to the DVL's velocity less the current estimate.
    pub(super) fn reset_velocity(&mut self, velocity_m_s: [f32; 2], std_m_s: f32) {
        let (s, c) = sin_cos(self.kf.x[PSI]);
        let (cn, ce) = (self.kf.x[CN], self.kf.x[CE]);
        let var = std_m_s * std_m_s;
        self.kf
            .reset_state(U, velocity_m_s[0] - (c * cn + s * ce), var);
        self.kf
            .reset_state(V, velocity_m_s[1] - (-s * cn + c * ce), var);
    }

    /// After a refused fix: if the last refused fixes form a cluster, move the position to
    /// the cluster and return true. A cluster is [`CLUSTER_MIN`] or more refused fixes within
    /// [`CLUSTER_WINDOW_US`] of the newest whose offsets all agree with the newest's (99 %
    /// chi-square on their difference), and that are the majority of every fix that reached
    /// the gate since the oldest of them. One refused fix, however far, never moves the
    /// estimate: multipath outliers scatter in every direction and never agree with each
    /// other, while a transceiver that moved, or an estimate that is lost, gives fixes that
    /// all say the same thing. The position moves by the cluster's mean offset (not to the
    /// last fix), with the variance of one fix, its correlations cleared.
    fn cluster_reset(&mut self) -> bool {
        let Some(newest) = self.refused.recent().copied() else {
            return false;
        };
        let mut n = 0u32;
        let mut oldest_seq = newest.seq;
        let mut sum = [0.0f32; 2];
        let mut var_sum = 0.0f32;
        for f in self.refused.oldest_ordered() {
            let dn = f.offset[0] - newest.offset[0];
            let de = f.offset[1] - newest.offset[1];
            let recent = newest.t_us.saturating_sub(f.t_us) <= CLUSTER_WINDOW_US;
            if recent && dn * dn + de * de <= CLUSTER_CHI2 * (f.var + newest.var) {
                n += 1;
                oldest_seq = oldest_seq.min(f.seq);
                sum[0] += f.offset[0];
                sum[1] += f.offset[1];
                var_sum += f.var;
            }
        }
        let seen = newest.seq.saturating_sub(oldest_seq) + 1;
        if (n as usize) < CLUSTER_MIN || 2 * n <= seen {
            return false;
        }
        let inv_n = 1.0 / n as f32;
        // Mean offset against today's (corrected) estimate.
        let shift = [
            sum[0] * inv_n - self.correction[0],
            sum[1] * inv_n - self.correction[1],
        ];
        let var = var_sum * inv_n;
        let now = self.position();
        self.corrected(|kf| {
            kf.reset_state(N, now[0] + shift[0], var);
            kf.reset_state(E, now[1] + shift[1], var);
        });
        self.refused.clear();
        true
    }

    /// After a run of gated compass fixes: the compass's bias, not the gyro-carried heading,
    /// is taken to have moved (a hard iron seen at a new heading, a thruster's field). The
    /// bias's variance grows by the innovation's square, then the fix is fused: the
    /// innovation goes to `b_c` in proportion to that variance, the heading keeps what the
    /// gyro carried, and the USBL track against the dead reckoning later corrects either.
    pub(super) fn reset_heading(&mut self, yaw_rad: f32, std_rad: f32) {
        let nu = wrap_angle(yaw_rad - self.kf.x[PSI] - self.kf.x[BC]);
        if let Some(v) = self.kf.p.get_mut(BC).and_then(|row| row.get_mut(BC)) {
            *v += nu * nu;
        }
        let h = Self::compass_row();
        self.corrected(|kf| {
            kf.update(&h, nu, std_rad * std_rad);
        });
        self.kf.x[PSI] = wrap_angle(self.kf.x[PSI]);
        self.kf.x[BC] = wrap_angle(self.kf.x[BC]);
    }

    /// The compass's measurement row: `psi + b_c`.
    fn compass_row() -> [f32; NX] {
        let mut h = unit(PSI);
        h[BC] = 1.0;
        h
    }

    pub(super) fn fuse_heading(&mut self, yaw_rad: f32, std_rad: f32) -> Result<(), Refusal> {
        let nu = wrap_angle(yaw_rad - self.kf.x[PSI] - self.kf.x[BC]);
        let r = std_rad * std_rad;
        let h = Self::compass_row();
        if !within_gate(nu * nu / (self.kf.cross(&h, &h) + r), GATE_CHI2_1DOF) {
            return Err(Refusal::Outlier);
        }
        self.corrected(|kf| {
            kf.update(&h, nu, r);
        });
        self.kf.x[PSI] = wrap_angle(self.kf.x[PSI]);
        Ok(())
    }

    pub(super) fn fuse_dvl(&mut self, velocity_m_s: [f32; 2], std_m_s: f32) -> Result<(), Refusal> {
        let (hu, hv) = dvl_rows(&self.kf.x);
        let r = std_m_s * std_m_s;
        let predicted = over_ground(&self.kf.x);
        let nu = [
            velocity_m_s[0] - predicted[0],
            velocity_m_s[1] - predicted[1],
        ];
        let s00 = self.kf.cross(&hu, &hu) + r;
        let s01 = self.kf.cross(&hu, &hv);
        let s11 = self.kf.cross(&hv, &hv) + r;
        if !within_gate(nis2(nu, s00, s01, s11), GATE_CHI2_2DOF) {
            return Err(Refusal::Outlier);
        }
        self.corrected(|kf| {
            kf.update(&hu, nu[0], r);
            let nu_v = velocity_m_s[1] - over_ground(&kf.x)[1];
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
        if t_us > now.t_us {
            return None;
        }
        // From the newest back: a fix is at most a few hundred milliseconds late, so this
        // visits a few entries, not the whole 2.56 s.
        let (older, newer) = self.history.as_slices();
        let mut hi = now;
        for &lo in newer.iter().rev().chain(older.iter().rev()) {
            if lo.t_us < t_us {
                // lo.t_us < t_us <= hi.t_us: interpolate.
                let a = (t_us - lo.t_us) as f32 / (hi.t_us - lo.t_us) as f32;
                let at = |i: usize| {
                    let (l, h) = (
                        lo.pos.get(i).copied().unwrap_or(0.0),
                        hi.pos.get(i).copied().unwrap_or(0.0),
                    );
                    l + a * (h - l)
                };
                return Some([at(0) + self.correction[0], at(1) + self.correction[1]]);
            }
            hi = lo;
        }
        // Every entry is at or after `t_us`: only an exact match with the oldest is inside.
        (hi.t_us == t_us).then(|| {
            [
                hi.pos[0] + self.correction[0],
                hi.pos[1] + self.correction[1],
            ]
        })
    }

    /// Fuse a USBL fix; a refused one is kept for the cluster test, and `Ok(true)` says the
    /// refused fixes formed a cluster and the position moved to it.
    pub(super) fn fuse_position_or_cluster(
        &mut self,
        t_us: u64,
        now_us: u64,
        fix: [f32; 2],
        std_m: f32,
    ) -> Result<bool, Refusal> {
        match self.fuse_position(t_us, now_us, fix, std_m) {
            Ok(()) => Ok(false),
            Err(Refusal::Outlier) if self.cluster_reset() => Ok(true),
            Err(e) => Err(e),
        }
    }

    fn fuse_position(
        &mut self,
        t_us: u64,
        now_us: u64,
        fix: [f32; 2],
        std_m: f32,
    ) -> Result<(), Refusal> {
        let past = self.past_position(t_us, now_us).ok_or(Refusal::TooOld)?;
        self.fix_seq = self.fix_seq.wrapping_add(1);
        let nu = [fix[0] - past[0], fix[1] - past[1]];
        // The displacement since the time of validity is known up to the velocity's
        // uncertainty over the latency.
        let latency_s = now_us.saturating_sub(t_us) as f32 * 1.0e-6;
        let var_v = max(self.kf.var(U), self.kf.var(V)) + max(self.kf.var(CN), self.kf.var(CE));
        let r = std_m * std_m + var_v * latency_s * latency_s;
        let s00 = self.kf.var(N) + r;
        let s01 = self.kf.cov(N, E);
        let s11 = self.kf.var(E) + r;
        let nis = nis2(nu, s00, s01, s11);
        if !within_gate(nis, USBL_GATE_CHI2) {
            self.refused.write(RefusedFix {
                t_us,
                seq: self.fix_seq,
                offset: [nu[0] + self.correction[0], nu[1] + self.correction[1]],
                var: r,
            });
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

/// The DVL's measurement `[u, v]_ground = [u_r, v_r] + R(psi)^T [c_N, c_E]`.
fn over_ground(x: &[f32; NX]) -> [f32; 2] {
    let (s, c) = sin_cos(x[PSI]);
    [x[U] + c * x[CN] + s * x[CE], x[V] - s * x[CN] + c * x[CE]]
}

/// Rows of the DVL measurement's Jacobian.
fn dvl_rows(x: &[f32; NX]) -> ([f32; NX], [f32; NX]) {
    let (s, c) = sin_cos(x[PSI]);
    let (cn, ce) = (x[CN], x[CE]);
    (
        [0.0, 0.0, 1.0, 0.0, c, s, -s * cn + c * ce, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, -s, c, -c * cn - s * ce, 0.0, 0.0],
    )
}
