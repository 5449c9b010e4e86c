//! The thrust curve as the force scale: each vehicle identified with its own thrusters'
//! published curve (a datasheet value off the truth by a stated error), no net buoyancy
//! given; the net buoyancy comes out of the fit with the masses and drags.

use super::*;

/// A builder's datasheet for the installed thrusters: the truth's limits off by `error`
/// (a fraction: +0.04 is a curve 4 % stronger than the thrusters really are).
fn datasheet_prior(truth: &VehicleParams, error: f64) -> VehicleParams {
    let mut p = VehicleParams::OBSERVER;
    let k = (1.0 + error) as f32;
    p.thrust_max_forward_n = truth.thrust_max_forward_n * k;
    p.thrust_max_reverse_n = truth.thrust_max_reverse_n * k;
    p
}

/// Identify `file` (seed `seed`) with the curve `prior` as the anchor; the errors of every
/// value (%) against the truth.
fn identify_on_curve(file: &str, seed: u64, prior: &VehicleParams) -> [f64; 12] {
    let truth = vehicle_file(file);
    let tag = format!("curve-{}-{seed}", file.trim_end_matches(".toml"));
    let rec = fly(&truth, seed, &tag);
    let out = identify(&rec, prior, Anchor::ThrustAhead).unwrap();
    let t = truth_values_against(&truth, prior);
    report(&tag, &out, &t);
    let v = out.identified.model.values();
    std::array::from_fn(|i| (v[i] / t[i] - 1.0) * 100.0)
}

/// Heavy-slow with its thrusters' curve 4 % strong, light with its 4 % weak: net buoyancy,
/// masses and quadratic drags within 10 % of the truth.
#[test]
fn net_buoyancy_masses_and_drags_within_10_percent_on_the_installed_thrust_curve() {
    for (file, error) in [("heavy-slow.toml", 0.04), ("light.toml", -0.04)] {
        let truth = vehicle_file(file);
        let err = identify_on_curve(file, 1, &datasheet_prior(&truth, error));
        let worst = JUDGED.iter().map(|&i| err[i].abs()).fold(0.0, f64::max);
        eprintln!(
            "{file}: curve {:+.0} %: net buoyancy {:+.1} %, worst judged {worst:.1} %",
            error * 100.0,
            err[9]
        );
        assert!(worst <= 10.0, "{file}: worst {worst:.1} %");
    }
}

/// The same anchor on the Observer's curve (the thrusters the vehicle does not have): every
/// force is off by the thrust ratio; shown, and asserted to be far off, so that the
/// datasheet is what the figure above rests on.
#[test]
fn on_the_observers_curve_the_net_buoyancy_is_off_by_the_thrust_ratio() {
    let err = identify_on_curve("heavy-slow.toml", 1, &VehicleParams::OBSERVER);
    eprintln!(
        "heavy-slow on the Observer's curve: net buoyancy {:+.1} %",
        err[9]
    );
    assert!(err[9] > 30.0, "net buoyancy {:+.1} %", err[9]);
}
