//! The navigation state check.

use super::*;

/// Sets one field of a state.
type Setter = fn(&mut NavState, f32);

/// Every field of a state, each with its limit and its setter.
fn fields() -> [(f32, Setter); 12] {
    use nav_limits::*;
    [
        (POSITION_M, |s, v| s.x_m = v),
        (POSITION_M, |s, v| s.y_m = v),
        (POSITION_M, |s, v| s.z_m = v),
        (ANGLE_RAD, |s, v| s.roll_rad = v),
        (ANGLE_RAD, |s, v| s.pitch_rad = v),
        (ANGLE_RAD, |s, v| s.yaw_rad = v),
        (SPEED_M_S, |s, v| s.u_m_s = v),
        (SPEED_M_S, |s, v| s.v_m_s = v),
        (SPEED_M_S, |s, v| s.w_m_s = v),
        (RATE_RAD_S, |s, v| s.p_rad_s = v),
        (RATE_RAD_S, |s, v| s.q_rad_s = v),
        (RATE_RAD_S, |s, v| s.r_rad_s = v),
    ]
}

#[test]
fn check_nav_names_the_first_reason_for_every_field() {
    assert_eq!(check_nav(&NavState::default()), Ok(()));
    for (k, (lim, set)) in fields().into_iter().enumerate() {
        for (v, want) in [
            (lim, Ok(())),
            (-lim, Ok(())),
            (lim * 1.001, Err(NackReason::OutOfRange)),
            (-lim * 1.001, Err(NackReason::OutOfRange)),
            (f32::NAN, Err(NackReason::NonFinite)),
            (f32::INFINITY, Err(NackReason::NonFinite)),
            (f32::NEG_INFINITY, Err(NackReason::NonFinite)),
        ] {
            let mut s = NavState::default();
            set(&mut s, v);
            assert_eq!(check_nav(&s), want, "field {k} = {v}");
        }
        // A non-finite field wins over an out-of-range one elsewhere.
        let mut s = NavState::default();
        set(&mut s, f32::NAN);
        let (lim2, set2) = fields()[(k + 1) % 12];
        set2(&mut s, lim2 * 2.0);
        assert_eq!(check_nav(&s), Err(NackReason::NonFinite), "field {k}");
    }
}
