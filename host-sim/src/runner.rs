//! The closed-loop runner: the `f64` plant at `plant_dt_s`, the `f32` core controller at
//! `control_period_s` with a zero-order hold, and the measurement path between them.
//!
//! Each control tick:
//! 1. the measurement is the plant state `delay_s` ago (a ring buffer filled every plant step),
//!    converted to the core's `f32` [`NavState`], plus Gaussian noise when enabled;
//! 2. the core reference is sampled at the tick time;
//! 3. [`Controller::step`] gives the thruster commands `[F1x, F2x, F3z]`, held for the
//!    `control_period_s / plant_dt_s` plant steps that follow;
//! 4. the tracking metrics are computed from the *true* plant state: position error is always
//!    the body origin against the reference for the body origin, on the plane's axes.
//!
//! The run stops early when the state or the requested forces stop being finite
//! (`nan_detected`) or when it diverges (position error > 1 km, |position| > 10 km,
//! |velocity| > 100 m/s or |rate| > 100 rad/s, or a thrust command above 10 kN).
//!
//! With `[thrusters] saturate = false` (the paper's setting) the controller is built with
//! unlimited thrusters (1 MN), so its allocation passes the request through, and the plant
//! applies no limits; the PWM column still uses the real map (clamped) for reference.

use crate::plant::six_dof_factory;
use crate::plant::xy::XyPlant;
use crate::plant::xz::XzPlant;
use crate::plant::{Environment, Plant, PlantState};
use crate::scenario::{NoiseStd, Plane, Scenario};
use anyhow::{anyhow, Result};
use controller_core::alloc::PwmMap;
use controller_core::controller::{Controller, Gains};
use controller_core::params::{Vehicle, VehicleParams};
use controller_core::reference::RefSample;
use controller_core::state::{NavState, TrackingErrors};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::collections::VecDeque;
use std::time::Instant;

/// What a run may change from the scenario (Monte Carlo uses these).
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// Keep the per-tick log (for CSV and plots).
    pub record: bool,
    /// Plant parameters instead of the nominal Observer (the controller keeps the nominal).
    pub plant_params: Option<VehicleParams>,
    /// Current instead of the scenario's.
    pub current_m_s: Option<[f64; 3]>,
    /// Noise seed instead of the scenario's.
    pub noise_seed: Option<u64>,
}

/// One logged control tick.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Sample {
    /// Time (s).
    pub t_s: f64,
    /// True plant state.
    #[serde(skip)]
    pub state: PlantState,
    /// Reference position.
    pub ref_pos_m: [f64; 3],
    /// Reference velocity (inertial).
    pub ref_vel_m_s: [f64; 3],
    /// Position error on the plane's axes (zero on the others).
    pub pos_err_m: [f64; 3],
    /// Norm of `pos_err_m`.
    pub pos_err_norm_m: f64,
    /// Inertial velocity error of the body origin on the plane's axes.
    pub vel_err_m_s: [f64; 3],
    /// Angle error reported by the law (pitch in XZ, yaw otherwise).
    pub angle_err_rad: f64,
    /// Everything the law reported.
    #[serde(skip)]
    pub law_errors: TrackingErrors,
    /// Requested generalized forces `[tau_1, tau_2, tau_3]`.
    pub requested: [f64; 3],
    /// Achieved generalized forces after allocation.
    pub achieved: [f64; 3],
    /// Thruster commands `[F1x, F2x, F3z]`.
    pub thrust_cmd_n: [f64; 3],
    /// Thrust delivered by the plant's thrusters (after lag).
    pub thrust_n: [f64; 3],
    /// PWM pulses (real map, clamped).
    pub pulse_us: [f64; 3],
    /// The allocation clamped the request (or, unlimited, a thrust exceeded the real limits).
    pub saturated: bool,
}

/// The per-run summary, written as `summary.json`.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// `xz`, `xy` or `3d`.
    pub plane: String,
    /// `paper` or `tracking`.
    pub controller: String,
    /// Reference kind.
    pub reference: String,
    /// Thruster limits applied.
    pub saturate: bool,
    /// Requested simulated time (s).
    pub duration_s: f64,
    /// Simulated time reached (s).
    pub simulated_s: f64,
    /// Position error at the end (m).
    pub final_position_error_m: f64,
    /// Largest position error (m).
    pub max_position_error_m: f64,
    /// Largest position error after the first 10 s (m).
    pub max_position_error_after_10s_m: f64,
    /// RMS position error over the whole run (m).
    pub rms_position_error_m: f64,
    /// RMS position error over the last 20 % of the run (m).
    pub rms_position_error_tail_m: f64,
    /// RMS position error over the last 80 % of the run (m).
    pub rms_position_error_last80_m: f64,
    /// Final position error per axis `[x, y, z]` (m).
    pub final_position_error_xyz_m: [f64; 3],
    /// Angle error at the end, as the law reports it (rad).
    pub final_angle_error_rad: f64,
    /// Largest |angle error| after the first 10 s (rad).
    pub max_angle_error_after_10s_rad: f64,
    /// Largest |thruster command| (N).
    pub max_abs_thruster_force_n: f64,
    /// Largest |requested generalized force| `[tau_1 (N), tau_2 (N m), tau_3 (N)]`.
    pub max_abs_requested_force: [f64; 3],
    /// Share of control ticks with saturated thrusters.
    pub saturated_fraction: f64,
    /// The run diverged.
    pub diverged: bool,
    /// A NaN or infinity appeared.
    pub nan_detected: bool,
    /// Why the run stopped.
    pub stop_reason: String,
    /// One-line verdict: "tracks" (final and last-20 % RMS error under 1 cm), "tracks
    /// roughly" (under 10 cm), or "does not track" with the reason.
    pub verdict: String,
    /// Plant RK4 steps done.
    pub sim_steps: u64,
    /// Control steps done.
    pub control_steps: u64,
    /// Wall-clock time of the simulation (s).
    pub wall_time_s: f64,
    /// Final plant state `[x, y, z, roll, pitch, yaw, u, v, w, p, q, r]`.
    pub final_state: Vec<f64>,
}

/// The result of one run.
#[derive(Debug, Clone, Default)]
pub struct RunOutput {
    /// Summary figures.
    pub summary: Summary,
    /// Per-tick log (empty unless `record`).
    pub log: Vec<Sample>,
}

/// Build the plant for a scenario.
pub fn make_plant(
    plane: Plane,
    params: &VehicleParams,
    env: Environment,
    saturate: bool,
    initial: PlantState,
) -> Result<Box<dyn Plant>> {
    Ok(match plane {
        Plane::Xz => Box::new(XzPlant::new(params, env, saturate, initial)),
        Plane::Xy => Box::new(XyPlant::new(params, env, saturate, initial)),
        Plane::ThreeD => six_dof_factory(params, env, saturate, initial)?,
    })
}

/// Rotation body -> inertial (ZYX Euler), applied to a body vector.
pub fn body_to_inertial(eta: &[f64; 6], v: [f64; 3]) -> [f64; 3] {
    let (sf, cf) = eta[3].sin_cos();
    let (st, ct) = eta[4].sin_cos();
    let (sp, cp) = eta[5].sin_cos();
    [
        cp * ct * v[0] + (cp * st * sf - sp * cf) * v[1] + (cp * st * cf + sp * sf) * v[2],
        sp * ct * v[0] + (sp * st * sf + cp * cf) * v[1] + (sp * st * cf - cp * sf) * v[2],
        -st * v[0] + ct * sf * v[1] + ct * cf * v[2],
    ]
}

/// The measurement path: a ring buffer of plant states (one per plant step) for the delay,
/// conversion to the core's `f32` [`NavState`], and Gaussian noise.
#[derive(Debug, Clone)]
pub struct Sensor {
    history: VecDeque<PlantState>,
    noise: Option<NoiseStd>,
    rng: ChaCha8Rng,
}

impl Sensor {
    /// A sensor that reports the state `delay_steps` plant steps old (the initial state until
    /// enough steps have passed), with noise of `noise` standard deviations if given.
    pub fn new(
        initial: PlantState,
        delay_steps: usize,
        noise: Option<NoiseStd>,
        seed: u64,
    ) -> Self {
        let mut history = VecDeque::with_capacity(delay_steps + 1);
        for _ in 0..=delay_steps {
            history.push_back(initial);
        }
        Self {
            history,
            noise,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// Record the plant state after one plant step.
    pub fn push(&mut self, s: PlantState) {
        self.history.pop_front();
        self.history.push_back(s);
    }

    /// The measurement now.
    pub fn measure(&mut self) -> NavState {
        let st = self.history.front().copied().unwrap_or_default();
        let mut nav = to_nav(&st);
        if let Some(ns) = self.noise {
            let rng = &mut self.rng;
            let mut g = |sd: f64| (sd * gauss(rng)) as f32;
            nav.x_m += g(ns.position_m);
            nav.y_m += g(ns.position_m);
            nav.z_m += g(ns.position_m);
            nav.roll_rad += g(ns.angle_rad);
            nav.pitch_rad += g(ns.angle_rad);
            nav.yaw_rad += g(ns.angle_rad);
            nav.u_m_s += g(ns.velocity_m_s);
            nav.v_m_s += g(ns.velocity_m_s);
            nav.w_m_s += g(ns.velocity_m_s);
            nav.p_rad_s += g(ns.rate_rad_s);
            nav.q_rad_s += g(ns.rate_rad_s);
            nav.r_rad_s += g(ns.rate_rad_s);
        }
        nav
    }
}

/// The plant state as the core's `f32` navigation state.
pub fn to_nav(s: &PlantState) -> NavState {
    NavState {
        x_m: s.eta[0] as f32,
        y_m: s.eta[1] as f32,
        z_m: s.eta[2] as f32,
        roll_rad: s.eta[3] as f32,
        pitch_rad: s.eta[4] as f32,
        yaw_rad: s.eta[5] as f32,
        u_m_s: s.nu[0] as f32,
        v_m_s: s.nu[1] as f32,
        w_m_s: s.nu[2] as f32,
        p_rad_s: s.nu[3] as f32,
        q_rad_s: s.nu[4] as f32,
        r_rad_s: s.nu[5] as f32,
    }
}

/// Standard normal draw (Box-Muller; one of the pair is dropped, simplicity over speed).
fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.random::<f64>().max(1e-300);
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

fn v3(a: [f32; 3]) -> [f64; 3] {
    [f64::from(a[0]), f64::from(a[1]), f64::from(a[2])]
}

/// The nominal plant parameters of a scenario: the Observer with the scenario's buoyancy offset.
pub fn nominal_plant_params(sc: &Scenario) -> VehicleParams {
    let mut p = VehicleParams::OBSERVER;
    p.buoyancy_offset_n = sc.disturbance.buoyancy_offset_n as f32;
    p
}

/// The one-line verdict of a summary.
pub fn verdict(s: &Summary) -> String {
    if s.nan_detected {
        return format!("does not track: {}", s.stop_reason);
    }
    if s.diverged {
        return format!("does not track: {}", s.stop_reason);
    }
    let worst = s.final_position_error_m.max(s.rms_position_error_tail_m);
    if worst < 0.01 {
        format!(
            "tracks: final error {:.3} mm, last-20 % RMS {:.3} mm",
            1e3 * s.final_position_error_m,
            1e3 * s.rms_position_error_tail_m
        )
    } else if worst < 0.1 {
        format!(
            "tracks roughly: final error {:.1} cm, last-20 % RMS {:.1} cm",
            1e2 * s.final_position_error_m,
            1e2 * s.rms_position_error_tail_m
        )
    } else {
        format!(
            "does not track: final error {:.2} m, last-20 % RMS {:.2} m",
            s.final_position_error_m, s.rms_position_error_tail_m
        )
    }
}

/// Run one scenario.
pub fn run(sc: &Scenario, opts: &RunOptions) -> Result<RunOutput> {
    sc.validate()?;
    let wall = Instant::now();
    let mode = sc.control_mode()?;
    let saturate = sc.thrusters.saturate;

    // Controller: nominal model, unlimited thrusters when the scenario says so.
    let mut ctrl_params = VehicleParams::OBSERVER;
    if !saturate {
        ctrl_params.thrust_max_forward_n = 1.0e6;
        ctrl_params.thrust_max_reverse_n = 1.0e6;
    }
    let ctrl_vehicle = ctrl_params
        .validate()
        .map_err(|e| anyhow!("controller parameters: {e}"))?;
    let mut controller = Controller::new(ctrl_vehicle, Gains::default())
        .map_err(|e| anyhow!("controller gains: {e}"))?;
    let nominal = Vehicle::observer();
    let pwm = PwmMap::for_vehicle(&nominal);
    let (lim_fwd, lim_rev) = (
        f64::from(nominal.params().thrust_max_forward_n),
        f64::from(nominal.params().thrust_max_reverse_n),
    );

    // Plant.
    let plant_params = opts
        .plant_params
        .unwrap_or_else(|| nominal_plant_params(sc));
    plant_params
        .validate()
        .map_err(|e| anyhow!("plant parameters: {e}"))?;
    let env = Environment {
        current_m_s: opts.current_m_s.unwrap_or(sc.disturbance.current_m_s),
    };
    let initial = sc.initial.to_plant();
    let mut plant = make_plant(sc.plane, &plant_params, env, saturate, initial)?;

    let reference = sc.reference.to_core();
    let axes = sc.plane.axes();
    let n_sub = sc.plant_steps_per_control().max(1);
    let dt = sc.plant_dt_s;
    let tc = dt * n_sub as f64;
    let n_ctrl = (sc.duration_s / tc).round() as u64;

    // Measurement path.
    let dist = &sc.disturbance;
    let mut sensor = Sensor::new(
        initial,
        (dist.delay_s / dt).round() as usize,
        dist.noise.then_some(dist.noise_std),
        opts.noise_seed.unwrap_or(dist.noise_seed),
    );

    let mut log = Vec::with_capacity(if opts.record { n_ctrl as usize + 1 } else { 0 });
    let mut sum_sq = 0.0;
    let mut n_all = 0u64;
    let mut sum_sq_tail = 0.0;
    let mut n_tail = 0u64;
    let mut sum_sq_80 = 0.0;
    let mut n_80 = 0u64;
    let mut s = Summary {
        scenario: sc.name.clone(),
        plane: sc.plane.as_str().into(),
        controller: sc.controller.as_str().into(),
        reference: sc.reference.kind().into(),
        saturate,
        duration_s: sc.duration_s,
        stop_reason: "completed".into(),
        ..Summary::default()
    };
    let mut n_sat = 0u64;
    let mut last = Sample::default();
    let t_tail = 0.8 * sc.duration_s;
    let t_80 = 0.2 * sc.duration_s;

    for k in 0..=n_ctrl {
        let t = k as f64 * tc;
        let truth = plant.state();
        // Measurement: delayed, noisy.
        let nav = sensor.measure();
        let r: RefSample = reference.sample(t as f32);
        let out = controller.step(mode, &nav, &r, tc as f32);

        // Metrics on the true state.
        let ref_pos = v3(r.pos_m);
        let ref_vel = v3(r.vel_m_s);
        let vel = body_to_inertial(&truth.eta, [truth.nu[0], truth.nu[1], truth.nu[2]]);
        let mut pe = [0.0; 3];
        let mut ve = [0.0; 3];
        for i in 0..3 {
            if axes[i] {
                pe[i] = truth.eta[i] - ref_pos[i];
                ve[i] = vel[i] - ref_vel[i];
            }
        }
        let pen = (pe[0] * pe[0] + pe[1] * pe[1] + pe[2] * pe[2]).sqrt();
        let angle_err = f64::from(match sc.plane {
            Plane::Xz => out.errors.pitch_rad,
            _ => out.errors.yaw_rad,
        });
        let requested = [
            f64::from(out.requested.surge_n),
            f64::from(out.requested.yaw_n_m),
            f64::from(out.requested.heave_n),
        ];
        let cmd = out.allocation.thrust_n.map(f64::from);
        let exceeds = cmd
            .iter()
            .any(|&f| f > lim_fwd + 1e-6 || f < -lim_rev - 1e-6);
        let saturated = out.allocation.saturated || exceeds;
        let sample = Sample {
            t_s: t,
            state: truth,
            ref_pos_m: ref_pos,
            ref_vel_m_s: ref_vel,
            pos_err_m: pe,
            pos_err_norm_m: pen,
            vel_err_m_s: ve,
            angle_err_rad: angle_err,
            law_errors: out.errors,
            requested,
            achieved: [
                f64::from(out.allocation.achieved.surge_n),
                f64::from(out.allocation.achieved.yaw_n_m),
                f64::from(out.allocation.achieved.heave_n),
            ],
            thrust_cmd_n: cmd,
            thrust_n: plant.thrust_n(),
            pulse_us: [
                f64::from(pwm.pulse_us(out.allocation.thrust_n[0])),
                f64::from(pwm.pulse_us(out.allocation.thrust_n[1])),
                f64::from(pwm.pulse_us(out.allocation.thrust_n[2])),
            ],
            saturated,
        };

        // Stop conditions.
        let nan = !truth.is_finite() || !out.requested.is_finite() || !pen.is_finite();
        if nan {
            s.nan_detected = true;
            s.stop_reason = format!("non-finite state or force at t = {t:.3} s");
            last = sample;
            if opts.record {
                log.push(sample);
            }
            break;
        }

        // Accumulate.
        sum_sq += pen * pen;
        n_all += 1;
        if t >= t_tail {
            sum_sq_tail += pen * pen;
            n_tail += 1;
        }
        if t >= t_80 {
            sum_sq_80 += pen * pen;
            n_80 += 1;
        }
        s.max_position_error_m = s.max_position_error_m.max(pen);
        if t >= 10.0 {
            s.max_position_error_after_10s_m = s.max_position_error_after_10s_m.max(pen);
            s.max_angle_error_after_10s_rad = s.max_angle_error_after_10s_rad.max(angle_err.abs());
        }
        for i in 0..3 {
            s.max_abs_requested_force[i] = s.max_abs_requested_force[i].max(requested[i].abs());
            s.max_abs_thruster_force_n = s.max_abs_thruster_force_n.max(cmd[i].abs());
        }
        if saturated {
            n_sat += 1;
        }
        s.control_steps += 1;
        s.simulated_s = t;
        last = sample;
        if opts.record {
            log.push(sample);
        }

        let pos_abs = truth.eta[..3].iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let vel_abs = truth.nu[..3].iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let rate_abs = truth.nu[3..].iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let thrust_abs = cmd.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        let why = if pen > 1.0e3 {
            Some("position error > 1 km")
        } else if pos_abs > 1.0e4 {
            Some("|position| > 10 km")
        } else if vel_abs > 100.0 {
            Some("|velocity| > 100 m/s")
        } else if rate_abs > 100.0 {
            Some("|angular rate| > 100 rad/s")
        } else if thrust_abs > 1.0e4 {
            Some("thrust command > 10 kN")
        } else {
            None
        };
        if let Some(why) = why {
            s.diverged = true;
            s.stop_reason = format!("diverged at t = {t:.3} s: {why}");
            break;
        }
        if k == n_ctrl {
            break;
        }

        // Zero-order hold over the plant steps of this period.
        for _ in 0..n_sub {
            plant.step(cmd, dt);
            s.sim_steps += 1;
            sensor.push(plant.state());
        }
    }

    let rms = |sq: f64, n: u64| {
        if n > 0 {
            (sq / n as f64).sqrt()
        } else {
            f64::NAN
        }
    };
    s.rms_position_error_m = rms(sum_sq, n_all);
    s.rms_position_error_tail_m = rms(sum_sq_tail, n_tail);
    s.rms_position_error_last80_m = rms(sum_sq_80, n_80);
    s.final_position_error_m = last.pos_err_norm_m;
    s.final_position_error_xyz_m = last.pos_err_m;
    s.final_angle_error_rad = last.angle_err_rad;
    s.saturated_fraction = if s.control_steps > 0 {
        n_sat as f64 / s.control_steps as f64
    } else {
        0.0
    };
    if s.diverged || s.nan_detected {
        // A run that stopped early has no meaningful tail: report it as infinite error.
        if !s.rms_position_error_tail_m.is_finite() || n_tail == 0 {
            s.rms_position_error_tail_m = f64::INFINITY;
        }
        if n_80 == 0 {
            s.rms_position_error_last80_m = f64::INFINITY;
        }
    }
    s.verdict = verdict(&s);
    let fs = last.state;
    s.final_state = fs.eta.iter().chain(fs.nu.iter()).copied().collect();
    s.wall_time_s = wall.elapsed().as_secs_f64();
    Ok(RunOutput { summary: s, log })
}
