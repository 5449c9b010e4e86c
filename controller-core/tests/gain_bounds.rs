//! The gains' ranges: a gain that makes a law bang-bang at its control period, or that
//! switches a law off, is refused, and the refusal names the range.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use controller_core::controller::Gains;
use controller_core::law::tracking::TrackingGains;

type Setter = fn(&mut TrackingGains, f32);

fn velocity_gains() -> [(&'static str, Setter); 2] {
    [
        ("xy_kd", |g, v| g.xy_kd = v),
        ("depth_kd", |g, v| g.depth_kd = v),
    ]
}

#[test]
fn a_velocity_gain_of_999_or_1e_30_is_refused_naming_its_range() {
    assert_eq!(Gains::default().validate(), Ok(()));
    for (name, set) in velocity_gains() {
        for v in [999.0, 1.0e-30] {
            let mut g = Gains::default();
            set(&mut g.tracking, v);
            let e = g.validate().expect_err(name);
            let text = e.to_string();
            assert!(text.contains(name), "{name} = {v}: {text}");
            assert!(text.contains("..="), "{name} = {v}: the range in {text}");
        }
    }
}

use controller_core::alloc::{allocate, ThrusterLimits};
use controller_core::law::gain_bounds::{CONTROL_PERIOD_S, RATE_GAIN_MAX};
use controller_core::law::tracking::{step_xy, step_xz, TrackingState};
use controller_core::model::{rk4_step, xy, xz};
use controller_core::params::Vehicle;
use controller_core::reference::Reference;
use controller_core::state::{NavState, XyState, XzState};

/// How a closed-loop run used the thrusters.
#[derive(Debug, Default)]
struct Run {
    /// Control steps whose allocation was clamped (a thruster at its limit).
    saturated: usize,
    steps: usize,
    /// Sign changes of the watched thruster's force between steps where it pushes more than
    /// a quarter of its reverse limit (full swings, not the noise's jitter).
    flips: usize,
    /// Sign changes of the watched thruster's force beyond 1 N (the noise's jitter too).
    jitter_flips: usize,
    /// Final position error, m.
    final_error_m: f32,
}

/// A small deterministic velocity noise, +-0.01 m/s (the estimator's).
fn noise(state: &mut u32) -> f32 {
    *state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
    ((*state >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.02
}

/// Control every 20 ms, the forces held over RK4 steps of 1 ms on the core's model, the
/// thrusters' limits applied. `plane`: the XZ plant holding 0.3 m shallower (the depth law,
/// `F3z` watched), or the XY plant holding a point 0.3 m ahead and aside (`F1x` watched).
fn fly(g: &TrackingGains, xz_plane: bool, seconds: f32) -> Run {
    let v = Vehicle::observer();
    let limits = ThrusterLimits::of(&v);
    let hold = Reference::Hold {
        pos_m: if xz_plane {
            [0.0, 0.0, 2.0]
        } else {
            [0.3, 0.3, 0.0]
        },
    };
    let sample = hold.sample(0.0);
    let mut st = TrackingState::default();
    let (mut sxz, mut sxy) = (
        XzState {
            z_m: 2.3,
            ..XzState::default()
        },
        XyState::default(),
    );
    let mut seed = 7u32;
    let mut run = Run::default();
    let (mut last_sign, mut last_jitter_sign) = (0.0f32, 0.0f32);
    let swing_n = 0.25 * limits.max_reverse_n;
    let steps = (seconds / CONTROL_PERIOD_S) as usize;
    for _ in 0..steps {
        let nav = if xz_plane {
            NavState {
                x_m: sxz.x_m,
                z_m: sxz.z_m,
                pitch_rad: sxz.pitch_rad,
                u_m_s: sxz.u_m_s + noise(&mut seed),
                w_m_s: sxz.w_m_s + noise(&mut seed),
                q_rad_s: sxz.q_rad_s,
                ..NavState::default()
            }
        } else {
            NavState {
                x_m: sxy.x_m,
                y_m: sxy.y_m,
                yaw_rad: sxy.yaw_rad,
                u_m_s: sxy.u_m_s + noise(&mut seed),
                v_m_s: sxy.v_m_s + noise(&mut seed),
                r_rad_s: sxy.r_rad_s,
                ..NavState::default()
            }
        };
        let out = if xz_plane {
            step_xz(&v, g, &mut st, &nav, &sample, CONTROL_PERIOD_S)
        } else {
            step_xy(&v, g, &mut st, &nav, &sample, CONTROL_PERIOD_S)
        };
        let a = allocate(&out.forces, &limits);
        st.on_allocation(&out.forces, &a.achieved);
        run.steps += 1;
        run.saturated += usize::from(a.saturated);
        let watched = if xz_plane {
            a.thrust_n[2]
        } else {
            a.thrust_n[0]
        };
        if watched.abs() > swing_n {
            if watched.signum() == -last_sign {
                run.flips += 1;
            }
            last_sign = watched.signum();
        }
        if watched.abs() > 1.0 {
            if watched.signum() == -last_jitter_sign {
                run.jitter_flips += 1;
            }
            last_jitter_sign = watched.signum();
        }
        for _ in 0..20 {
            if xz_plane {
                sxz = rk4_step(|s| xz::derivative(&v, s, &a.achieved), &sxz, 1e-3);
            } else {
                sxy = rk4_step(|s| xy::derivative(&v, s, &a.achieved), &sxy, 1e-3);
            }
        }
        run.final_error_m = if xz_plane {
            (sxz.z_m - 2.0).abs()
        } else {
            ((sxy.x_m - 0.3).powi(2) + (sxy.y_m - 0.3).powi(2)).sqrt()
        };
    }
    run
}

#[test]
fn the_largest_accepted_velocity_gain_flies_without_bang_bang_and_999_does_not() {
    for (name, xz_plane, set) in [
        ("depth_kd", true, (|g, v| g.depth_kd = v) as Setter),
        ("xy_kd", false, (|g, v| g.xy_kd = v) as Setter),
    ] {
        let mut at_bound = TrackingGains::DEFAULT;
        set(&mut at_bound, RATE_GAIN_MAX);
        assert_eq!(
            Gains {
                tracking: at_bound,
                ..Gains::default()
            }
            .validate(),
            Ok(()),
            "{name} at its bound is accepted"
        );
        let mut wild = TrackingGains::DEFAULT;
        set(&mut wild, 999.0);
        let (def, bound, bang) = (
            fly(&TrackingGains::DEFAULT, xz_plane, 8.0),
            fly(&at_bound, xz_plane, 8.0),
            fly(&wild, xz_plane, 8.0),
        );
        println!("{name}: default {def:?}\n  at 12.5 {bound:?}\n  at 999 {bang:?}");
        assert!(
            bound.saturated * 10 <= bound.steps,
            "{name} at 12.5: {bound:?}"
        );
        assert!(bound.flips <= 4, "{name} at 12.5: {bound:?}");
        // Converging from its 0.3 m (depth) or 0.42 m (XY), slowly: a large k_d puts the
        // slow pole near k_p / k_d (0.24/s for depth, 0.08/s for XY).
        let start_m = if xz_plane { 0.3 } else { 0.3 * 2.0f32.sqrt() };
        assert!(
            bound.final_error_m < 0.6 * start_m,
            "{name} at 12.5: {bound:?}"
        );
        assert!(bang.saturated * 2 >= bang.steps, "{name} at 999: {bang:?}");
        assert!(bang.flips >= 50, "{name} at 999: {bang:?}");
    }
}

/// The tracking gains follow the vehicle: a heavier, weaker vehicle's description slows
/// them (`TrackingGains::for_vehicle`), the Observer's gives the defaults back; gains an
/// operator set stay through a change of description.
#[test]
fn the_tracking_gains_follow_the_vehicle_unless_an_operator_set_them() {
    use controller_core::controller::{Controller, Gains};
    use controller_core::law::tracking::TrackingGains;
    use controller_core::params::{Vehicle, VehicleParams};
    let heavy = VehicleParams {
        mass_kg: 16.0,
        thrust_max_forward_n: 13.0,
        thrust_max_reverse_n: 9.75,
        ..VehicleParams::OBSERVER
    }
    .validate()
    .unwrap();
    let mut c = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    c.set_vehicle(heavy);
    let slowed = c.gains().tracking;
    assert_eq!(slowed, TrackingGains::for_vehicle(&heavy));
    assert!(slowed.xy_kp < TrackingGains::DEFAULT.xy_kp, "{slowed:?}");
    assert_eq!(*c.gains(), Gains::for_vehicle(&heavy));
    c.set_vehicle(Vehicle::observer());
    assert_eq!(c.gains().tracking, TrackingGains::DEFAULT);

    let mut own = Gains::default();
    own.tracking.xy_kp *= 0.9;
    c.set_gains(own).unwrap();
    c.set_vehicle(heavy);
    assert_eq!(*c.gains(), own);
}
