//! Closed loop for the tracking tests: the 6-DOF plant (RK4, 1 ms) and the core's
//! `Controller` at 10 ms with a zero-order hold. Errors are measured on the true plant state,
//! at the body origin, against the reference for the body origin.
#![allow(dead_code, clippy::indexing_slicing)]

use controller_core::controller::{ControlMode, Controller, Gains};
use controller_core::params::VehicleParams;
use controller_core::reference::Reference;
use controller_core::state::NavState;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::{Environment, Plant, PlantState};

pub const PLANT_DT: f64 = 0.001;
pub const CTRL_DT: f64 = 0.01;

/// What one run measured.
#[derive(Debug, Clone, Default)]
pub struct Metrics {
    pub final_err_m: f64,
    pub max_err_after_10s_m: f64,
    pub max_err_after_60s_m: f64,
    pub rms_last_80_m: f64,
    pub max_thrust_n: f64,
    pub max_pitch_rad: f64,
    pub finite: bool,
}

pub fn nav_of(s: &PlantState) -> NavState {
    let [x, y, z, roll, pitch, yaw] = s.eta;
    let [u, v, w, p, q, r] = s.nu;
    NavState {
        x_m: x as f32,
        y_m: y as f32,
        z_m: z as f32,
        roll_rad: roll as f32,
        pitch_rad: pitch as f32,
        yaw_rad: yaw as f32,
        u_m_s: u as f32,
        v_m_s: v as f32,
        w_m_s: w as f32,
        p_rad_s: p as f32,
        q_rad_s: q as f32,
        r_rad_s: r as f32,
    }
}

/// Which components of the position error count for a mode.
fn mask(mode: ControlMode) -> [f64; 3] {
    match mode {
        ControlMode::TrackingXz | ControlMode::PaperXz => [1.0, 0.0, 1.0],
        ControlMode::TrackingXy | ControlMode::PaperXy => [1.0, 1.0, 0.0],
        _ => [1.0, 1.0, 1.0],
    }
}

/// Run `t_end_s` of closed loop. `plant_params` is what the plant simulates (buoyancy offset
/// included); the controller always uses the nominal Observer.
pub fn run(
    mode: ControlMode,
    reference: &Reference,
    initial: PlantState,
    plant_params: &VehicleParams,
    env: Environment,
    t_end_s: f64,
) -> Metrics {
    run_with(
        Gains::default(),
        mode,
        reference,
        initial,
        plant_params,
        env,
        t_end_s,
    )
}

/// [`run`] with explicit gains.
pub fn run_with(
    gains: Gains,
    mode: ControlMode,
    reference: &Reference,
    initial: PlantState,
    plant_params: &VehicleParams,
    env: Environment,
    t_end_s: f64,
) -> Metrics {
    reference.validate().expect("reference");
    let vehicle = VehicleParams::OBSERVER.validate().expect("vehicle");
    let mut ctl = Controller::new(vehicle, gains).expect("controller");
    let mut plant = SixDof::new(plant_params, env, true, initial);
    let sub = (CTRL_DT / PLANT_DT).round() as usize;
    let n = (t_end_s / CTRL_DT).round() as usize;
    let m = mask(mode);
    let mut errs = Vec::with_capacity(n);
    let mut out = Metrics {
        finite: true,
        ..Metrics::default()
    };
    for i in 0..n {
        let t = i as f64 * CTRL_DT;
        let s = plant.state();
        let r = reference.sample(t as f32);
        let e: f64 = (0..3)
            .map(|k| {
                let d = (s.eta[k] - f64::from(r.pos_m[k])) * m[k];
                d * d
            })
            .sum::<f64>()
            .sqrt();
        errs.push((t, e));
        out.max_pitch_rad = out.max_pitch_rad.max(s.eta[4].abs());
        if !s.is_finite() {
            out.finite = false;
            break;
        }
        let o = ctl.step(mode, &nav_of(&s), &r, CTRL_DT as f32);
        let cmd = o.allocation.thrust_n.map(f64::from);
        for _ in 0..sub {
            plant.step(cmd, PLANT_DT);
        }
        for f in plant.thrust_n() {
            out.max_thrust_n = out.max_thrust_n.max(f.abs());
        }
    }
    let t_end = errs.last().map(|x| x.0).unwrap_or(0.0);
    out.final_err_m = errs.last().map(|x| x.1).unwrap_or(f64::NAN);
    out.max_err_after_10s_m = errs
        .iter()
        .filter(|x| x.0 >= 10.0)
        .map(|x| x.1)
        .fold(0.0, f64::max);
    out.max_err_after_60s_m = errs
        .iter()
        .filter(|x| x.0 >= 60.0)
        .map(|x| x.1)
        .fold(0.0, f64::max);
    let tail: Vec<f64> = errs
        .iter()
        .filter(|x| x.0 >= 0.2 * t_end)
        .map(|x| x.1 * x.1)
        .collect();
    out.rms_last_80_m = (tail.iter().sum::<f64>() / tail.len().max(1) as f64).sqrt();
    out
}

/// The initial plant state at rest at `pos` with yaw `yaw`.
pub fn at_rest(pos: [f64; 3], yaw: f64) -> PlantState {
    PlantState {
        eta: [pos[0], pos[1], pos[2], 0.0, 0.0, yaw],
        nu: [0.0; 6],
    }
}

/// One traced sample: `(t, [ex, ey, ez], pitch, yaw, thrust)`.
pub type TracePoint = (f64, [f64; 3], f64, f64, [f32; 3]);

/// Time series `(t, [ex, ey, ez], pitch, yaw, thrust)` every `every` control steps (debugging
/// and docs).
pub fn trace(
    mode: ControlMode,
    reference: &Reference,
    initial: PlantState,
    plant_params: &VehicleParams,
    env: Environment,
    t_end_s: f64,
    every: usize,
) -> Vec<TracePoint> {
    let vehicle = VehicleParams::OBSERVER.validate().expect("vehicle");
    let mut ctl = Controller::new(vehicle, Gains::default()).expect("controller");
    let mut plant = SixDof::new(plant_params, env, true, initial);
    let sub = (CTRL_DT / PLANT_DT).round() as usize;
    let n = (t_end_s / CTRL_DT).round() as usize;
    let mut v = Vec::new();
    for i in 0..n {
        let t = i as f64 * CTRL_DT;
        let s = plant.state();
        let r = reference.sample(t as f32);
        let o = ctl.step(mode, &nav_of(&s), &r, CTRL_DT as f32);
        if i % every == 0 {
            let e = [0, 1, 2].map(|k| s.eta[k] - f64::from(r.pos_m[k]));
            v.push((t, e, s.eta[4], s.eta[5], o.allocation.thrust_n));
        }
        let cmd = o.allocation.thrust_n.map(f64::from);
        for _ in 0..sub {
            plant.step(cmd, PLANT_DT);
        }
    }
    v
}
