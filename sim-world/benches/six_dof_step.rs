//! The 6-DOF plant's cost per RK4 step, alone and side by side, and a fingerprint of the
//! trajectories it integrates.
//!
//! `cargo bench -p sim-world --bench six_dof_step` steps four Observer plants 1 ms at a
//! time for 120 s of simulated time each (one `mc-circle-3d` run's plant work), with thrust
//! commands that turn, surge and heave them in a current, first one at a time
//! ([`Plant::step`]), then two and four side by side ([`SixDof::step_lanes`]). It prints the
//! nanoseconds per plant step of each (the best of 5 repeats, in this thread's CPU time) and a hash of the
//! final states' bits, and exits 1 if the side-by-side states differ from the one-at-a-time
//! ones by a bit.

use controller_core::params::VehicleParams;
use cpu_time::ThreadTime;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::{Environment, Plant, PlantState};
use std::hash::{DefaultHasher, Hash, Hasher};

const STEPS: usize = 120_000;
const DT_S: f64 = 0.001;
const PLANTS: usize = 4;

/// Thrust commands `[F1x, F2x, F3z]` of plant `j` at step `i`: a surge, a yaw and a heave
/// that change with time (held over 10 steps, as the control loop holds them).
fn command_n(j: usize, i: usize) -> [f64; 3] {
    let t = (i / 10) as f64 * 0.01 + j as f64 * 7.0;
    let surge = 6.0 * (0.05 * t).sin();
    let yaw = 4.0 * (0.13 * t).cos();
    let heave = 3.0 * (0.07 * t).sin() + 0.5;
    [surge + yaw, surge - yaw, heave]
}

fn plant(j: usize) -> SixDof {
    let initial = PlantState {
        eta: [0.0, 0.0, 2.0, 0.0, 0.0, 0.3 * j as f64],
        nu: [0.0; 6],
    };
    let mut params = VehicleParams::OBSERVER;
    params.mass_kg *= 1.0 + 0.05 * j as f32;
    let env = Environment {
        current_m_s: [0.1, 0.05 * j as f64, 0.0],
    };
    SixDof::new(&params, env, true, initial)
}

fn fingerprint(plants: &[SixDof]) -> u64 {
    let mut h = DefaultHasher::new();
    for p in plants {
        let st = p.state();
        for v in st.eta.iter().chain(st.nu.iter()).chain(p.thrust_n().iter()) {
            v.to_bits().hash(&mut h);
        }
    }
    h.finish()
}

fn commands() -> Vec<[[f64; 3]; PLANTS]> {
    (0..STEPS)
        .map(|i| std::array::from_fn(|j| command_n(j, i)))
        .collect()
}

/// All plants, `W` at a time; returns them and the seconds taken.
fn run<const W: usize>(cmds: &[[[f64; 3]; PLANTS]]) -> (Vec<SixDof>, f64) {
    let mut plants: Vec<SixDof> = (0..PLANTS).map(plant).collect();
    let start = ThreadTime::now();
    for (g, group) in plants.chunks_mut(W).enumerate() {
        if W == 1 {
            for (i, c) in cmds.iter().enumerate() {
                for (p, j) in group.iter_mut().zip(g..) {
                    p.step(c[j], DT_S);
                    std::hint::black_box(i);
                }
            }
            continue;
        }
        let refs: Vec<&mut SixDof> = group.iter_mut().collect();
        let Ok(mut lanes) = <[&mut SixDof; W]>::try_from(refs) else {
            continue;
        };
        for c in cmds {
            let cmd: [[f64; 3]; W] = std::array::from_fn(|l| c[g * W + l]);
            SixDof::step_lanes(&mut lanes, cmd, DT_S);
        }
    }
    (plants, start.elapsed().as_secs_f64())
}

fn best<const W: usize>(cmds: &[[[f64; 3]; PLANTS]]) -> (f64, u64) {
    let mut best_s = f64::INFINITY;
    let mut fp = 0;
    for _ in 0..5 {
        let (plants, s) = run::<W>(cmds);
        best_s = best_s.min(s);
        fp = fingerprint(&plants);
    }
    (best_s / (STEPS * PLANTS) as f64 * 1e9, fp)
}

fn main() {
    let cmds = commands();
    let (ns1, fp1) = best::<1>(&cmds);
    let (ns2, fp2) = best::<2>(&cmds);
    let (ns4, fp4) = best::<4>(&cmds);
    println!("six_dof_step: one at a time {ns1:.1} ns per plant step, fingerprint {fp1:016x}");
    println!("six_dof_step: two side by side {ns2:.1} ns per plant step, fingerprint {fp2:016x}");
    println!("six_dof_step: four side by side {ns4:.1} ns per plant step, fingerprint {fp4:016x}");
    if fp2 != fp1 || fp4 != fp1 {
        println!("six_dof_step: the side-by-side states differ from the one-at-a-time ones");
        std::process::exit(1);
    }
}
