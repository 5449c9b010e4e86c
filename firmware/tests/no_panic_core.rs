//! Which parts of controller-core's control step still have a panic path (link-time check,
//! `cargo test -p firmware --release --features no-panic-step --test no_panic_core`).
//! Each probe wraps one core function in `#[no_panic]`; the link error names every probe
//! whose callee can panic. All link as of 2026-11-22 (the usual culprit was `f32::clamp(lo, hi)`
//! with bounds computed at run time: its `assert!(lo <= hi)`; use `math::clamp`).
#![cfg(feature = "no-panic-step")]
// Test code: a failed expectation should stop the test.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::alloc::{allocate, Allocation, ThrusterLimits};
use controller_core::controller::{ControlMode, Controller, Gains};
use controller_core::law::LawOutput;
use controller_core::law::{paper_xy, paper_xz};
use controller_core::params::Vehicle;
use controller_core::reference::RefSample;
use controller_core::state::{BodyForces, NavState};
use std::hint::black_box;

#[no_panic::no_panic]
#[inline(never)]
fn probe_allocate(r: &BodyForces, l: &ThrusterLimits) -> Allocation {
    allocate(r, l)
}

#[no_panic::no_panic]
#[inline(never)]
fn probe_paper_xy(v: &Vehicle, g: &Gains, s: &NavState, r: &RefSample) -> LawOutput {
    paper_xy::step(v, &g.paper_xy, &s.xy(), r)
}

#[no_panic::no_panic]
#[inline(never)]
fn probe_paper_xz(v: &Vehicle, g: &Gains, s: &NavState, r: &RefSample) -> LawOutput {
    paper_xz::step(v, &g.paper_xz, &s.xz(), r)
}

#[no_panic::no_panic]
#[inline(never)]
fn probe_controller(c: &mut Controller, m: ControlMode, s: &NavState, r: &RefSample) -> [f32; 3] {
    c.step(m, s, r, 0.02).pulse_us
}

#[test]
fn core_probes_link() {
    let v = Vehicle::observer();
    let g = Gains::default();
    let l = ThrusterLimits::of(&v);
    let s = black_box(NavState::default());
    let r = black_box(RefSample::default());
    let _ = probe_allocate(&black_box(BodyForces::default()), &l);
    let _ = probe_paper_xy(&v, &g, &s, &r);
    let _ = probe_paper_xz(&v, &g, &s, &r);
    let mut c = Controller::new(v, g).unwrap();
    let _ = probe_controller(&mut c, black_box(ControlMode::Tracking3d), &s, &r);
}
