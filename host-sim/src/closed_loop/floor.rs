//! The navigation floor of one run ([`NavFloor`] in `summary.json`): the measurements the
//! on-board estimator was given, recorded as it got them ([`FloorRecorder`]), run after the
//! run through the estimator's own model in `f64`, forward with every fix at its time of
//! validity, then backward ([`super::smoother::rts`]). Its position RMS against the truth is
//! the best this model can do with these measurements; the estimator's RMS over the same
//! window divided by it says how far the estimator is from that.
//!
//! The model is the horizontal filter's (`controller_core::nav`, `horizontal.rs`) and the
//! vertical one's, stacked: `[N, E, u_r, v_r, c_N, c_E, psi, b_r, b_c, z, z_dot, b_a]`,
//! driven by the yaw gyro, the lagged surge thrust and the vertical specific force. Roll,
//! pitch and the bias-corrected pitch rate are the on-board tilt filter's at each IMU sample
//! (the tilt enters the heading's kinematics and the vertical acceleration only to second
//! order about level trim). Process noise: the gyro's white noise and bias walk are the
//! IMU's stated figures (the sensor's datasheet, `[sensors.imu]`); what the model misses
//! (surge/sway acceleration, current walk, compass-bias walk, vertical acceleration) is the
//! estimator's own setting, since no sensor states it. The start is the estimator's: the
//! told launch point with its uncertainties. Every fix passes a 99.9 % chi-square gate.

use super::smoother::{rts, Epoch};
use controller_core::nav::{DepthFix, DvlFix, HeadingFix, NavConfig, PositionFix};
use controller_core::params::Vehicle;
use controller_core::state::NavState;
use nalgebra::{SMatrix, SVector};
use serde::Serialize;

/// States of the floor's model.
const NS: usize = 12;
type Mat = SMatrix<f64, NS, NS>;
type Vect = SVector<f64, NS>;

const N: usize = 0;
const E: usize = 1;
const U: usize = 2;
const V: usize = 3;
const CN: usize = 4;
const CE: usize = 5;
const PSI: usize = 6;
const BR: usize = 7;
const BC: usize = 8;
const Z: usize = 9;
const ZD: usize = 10;
const BA: usize = 11;

const GRAVITY_M_S2: f64 = 9.806_65;
/// Chi-square gates at 99.9 % (1 and 2 degrees of freedom).
const GATE_1: f64 = 10.83;
const GATE_2: f64 = 13.82;
/// Process noise on the position itself (m^2/s), as the estimator's.
const POSITION_NOISE_M2_S: f64 = 1.0e-6;
/// An epoch is kept at least every this many IMU samples, and at every fix.
const EPOCH_EVERY: u32 = 10;
/// The window of the figures starts here (s), as `rms_estimation_error_m`'s.
const SCORE_FROM_S: f64 = 10.0;
/// The second window starts at this share of the run, as the tracking figure's (last 80 %).
const LAST80_FROM: f64 = 0.2;
/// Longest IMU interval integrated (s), as the estimator's.
const MAX_DT_S: f64 = 0.25;

/// The floor of a run, for `summary.json` (`navigation.floor`).
#[derive(Debug, Clone, Default, Serialize)]
pub struct NavFloor {
    /// RMS position error of the smoother against the truth, on the plane's axes, after the
    /// first 10 s (m).
    pub floor_rms_m: f64,
    /// The on-board estimator's RMS over the same window, at the control ticks (m): the
    /// same figure as `rms_estimation_error_m`.
    pub filter_rms_m: f64,
    /// `filter_rms_m / floor_rms_m`.
    pub ratio: f64,
    /// RMS of the smoother's forward pass alone over the same epochs (m): the same model in
    /// `f64` with every fix at its time of validity, but no hindsight. The best a causal
    /// filter on this model could do (with the fixes' latency bridged exactly).
    pub forward_rms_m: f64,
    /// `filter_rms_m / forward_rms_m`.
    pub ratio_to_forward: f64,
    /// The smoother's RMS over the last 80 % of the run (m): the window of the tracking
    /// figure, after the launch transient (the first fixes averaging the start's 0.5 m down,
    /// the heading learning its compass bias from the track), which hindsight removes and a
    /// filter cannot.
    pub floor_rms_last80_m: f64,
    /// The on-board estimator's RMS over the last 80 % (m).
    pub filter_rms_last80_m: f64,
    /// `filter_rms_last80_m / floor_rms_last80_m`.
    pub ratio_last80: f64,
    /// The forward pass's RMS over the last 80 % (m).
    pub forward_rms_last80_m: f64,
    /// Epochs of the smoother scored.
    pub epochs_scored: u64,
    /// USBL fixes the smoother's gate refused.
    pub usbl_refused: u64,
}

/// What the floor's model is driven and corrected by.
#[derive(Debug, Clone, Copy)]
enum Event {
    Imu {
        t_us: u64,
        r_gyro_rad_s: f64,
        accel_m_s2: [f64; 3],
        roll_rad: f64,
        pitch_rad: f64,
        q_rad_s: f64,
        thrust_cmd_n: [f64; 3],
    },
    Depth(DepthFix),
    Heading(HeadingFix),
    Dvl(DvlFix),
    Position(PositionFix),
}

impl Event {
    /// Time of validity, and the order at equal times (the IMU sample first).
    fn key(&self) -> (u64, u8) {
        match self {
            Event::Imu { t_us, .. } => (*t_us, 0),
            Event::Depth(f) => (f.t_us, 1),
            Event::Heading(f) => (f.t_us, 1),
            Event::Dvl(f) => (f.t_us, 1),
            Event::Position(f) => (f.t_us, 1),
        }
    }
}

/// Process noise of the floor's model (see the module docs for where each comes from).
#[derive(Debug, Clone, Copy)]
pub struct FloorNoise {
    /// Yaw gyro white noise (rad/s/sqrt(Hz)): the IMU's.
    pub gyro_noise_rad_s_sqrt_hz: f64,
    /// Yaw gyro bias walk (rad/s/sqrt(s)): the IMU's.
    pub gyro_bias_walk_rad_s_sqrt_s: f64,
    /// The estimator's settings for the rest.
    pub nav: NavConfig,
}

/// Records a run's navigation inputs and truth; [`FloorRecorder::floor`] smooths them.
#[derive(Debug, Clone)]
pub struct FloorRecorder {
    vehicle: Vehicle,
    noise: FloorNoise,
    initial: NavState,
    axes: [bool; 3],
    events: Vec<Event>,
    /// The true position at each IMU sample's time.
    truth: Vec<(u64, [f64; 3])>,
    /// The estimator's squared position error at each control tick `(t_s, e^2)`.
    filter_sq: Vec<(f64, f64)>,
}

impl FloorRecorder {
    /// A recorder for an estimator started at `initial` with `noise`, scored on `axes`.
    pub fn new(vehicle: Vehicle, noise: FloorNoise, initial: NavState, axes: [bool; 3]) -> Self {
        Self {
            vehicle,
            noise,
            initial,
            axes,
            events: Vec::new(),
            truth: Vec::new(),
            filter_sq: Vec::new(),
        }
    }

    /// An IMU sample the estimator integrated, with the tilt `(roll, pitch, q)` it had after
    /// it and the thrust command held over it.
    pub fn imu(
        &mut self,
        imu: &controller_core::nav::ImuSample,
        tilt: (f32, f32, f32),
        thrust_cmd_n: [f32; 3],
    ) {
        self.events.push(Event::Imu {
            t_us: imu.t_us,
            r_gyro_rad_s: f64::from(imu.gyro_rad_s[2]),
            accel_m_s2: imu.accel_m_s2.map(f64::from),
            roll_rad: f64::from(tilt.0),
            pitch_rad: f64::from(tilt.1),
            q_rad_s: f64::from(tilt.2),
            thrust_cmd_n: thrust_cmd_n.map(f64::from),
        });
    }

    /// A depth as the estimator got it.
    pub fn depth(&mut self, f: &DepthFix) {
        self.events.push(Event::Depth(*f));
    }

    /// A heading as the estimator got it (calibration applied).
    pub fn heading(&mut self, f: &HeadingFix) {
        self.events.push(Event::Heading(*f));
    }

    /// A DVL velocity.
    pub fn dvl(&mut self, f: &DvlFix) {
        self.events.push(Event::Dvl(*f));
    }

    /// A USBL fix.
    pub fn position(&mut self, f: &PositionFix) {
        self.events.push(Event::Position(*f));
    }

    /// The true position `[x, y, z]` at `t_us` (an IMU sample's time).
    pub fn truth(&mut self, t_us: u64, pos_m: [f64; 3]) {
        self.truth.push((t_us, pos_m));
    }

    /// The estimator's position error at a control tick at `t_s`.
    pub fn filter_error(&mut self, t_s: f64, err_m: [f64; 3]) {
        let sq = self.on_axes(err_m);
        self.filter_sq.push((t_s, sq));
    }

    fn on_axes(&self, e: [f64; 3]) -> f64 {
        e.iter()
            .zip(self.axes)
            .filter(|(_, on)| *on)
            .map(|(v, _)| v * v)
            .sum()
    }

    /// Smooth the run and score it; `None` without IMU samples or when the forward pass
    /// broke (a covariance not positive definite).
    pub fn floor(&self) -> Option<NavFloor> {
        let (epochs, usbl_refused) = self.forward()?;
        let smoothed = rts(&epochs, |a, b| {
            let mut d = a - b;
            d[PSI] = wrap(d[PSI]);
            d
        })?;
        let mut truth = self.truth.clone();
        truth.sort_by_key(|(t, _)| *t);
        let end_s = self.filter_sq.last().map_or(0.0, |(t, _)| *t);
        let last80_from_s = LAST80_FROM * end_s;
        let (mut all, mut last80) = (Rms::default(), Rms::default());
        for (ep, (x, _)) in epochs.iter().zip(&smoothed) {
            let t_s = ep.t_us as f64 * 1e-6;
            if t_s < SCORE_FROM_S {
                continue;
            }
            let Ok(i) = truth.binary_search_by_key(&ep.t_us, |(t, _)| *t) else {
                continue;
            };
            let tp = truth[i].1;
            let sq = self.on_axes([x[N] - tp[0], x[E] - tp[1], x[Z] - tp[2]]);
            let xf = &ep.x_f;
            let sq_f = self.on_axes([xf[N] - tp[0], xf[E] - tp[1], xf[Z] - tp[2]]);
            all.add(sq, sq_f);
            if t_s >= last80_from_s {
                last80.add(sq, sq_f);
            }
        }
        let (mut filter, mut filter_last80) = (Rms::default(), Rms::default());
        for &(t_s, sq) in &self.filter_sq {
            if t_s >= SCORE_FROM_S {
                filter.add(sq, 0.0);
            }
            if t_s >= last80_from_s {
                filter_last80.add(sq, 0.0);
            }
        }
        if all.n == 0 || filter.n == 0 || last80.n == 0 || filter_last80.n == 0 {
            return None;
        }
        let floor_rms_m = all.rms();
        let forward_rms_m = all.rms_b();
        let filter_rms_m = filter.rms();
        let floor_rms_last80_m = last80.rms();
        let filter_rms_last80_m = filter_last80.rms();
        Some(NavFloor {
            floor_rms_m,
            filter_rms_m,
            ratio: filter_rms_m / floor_rms_m,
            forward_rms_m,
            ratio_to_forward: filter_rms_m / forward_rms_m,
            floor_rms_last80_m,
            filter_rms_last80_m,
            ratio_last80: filter_rms_last80_m / floor_rms_last80_m,
            forward_rms_last80_m: last80.rms_b(),
            epochs_scored: all.n,
            usbl_refused,
        })
    }

    fn initial_state(&self) -> (Vect, Mat) {
        let c = &self.noise.nav;
        let s = &self.initial;
        let mut x = Vect::zeros();
        x[N] = f64::from(s.x_m);
        x[E] = f64::from(s.y_m);
        x[U] = f64::from(s.u_m_s);
        x[V] = f64::from(s.v_m_s);
        x[PSI] = f64::from(s.yaw_rad);
        x[Z] = f64::from(s.z_m);
        let sq = |v: f32| f64::from(v) * f64::from(v);
        let mut var = Vect::zeros();
        var[N] = sq(c.initial_position_std_m);
        var[E] = var[N];
        var[U] = 0.01;
        var[V] = 0.01;
        var[CN] = sq(c.initial_current_std_m_s);
        var[CE] = var[CN];
        var[PSI] = sq(c.initial_heading_std_rad);
        var[BR] = sq(c.initial_gyro_bias_std_rad_s);
        var[BC] = sq(c.initial_compass_bias_std_rad);
        var[Z] = sq(c.initial_depth_std_m);
        var[ZD] = 0.01;
        var[BA] = sq(c.initial_accel_bias_std_m_s2);
        (x, Mat::from_diagonal(&var))
    }

    /// The forward filter over every event in time-of-validity order, keeping an epoch at
    /// every fix and at least every [`EPOCH_EVERY`] IMU samples.
    fn forward(&self) -> Option<(Vec<Epoch<NS>>, u64)> {
        let mut events = self.events.clone();
        events.sort_by_key(Event::key);
        let (mut x, mut p) = self.initial_state();
        let tau = f64::from(self.vehicle.params().thruster_time_constant_s);
        let mut thrust = [0.0f64; 3];
        let mut t_us = 0u64;
        let mut epochs = vec![];
        let mut phi_acc = Mat::identity();
        let (mut x_p, mut p_p) = (x, p);
        let (mut steps, mut fused_here, mut refused) = (0u32, false, 0u64);
        for ev in &events {
            match *ev {
                Event::Imu {
                    t_us: t,
                    r_gyro_rad_s,
                    accel_m_s2,
                    roll_rad,
                    pitch_rad,
                    q_rad_s,
                    thrust_cmd_n,
                } => {
                    if t <= t_us && !epochs.is_empty() {
                        continue;
                    }
                    if epochs.is_empty() || fused_here || steps >= EPOCH_EVERY {
                        epochs.push(Epoch {
                            t_us,
                            phi: phi_acc,
                            x_p,
                            p_p,
                            x_f: x,
                            p_f: p,
                        });
                        phi_acc = Mat::identity();
                        steps = 0;
                    }
                    let dt = t.saturating_sub(t_us) as f64 * 1e-6;
                    t_us = t;
                    if dt > 0.0 && dt <= MAX_DT_S {
                        let a = dt / (tau + dt);
                        for (f, c) in thrust.iter_mut().zip(thrust_cmd_n) {
                            *f += a * (c - *f);
                        }
                        let phi = self.predict(
                            &mut x,
                            &mut p,
                            dt,
                            r_gyro_rad_s,
                            accel_m_s2,
                            (roll_rad, pitch_rad, q_rad_s),
                            thrust[0] + thrust[1],
                        );
                        phi_acc = phi * phi_acc;
                    }
                    steps += 1;
                    x_p = x;
                    p_p = p;
                    fused_here = false;
                }
                Event::Depth(f) => {
                    let mut h = SMatrix::<f64, 1, NS>::zeros();
                    h[Z] = 1.0;
                    let nu = f64::from(f.depth_m) - x[Z];
                    let r = sq(f.std_m);
                    update(
                        &mut x,
                        &mut p,
                        &h,
                        &nu1(nu),
                        &SMatrix::from_element(r),
                        GATE_1,
                    );
                    fused_here = true;
                }
                Event::Heading(f) => {
                    let mut h = SMatrix::<f64, 1, NS>::zeros();
                    h[PSI] = 1.0;
                    h[BC] = 1.0;
                    let nu = wrap(f64::from(f.yaw_rad) - x[PSI] - x[BC]);
                    let r = sq(f.std_rad);
                    update(
                        &mut x,
                        &mut p,
                        &h,
                        &nu1(nu),
                        &SMatrix::from_element(r),
                        GATE_1,
                    );
                    x[PSI] = wrap(x[PSI]);
                    fused_here = true;
                }
                Event::Dvl(f) => {
                    let (s, c) = x[PSI].sin_cos();
                    let (cn, ce) = (x[CN], x[CE]);
                    let mut h = SMatrix::<f64, 2, NS>::zeros();
                    h[(0, U)] = 1.0;
                    h[(0, CN)] = c;
                    h[(0, CE)] = s;
                    h[(0, PSI)] = -s * cn + c * ce;
                    h[(1, V)] = 1.0;
                    h[(1, CN)] = -s;
                    h[(1, CE)] = c;
                    h[(1, PSI)] = -c * cn - s * ce;
                    let pred = [x[U] + c * cn + s * ce, x[V] - s * cn + c * ce];
                    let nu = SVector::<f64, 2>::new(
                        f64::from(f.velocity_m_s[0]) - pred[0],
                        f64::from(f.velocity_m_s[1]) - pred[1],
                    );
                    let r = SMatrix::<f64, 2, 2>::identity() * sq(f.std_m_s);
                    update(&mut x, &mut p, &h, &nu, &r, GATE_2);
                    fused_here = true;
                }
                Event::Position(f) => {
                    let mut h = SMatrix::<f64, 2, NS>::zeros();
                    h[(0, N)] = 1.0;
                    h[(1, E)] = 1.0;
                    let nu = SVector::<f64, 2>::new(
                        f64::from(f.north_m) - x[N],
                        f64::from(f.east_m) - x[E],
                    );
                    let r = SMatrix::<f64, 2, 2>::identity() * sq(f.std_m);
                    if !update(&mut x, &mut p, &h, &nu, &r, GATE_2) {
                        refused += 1;
                    }
                    fused_here = true;
                }
            }
        }
        epochs.push(Epoch {
            t_us,
            phi: phi_acc,
            x_p,
            p_p,
            x_f: x,
            p_f: p,
        });
        (epochs.len() > 1).then_some((epochs, refused))
    }

    /// One step of the model: the state through the nonlinear model, the covariance through
    /// its Jacobian; returns the Jacobian.
    #[allow(clippy::too_many_arguments)]
    fn predict(
        &self,
        x: &mut Vect,
        p: &mut Mat,
        dt: f64,
        r_gyro: f64,
        accel: [f64; 3],
        tilt: (f64, f64, f64),
        surge_n: f64,
    ) -> Mat {
        let c = &self.vehicle.xy;
        let k = |v: f32| f64::from(v);
        let (a1, a2, a3) = (k(c.alpha1), k(c.alpha2), k(c.alpha3));
        let (b1, b2, b3) = (k(c.beta1), k(c.beta2), k(c.beta3));
        let m11 = k(c.m11).max(1e-6);
        let (roll, pitch, q) = tilt;
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let inv_cp = 1.0 / cp;
        let psi = x[PSI];
        let r = r_gyro - x[BR];
        let (u, v) = (x[U], x[V]);
        let (s, co) = psi.sin_cos();
        let u_dot = a1 * u - a2 * u.abs() * u - a3 * v * r + surge_n / m11;
        let v_dot = -b1 * v - b2 * v.abs() * v - b3 * u * r;
        let [fx, fy, fz] = accel;
        let a_z = -sp * fx + cp * sr * fy + cp * cr * fz + GRAVITY_M_S2 - x[BA];

        let mut phi = Mat::identity();
        phi[(N, U)] = co * dt;
        phi[(N, V)] = -s * dt;
        phi[(N, CN)] = dt;
        phi[(N, PSI)] = (-s * u - co * v) * dt;
        phi[(E, U)] = s * dt;
        phi[(E, V)] = co * dt;
        phi[(E, CE)] = dt;
        phi[(E, PSI)] = (co * u - s * v) * dt;
        phi[(U, U)] = 1.0 + (a1 - 2.0 * a2 * u.abs()) * dt;
        phi[(U, V)] = -a3 * r * dt;
        phi[(U, BR)] = a3 * v * dt;
        phi[(V, U)] = -b3 * r * dt;
        phi[(V, V)] = 1.0 - (b1 + 2.0 * b2 * v.abs()) * dt;
        phi[(V, BR)] = b3 * u * dt;
        phi[(PSI, BR)] = -cr * inv_cp * dt;
        phi[(Z, ZD)] = dt;
        phi[(Z, BA)] = -0.5 * dt * dt;
        phi[(ZD, BA)] = -dt;

        x[N] += (co * u - s * v + x[CN]) * dt;
        x[E] += (s * u + co * v + x[CE]) * dt;
        x[U] += u_dot * dt;
        x[V] += v_dot * dt;
        x[PSI] = wrap(psi + (sr * q + cr * r) * inv_cp * dt);
        x[Z] += x[ZD] * dt + 0.5 * a_z * dt * dt;
        x[ZD] += a_z * dt;

        let nav = &self.noise.nav;
        let f = |v: f32| f64::from(v) * f64::from(v);
        let m = f(nav.model_accel_noise_m_s2_sqrt_hz);
        let w = f(nav.current_walk_m_s_sqrt_s);
        let ng = self.noise.gyro_noise_rad_s_sqrt_hz.powi(2);
        let wb = self.noise.gyro_bias_walk_rad_s_sqrt_s.powi(2);
        let wc = f(nav.compass_bias_walk_rad_sqrt_s);
        let na = f(nav.accel_noise_m_s2_sqrt_hz);
        let wa = f(nav.accel_bias_walk_m_s2_sqrt_s);
        let mut q_d = Vect::zeros();
        q_d[N] = POSITION_NOISE_M2_S * dt;
        q_d[E] = q_d[N];
        q_d[U] = m * dt;
        q_d[V] = m * dt;
        q_d[CN] = w * dt;
        q_d[CE] = w * dt;
        q_d[PSI] = ng * dt;
        q_d[BR] = wb * dt;
        q_d[BC] = wc * dt;
        q_d[Z] = 0.25 * na * dt * dt * dt;
        q_d[ZD] = na * dt;
        q_d[BA] = wa * dt;
        let pp = phi * *p * phi.transpose() + Mat::from_diagonal(&q_d);
        *p = 0.5 * (pp + pp.transpose());
        phi
    }
}

/// Two sums of squares over the same samples, for their RMS.
#[derive(Debug, Default, Clone, Copy)]
struct Rms {
    a: f64,
    b: f64,
    n: u64,
}

impl Rms {
    fn add(&mut self, a: f64, b: f64) {
        self.a += a;
        self.b += b;
        self.n += 1;
    }

    fn rms(&self) -> f64 {
        (self.a / self.n as f64).sqrt()
    }

    fn rms_b(&self) -> f64 {
        (self.b / self.n as f64).sqrt()
    }
}

fn sq(v: f32) -> f64 {
    f64::from(v) * f64::from(v)
}

fn nu1(v: f64) -> SVector<f64, 1> {
    SVector::<f64, 1>::new(v)
}

/// An angle in (-pi, pi].
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(std::f64::consts::TAU);
    if w > std::f64::consts::PI {
        w - std::f64::consts::TAU
    } else {
        w
    }
}

/// The Kalman update with a chi-square gate; false (nothing changed) when the fix fails the
/// gate or its innovation covariance is not positive definite. Joseph form.
fn update<const M: usize>(
    x: &mut Vect,
    p: &mut Mat,
    h: &SMatrix<f64, M, NS>,
    nu: &SVector<f64, M>,
    r: &SMatrix<f64, M, M>,
    gate: f64,
) -> bool {
    let s = h * *p * h.transpose() + r;
    let Some(chol) = s.cholesky() else {
        return false;
    };
    let nis = nu.dot(&chol.solve(nu));
    if nis.is_nan() || nis > gate {
        return false;
    }
    // K = P H^T S^-1, from S K^T = H P.
    let k = chol.solve(&(h * *p)).transpose();
    *x += k * nu;
    let i_kh = Mat::identity() - k * h;
    let pp = i_kh * *p * i_kh.transpose() + k * r * k.transpose();
    *p = 0.5 * (pp + pp.transpose());
    true
}
