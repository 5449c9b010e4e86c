//! The 6-DOF plant's cost per RK4 step, and a fingerprint of the trajectory it integrates.
//!
//! `cargo bench -p sim-world --bench six_dof_step` steps the Observer plant 1 ms at a time
//! for 120 s of simulated time (one `mc-circle-3d` run's plant work), with thrust commands
//! that turn, surge and heave it in a 0.1 m/s current, and prints the nanoseconds per step
//! and a hash of the final state's bits: a change to the plant that keeps its results keeps
//! the hash.

use controller_core::params::VehicleParams;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::{Environment, Plant, PlantState};
use std::hash::{DefaultHasher, Hash, Hasher};
use std::time::Instant;

const STEPS: usize = 120_000;
const DT_S: f64 = 0.001;

/// Thrust commands `[F1x, F2x, F3z]` at step `i`: a surge, a yaw and a heave that change
/// with time (held over 10 steps, as the control loop holds them).
fn command_n(i: usize) -> [f64; 3] {
    let t = (i / 10) as f64 * 0.01;
    let surge = 6.0 * (0.05 * t).sin();
    let yaw = 4.0 * (0.13 * t).cos();
    let heave = 3.0 * (0.07 * t).sin() + 0.5;
    [surge + yaw, surge - yaw, heave]
}

fn run(commands: &[[f64; 3]]) -> (SixDof, f64) {
    let initial = PlantState {
        eta: [0.0, 0.0, 2.0, 0.0, 0.0, 0.3],
        nu: [0.0; 6],
    };
    let env = Environment {
        current_m_s: [0.1, 0.05, 0.0],
    };
    let mut plant = SixDof::new(&VehicleParams::OBSERVER, env, true, initial);
    let start = Instant::now();
    for cmd in commands {
        plant.step(*cmd, DT_S);
    }
    (plant, start.elapsed().as_secs_f64())
}

fn main() {
    let commands: Vec<[f64; 3]> = (0..STEPS).map(command_n).collect();
    let mut best_s = f64::INFINITY;
    let mut fingerprint = 0;
    for _ in 0..10 {
        let (plant, s) = run(&commands);
        best_s = best_s.min(s);
        let st = plant.state();
        let mut h = DefaultHasher::new();
        for v in st
            .eta
            .iter()
            .chain(st.nu.iter())
            .chain(plant.thrust_n().iter())
        {
            v.to_bits().hash(&mut h);
        }
        fingerprint = h.finish();
    }
    println!(
        "six_dof_step: {:.1} ns per step (best of 10 x {STEPS} steps), state fingerprint {fingerprint:016x}",
        best_s / STEPS as f64 * 1e9
    );
}
