//! The water the vehicle is in. The seabed and the surface bound the plant (a
//! run that meets either says so), the DVL loses bottom lock above its range, and the
//! current changes in time and with depth. Figures on the TRUE position.

use controller_core::params::VehicleParams;
use host_sim::closed_loop::runner::{run, RunOptions};
use sim_scenario::Scenario;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::water::WaterSpec;
use sim_world::plant::{Boundary, Environment, Plant, PlantState};
use sim_world::sensor_sim::SensorSuite;
use sim_world::sensors::{DvlSpec, Measurement, SensorsSpec};

#[test]
fn a_buoyant_vehicle_stops_at_the_surface_and_says_so() {
    let params = VehicleParams {
        buoyancy_offset_n: 5.0,
        ..VehicleParams::OBSERVER
    };
    let start = PlantState {
        eta: [0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
        ..PlantState::default()
    };
    let mut p = SixDof::new(&params, Environment::default(), true, start);
    p.set_bounds(true, None);
    let mut min_z = f64::MAX;
    for _ in 0..20_000 {
        p.step([0.0; 3], 1e-3);
        min_z = min_z.min(p.state().eta[2]);
    }
    assert!(min_z >= 0.0, "above the surface: z = {min_z}");
    assert_eq!(p.state().eta[2], 0.0);
    assert_eq!(p.contact(), Some(Boundary::Surface));
    // It rests there: no velocity up through the surface.
    assert!(p.state().nu[2] > -1e-3, "{:?}", p.state());
}

#[test]
fn a_survey_below_the_seabed_is_stopped_by_it_and_the_summary_says_so() {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    sc.water.seabed_depth_m = Some(2.5);
    sc.water.surface = true;
    // A start below the seabed is refused with the keys named.
    let e = format!("{:#}", sc.validate().unwrap_err());
    assert!(
        e.contains("initial.z_m") && e.contains("water.seabed_depth_m"),
        "{e}"
    );
    sc.initial.z_m = 2.0;
    sc.validate().unwrap();
    let out = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    let deepest = out.log.iter().map(|x| x.state.eta[2]).fold(0.0, f64::max);
    println!(
        "seabed 2.5 m, reference at 3 m: deepest {deepest:.4} m, {:?}",
        out.summary.boundary_contact
    );
    assert!(deepest <= 2.5 + 1e-9, "through the seabed: {deepest}");
    let said = out.summary.boundary_contact.unwrap_or_default();
    assert!(said.starts_with("hit the seabed at t = "), "{said}");
    // Without a seabed the same run meets nothing.
    let free = run(
        &Scenario::load("nav-lawnmower-3d")
            .unwrap()
            .resolve()
            .unwrap(),
        &RunOptions::default(),
    )
    .unwrap();
    assert_eq!(free.summary.boundary_contact, None);
}

#[test]
fn the_dvl_has_no_bottom_lock_above_its_range() {
    let spec = SensorsSpec {
        dvl: Some(DvlSpec {
            max_altitude_m: Some(50.0),
            ..DvlSpec::default()
        }),
        ..SensorsSpec::default()
    };
    let truth = PlantState {
        eta: [0.0, 0.0, 3.0, 0.0, 0.0, 0.0],
        nu: [0.2, 0.0, 0.0, 0.0, 0.0, 0.0],
    };
    let count = |seabed: Option<f64>| {
        let mut s = SensorSuite::new(&spec, 1);
        s.set_seabed_depth_m(seabed);
        let mut out = Vec::new();
        for k in 1..=10_000 {
            s.sample(k as f64 * 1e-3, &truth, &mut out);
        }
        out.iter()
            .filter(|(_, m)| matches!(m, Measurement::Dvl(_)))
            .count()
    };
    assert_eq!(count(Some(60.0)), 0, "57 m above the seabed, range 50 m");
    assert_eq!(
        count(Some(20.0)),
        50,
        "17 m above the seabed: 5 Hz for 10 s"
    );
    assert_eq!(count(None), 50, "no seabed given: always in range");
}

#[test]
fn a_current_that_grows_in_time_and_changes_with_depth_is_tracked_within_10_cm() {
    let mut sc = Scenario::load("nav-lawnmower-3d").unwrap();
    // 0 at the start to 0.2 m/s across the legs at 150 s, then turning along them; 0.05 m/s
    // more near the surface than at 3 m.
    sc.water = WaterSpec {
        surface: true,
        seabed_depth_m: Some(30.0),
        current_time_profile: vec![
            [0.0, 0.0, 0.0, 0.0],
            [150.0, 0.0, 0.2, 0.0],
            [250.0, 0.14, 0.14, 0.0],
        ],
        current_depth_profile: vec![[0.0, 0.05, 0.0, 0.0], [3.0, 0.0, 0.0, 0.0]],
    };
    if let Some(d) = sc.sensors.dvl.as_mut() {
        d.max_altitude_m = Some(50.0);
    }
    sc.validate().unwrap();
    let s = run(&sc.resolve().unwrap(), &RunOptions::default())
        .unwrap()
        .summary;
    println!(
        "lawnmower, current 0 -> 0.2 m/s in 150 s then turning, sheared: tracking {:.1} cm, estimation {:.1} cm, NEES {:.2}, {:?}",
        100.0 * s.rms_position_error_last80_m,
        100.0 * s.rms_estimation_error_m,
        s.navigation.nees_in_bounds_fraction.unwrap_or(f64::NAN),
        s.boundary_contact
    );
    assert!(!s.nan_detected && !s.diverged, "{}", s.verdict);
    assert_eq!(s.boundary_contact, None);
    assert!(
        s.rms_position_error_last80_m <= 0.10,
        "{}",
        s.rms_position_error_last80_m
    );
}
