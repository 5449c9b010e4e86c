//! Divergence judged on the true state: a vehicle that cannot hold its depth is
//! named so, not "completed"; a run that ends where it should is not judged lost.

use host_sim::closed_loop::runner::{nominal_plant_params, run, RunOptions};
use host_sim::closed_loop::Summary;
use sim_scenario::Scenario;

/// `line-3d` flown by a controller told the nominal vehicle, on a plant `heavy_n` heavier.
fn line_3d_heavier_by(heavy_n: f32) -> Summary {
    let sc = Scenario::load("line-3d").unwrap();
    let mut plant = nominal_plant_params(&sc);
    plant.buoyancy_offset_n -= heavy_n;
    let out = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            plant_params: Some(plant),
            ..RunOptions::default()
        },
    )
    .unwrap();
    out.summary
}

#[test]
fn an_18_n_heavy_vehicle_that_sinks_has_lost_depth_control() {
    // 18 N heavy: more than the vertical thruster's 15 N reverse thrust (the scenario check
    // refuses such a file, the plant of a Monte Carlo run or a real vehicle can still be so).
    let s = &line_3d_heavier_by(18.0);
    assert!(s.diverged, "{}", s.verdict);
    let lost = s.lost_control.as_deref().unwrap_or("");
    assert!(lost.starts_with("lost depth control"), "{lost}");
    assert!(lost.contains("below"), "{lost}");
    assert!(!s.verdict.contains("completed") && s.verdict.contains("lost depth control"));
    assert!(!s.targets.as_ref().unwrap().met);
}

#[test]
fn a_vehicle_just_within_its_thruster_holds_its_depth() {
    let s = &line_3d_heavier_by(14.0);
    assert!(!s.diverged && s.lost_control.is_none(), "{}", s.verdict);
}
