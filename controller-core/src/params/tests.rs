use super::*;

/// The two published BlueROV2 models (Table values as magnitudes; where a paper gives
/// no value the Observer's assumption is kept: `z_g`, the pitch terms, the lever arm
/// and the thrusters, a T200 at 16 V about 50 N ahead and 40 N astern).
fn bluerov2(
    mass_kg: f32,
    added: [f32; 5],
    linear: [f32; 5],
    quadratic: [f32; 5],
    inertia: [f32; 3],
) -> VehicleParams {
    VehicleParams {
        mass_kg,
        x_udot_kg: -added[0],
        y_vdot_kg: -added[1],
        z_wdot_kg: -added[2],
        m_qdot_kg_m2: -added[3],
        n_rdot_kg_m2: -added[4],
        x_u: linear[0],
        y_v: linear[1],
        z_w: linear[2],
        m_q: linear[3],
        n_r: linear[4],
        x_uu: quadratic[0],
        y_vv: quadratic[1],
        z_ww: quadratic[2],
        m_qq: quadratic[3],
        n_rr: quadratic[4],
        i_x_kg_m2: inertia[0],
        i_y_kg_m2: inertia[1],
        i_z_kg_m2: inertia[2],
        thrust_max_forward_n: 50.0,
        thrust_max_reverse_n: 40.0,
        thruster_lever_arm_m: 0.2,
        ..VehicleParams::OBSERVER
    }
}

#[test]
fn both_published_bluerov2_models_are_flyable() {
    // Wu (2018), BlueROV2.
    let wu = bluerov2(
        11.5,
        [5.5, 12.7, 14.57, 0.12, 0.12],
        [4.03, 6.22, 5.18, 0.07, 0.07],
        [18.18, 21.66, 36.99, 1.55, 1.55],
        [0.16, 0.16, 0.16],
    );
    // von Benzon et al. (2022), BlueROV2 Heavy.
    let von_benzon = bluerov2(
        13.5,
        [6.36, 7.12, 18.68, 0.135, 0.222],
        [13.7, 0.0, 33.0, 0.8, 0.0],
        [141.0, 217.0, 190.0, 0.47, 1.5],
        [0.26, 0.23, 0.37],
    );
    for (name, p) in [("Wu 2018", wu), ("von Benzon 2022", von_benzon)] {
        let v = p.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        v.check_flyable().unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

#[test]
fn observer_validates_and_derives() {
    let v = VehicleParams::OBSERVER.validate().unwrap();
    assert!((v.xz.m_x - 11.921).abs() < 1e-4);
    assert!((v.xz.m_z - 11.2248).abs() < 1e-4);
    assert!((v.xz.j_y - 0.2075).abs() < 1e-6);
    assert!((v.xz.a_uq - 0.3252).abs() < 1e-6);
    assert!((v.xz.a5 + 9.81).abs() < 1e-5, "a5 = -g");
    assert!(v.xz.delta > 0.0);
    assert_eq!(Vehicle::observer(), v);
}

#[test]
fn rejects_bad_values() {
    let mut p = VehicleParams::OBSERVER;
    p.mass_kg = f32::NAN;
    assert_eq!(p.validate(), Err(Error::NonFinite("mass_kg")));
    let mut p = VehicleParams::OBSERVER;
    p.z_g_m = 0.0;
    assert_eq!(p.validate(), Err(Error::NotPositive("z_g_m")));
    let mut p = VehicleParams::OBSERVER;
    p.x_uu = -1.0;
    assert_eq!(p.validate(), Err(Error::Negative("x_uu")));
    let mut p = VehicleParams::OBSERVER;
    p.x_udot_kg = 20.0;
    assert!(matches!(p.validate(), Err(Error::NonPhysical(_))));
    let mut p = VehicleParams::OBSERVER;
    p.buoyancy_offset_n = 1e4;
    assert_eq!(p.validate(), Err(Error::OutOfRange("buoyancy_offset_n")));
}
