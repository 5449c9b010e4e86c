//! One `Controller::step` (law + allocation + anti-windup + PWM map) per law, in `f32`, on the
//! host. `cargo bench -p rov-benches --features bench --bench controller_step`.
#![allow(missing_docs, clippy::unwrap_used)]

use controller_core::controller::{ControlMode, Controller, Gains};
use controller_core::params::Vehicle;
use controller_core::reference::{PaperPolynomial, Reference};
use controller_core::state::NavState;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;

fn nav() -> NavState {
    NavState {
        x_m: 4.98,
        y_m: 5.01,
        z_m: 5.02,
        roll_rad: 0.01,
        pitch_rad: -0.05,
        yaw_rad: 0.78,
        u_m_s: 0.69,
        v_m_s: 0.01,
        w_m_s: 0.49,
        p_rad_s: 0.0,
        q_rad_s: 0.002,
        r_rad_s: 0.001,
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("controller_step");
    g.throughput(Throughput::Elements(1));
    let paper = Reference::Paper(PaperPolynomial::PAPER).sample(50.0);
    let circle = Reference::Circle {
        center_m: [0.0, 5.0, 2.0],
        radius_m: 5.0,
        speed_m_s: 0.25,
    }
    .sample(60.0);
    for (name, mode, r) in [
        ("paper_xz", ControlMode::PaperXz, paper),
        ("paper_xy", ControlMode::PaperXy, paper),
        ("tracking_xz", ControlMode::TrackingXz, paper),
        ("tracking_xy", ControlMode::TrackingXy, paper),
        ("tracking_3d", ControlMode::Tracking3d, circle),
    ] {
        let mut ctl = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
        let n = nav();
        g.bench_function(name, |b| {
            b.iter(|| {
                ctl.step(
                    black_box(mode),
                    black_box(&n),
                    black_box(&r),
                    black_box(0.01),
                )
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
