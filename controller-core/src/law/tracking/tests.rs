use super::*;
use crate::error::Error;
use crate::params::Vehicle;
use crate::reference::Reference;

fn ctx() -> (Vehicle, TrackingGains, TrackingState) {
    (
        Vehicle::observer(),
        TrackingGains::DEFAULT,
        TrackingState::default(),
    )
}

#[test]
fn default_gains_validate_and_bad_ones_are_refused() {
    assert!(TrackingGains::DEFAULT.validate().is_ok());
    let mut g = TrackingGains::DEFAULT;
    g.hand_m = 0.0;
    assert_eq!(g.validate(), Err(Error::NotPositive("hand_m")));
    let mut g = TrackingGains::DEFAULT;
    g.xy_ki = f32::NAN;
    assert_eq!(g.validate(), Err(Error::NonFinite("xy_ki")));
    let mut g = TrackingGains::DEFAULT;
    g.pitch_max_rad = 0.8;
    assert_eq!(g.validate(), Err(Error::OutOfRange("pitch_max_rad")));
}

#[test]
fn at_rest_on_a_resting_reference_asks_for_nothing() {
    let (v, g, mut st) = ctx();
    let nav = NavState::default();
    let r = RefSample::default();
    for f in [step_xz, step_xy, step_3d] {
        let out = f(&v, &g, &mut st, &nav, &r, 0.01);
        assert!(out.forces.surge_n.abs() < 1e-5, "{out:?}");
        assert!(out.forces.yaw_n_m.abs() < 1e-5, "{out:?}");
        assert!(out.forces.heave_n.abs() < 1e-5, "{out:?}");
    }
}

#[test]
fn non_finite_inputs_never_give_nan_integrators() {
    let (v, g, mut st) = ctx();
    let nav = NavState {
        x_m: f32::NAN,
        u_m_s: f32::INFINITY,
        ..NavState::default()
    };
    let r = Reference::Circle {
        center_m: [0.0, 5.0, 1.0],
        radius_m: 5.0,
        speed_m_s: 0.3,
    }
    .sample(12.0);
    for dt in [0.01, f32::NAN, -1.0, 0.0] {
        let _ = step_3d(&v, &g, &mut st, &nav, &r, dt);
        let _ = step_xz(&v, &g, &mut st, &nav, &r, dt);
        assert!(st.integrators().iter().all(|x| x.is_finite()));
    }
}

#[test]
fn saturated_channel_freezes_its_integrator() {
    let (v, g, mut st) = ctx();
    let nav = NavState {
        z_m: -0.3,
        ..NavState::default()
    };
    let r = RefSample::default();
    let _ = step_3d(&v, &g, &mut st, &nav, &r, 0.01);
    let before = st.integrators()[3];
    st.on_allocation(
        &BodyForces {
            heave_n: 50.0,
            ..BodyForces::default()
        },
        &BodyForces {
            heave_n: 20.0,
            ..BodyForces::default()
        },
    );
    for _ in 0..10 {
        let _ = step_3d(&v, &g, &mut st, &nav, &r, 0.01);
    }
    assert_eq!(st.integrators()[3], before);
}
