//! One RK4 step of the 6-DOF plant (f64). Target: >= 3 M steps/s on one core.
//! `cargo bench -p rov-benches --features bench --bench six_dof`.
#![allow(missing_docs)]

use controller_core::params::VehicleParams;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::{Environment, Plant, PlantState};
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("six_dof");
    g.throughput(Throughput::Elements(1));
    let initial = PlantState {
        eta: [0.0, 0.0, 2.0, 0.05, -0.03, 0.4],
        nu: [0.3, -0.05, 0.02, 0.1, -0.05, 0.05],
    };
    let env = Environment {
        current_m_s: [0.1, -0.05, 0.0],
    };
    let mut plant = SixDof::new(&VehicleParams::OBSERVER, env, true, initial);
    g.bench_function("rk4_step", |b| {
        b.iter(|| plant.step(black_box([6.0, 4.0, -2.0]), black_box(1e-3)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
