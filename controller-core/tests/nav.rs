//! The estimator's contract: what it refuses leaves it unchanged and is counted; a late
//! USBL fix is compared with the estimate at its time of validity; gates and resets.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing
)]

use controller_core::nav::{
    DepthFix, DvlFix, Estimator, HeadingFix, ImuSample, NavConfig, NotReady, PositionFix, Refusal,
    CLUSTER_MIN, GRAVITY_M_S2, HISTORY_LEN, HISTORY_STEP_US, POSITION_READY_STD_M,
};
use controller_core::params::Vehicle;
use controller_core::state::NavState;

const DT_US: u64 = 10_000;

fn at_rest() -> Estimator {
    Estimator::new(
        Vehicle::observer(),
        NavConfig::default(),
        &NavState {
            z_m: 2.0,
            ..NavState::default()
        },
        0,
    )
    .unwrap()
}

fn imu(t_us: u64) -> ImuSample {
    ImuSample {
        t_us,
        gyro_rad_s: [0.0; 3],
        accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
    }
}

/// `n` IMU samples (100 Hz) with both surge thrusters at `thrust_each_n` (0: at rest), the
/// compass (north) and the depth (2 m) every 10th.
fn fly(e: &mut Estimator, n: u64, thrust_each_n: f32) {
    let t0 = e.time_us();
    for k in 1..=n {
        let t = t0 + k * DT_US;
        e.predict(&imu(t), [thrust_each_n, thrust_each_n, 0.0])
            .unwrap();
        if k % 10 == 0 {
            e.fuse_depth(&DepthFix {
                t_us: t,
                depth_m: 2.0,
                std_m: 0.005,
            })
            .unwrap();
            e.fuse_heading(&HeadingFix {
                t_us: t,
                yaw_rad: 0.0,
                std_rad: 0.02,
            })
            .unwrap();
        }
    }
}

#[test]
fn at_rest_the_estimate_stays_put_and_the_horizontal_uncertainty_grows_without_fixes() {
    let mut e = at_rest();
    let p0 = e.position_covariance()[0][0];
    fly(&mut e, 500, 0.0);
    let s = e.state();
    assert!(s.x_m.abs() < 1e-3 && s.y_m.abs() < 1e-3, "{s:?}");
    assert!((s.z_m - 2.0).abs() < 1e-3, "{s:?}");
    assert!(s.u_m_s.abs() < 1e-3 && s.yaw_rad.abs() < 1e-3, "{s:?}");
    assert!(e.position_covariance()[0][0] > p0);
    assert!(e.position_covariance()[2][2] < 0.005 * 0.005);
    let h = e.health();
    assert_eq!(
        (h.imu_samples, h.depth_fused, h.heading_fused),
        (500, 50, 50)
    );
}

#[test]
fn non_finite_absurd_and_badly_timed_measurements_are_refused_and_change_nothing() {
    let mut e = at_rest();
    fly(&mut e, 100, 0.0);
    let before = (e.state(), e.position_covariance());
    let now = e.time_us();
    let fix = |t_us, north_m, std_m| PositionFix {
        t_us,
        north_m,
        east_m: 0.0,
        std_m,
    };
    let cases: [(Result<(), Refusal>, Refusal); 10] = [
        (
            e.fuse_position(&fix(now, f32::NAN, 0.3)),
            Refusal::NonFinite,
        ),
        (e.fuse_position(&fix(now, 1.0e6, 0.3)), Refusal::OutOfRange),
        (e.fuse_position(&fix(now, 0.0, 0.0)), Refusal::BadAccuracy),
        (e.fuse_position(&fix(now, 0.0, -1.0)), Refusal::BadAccuracy),
        (
            e.fuse_position(&fix(now + 1_000_000, 0.0, 0.3)),
            Refusal::InFuture,
        ),
        (
            e.fuse_depth(&DepthFix {
                t_us: now,
                depth_m: f32::INFINITY,
                std_m: 0.005,
            }),
            Refusal::NonFinite,
        ),
        (
            e.fuse_dvl(&DvlFix {
                t_us: now,
                velocity_m_s: [50.0, 0.0],
                std_m_s: 0.01,
            }),
            Refusal::OutOfRange,
        ),
        (
            e.fuse_heading(&HeadingFix {
                t_us: now,
                yaw_rad: 0.0,
                std_rad: f32::NAN,
            }),
            Refusal::NonFinite,
        ),
        (e.predict(&imu(now), [0.0; 3]), Refusal::TooOld),
        (
            e.predict(
                &ImuSample {
                    gyro_rad_s: [f32::NAN, 0.0, 0.0],
                    ..imu(now + DT_US)
                },
                [0.0; 3],
            ),
            Refusal::NonFinite,
        ),
    ];
    for (i, (got, want)) in cases.iter().enumerate() {
        assert_eq!(*got, Err(*want), "case {i}");
    }
    assert_eq!(
        e.predict(&imu(now + 300_000), [0.0; 3]),
        Err(Refusal::ImuGap)
    );
    assert_eq!(
        e.predict(&imu(now + DT_US), [f32::NAN; 3]),
        Err(Refusal::NonFinite)
    );
    assert_eq!((e.state(), e.position_covariance()), before);
    assert_eq!(e.time_us(), now);
    assert_eq!(e.health().invalid, 12);
}

#[test]
fn a_fix_older_than_the_history_is_refused() {
    let mut e = at_rest();
    let span_s = (HISTORY_LEN as u64 * HISTORY_STEP_US) as f32 * 1e-6;
    fly(&mut e, (span_s / 0.01) as u64 + 100, 0.0);
    let r = e.fuse_position(&PositionFix {
        t_us: e.time_us() - (HISTORY_LEN as u64 + 5) * HISTORY_STEP_US,
        north_m: 0.0,
        east_m: 0.0,
        std_m: 0.3,
    });
    assert_eq!(r, Err(Refusal::TooOld));
}

#[test]
fn a_late_fix_is_compared_with_the_estimate_at_its_time_of_validity() {
    // Two identical estimators cruise north; each gets a fix 1 m ahead of where it was at
    // some time. Fused at its time of validity, a fix taken 0.5 s ago that agrees with the
    // estimate of 0.5 s ago changes nothing; the same numbers stamped "now" would pull the
    // estimate back by the distance run in 0.5 s.
    let mut a = at_rest();
    fly(&mut a, 2000, 3.0);
    let speed = a.state().u_m_s;
    assert!(speed > 0.2, "cruise speed {speed}");
    let t_then = a.time_us() - 500_000;
    let mut b = a.clone();
    // Where the estimate was 0.5 s ago: now minus the distance run.
    let north_then = a.state().x_m - 0.5 * speed;
    let fix_then = PositionFix {
        t_us: t_then,
        north_m: north_then,
        east_m: 0.0,
        std_m: 0.05,
    };
    let x_before = a.state().x_m;
    a.fuse_position(&fix_then).unwrap();
    assert!(
        (a.state().x_m - x_before).abs() < 0.01,
        "a consistent late fix moved the estimate by {}",
        a.state().x_m - x_before
    );
    let stamped_now = PositionFix {
        t_us: b.time_us(),
        ..fix_then
    };
    b.fuse_position(&stamped_now).unwrap();
    assert!(
        b.state().x_m < x_before - 0.05,
        "the same fix stamped now should pull back: {} -> {}",
        x_before,
        b.state().x_m
    );
}

#[test]
fn an_outlier_is_gated_and_counted_and_a_cluster_of_agreeing_ones_moves_the_position() {
    let mut e = at_rest();
    fly(&mut e, 200, 0.0);
    let fix = |t_us| PositionFix {
        t_us,
        north_m: 15.0,
        east_m: 0.0,
        std_m: 0.3,
    };
    let before = e.state();
    assert_eq!(e.fuse_position(&fix(e.time_us())), Err(Refusal::Outlier));
    assert_eq!(e.state(), before);
    assert_eq!(e.health().position_outliers, 1);
    for k in 1..CLUSTER_MIN - 1 {
        fly(&mut e, 100, 0.0);
        assert_eq!(
            e.fuse_position(&fix(e.time_us())),
            Err(Refusal::Outlier),
            "{k}"
        );
    }
    fly(&mut e, 100, 0.0);
    // The fifth that agrees with the others: the estimate, not the sensor, is wrong.
    assert_eq!(e.fuse_position(&fix(e.time_us())), Ok(()));
    assert!((e.state().x_m - 15.0).abs() < 0.01, "{:?}", e.state());
    assert_eq!(e.health().resets, 1);
    assert!((e.position_covariance()[0][0] - 0.09).abs() < 1e-3);
}

#[test]
fn usbl_fixes_pull_a_wrong_start_toward_the_truth_within_the_fixes_accuracy() {
    // Start 2 m off; 60 fixes of the true position (0, 0) with 0.3 m noise (a fixed pattern).
    let mut e = Estimator::new(
        Vehicle::observer(),
        NavConfig {
            initial_position_std_m: 2.0,
            ..NavConfig::default()
        },
        &NavState {
            x_m: 2.0,
            z_m: 2.0,
            ..NavState::default()
        },
        0,
    )
    .unwrap();
    let noise = [0.3f32, -0.2, 0.1, -0.35, 0.25, -0.05];
    for k in 0..60usize {
        fly(&mut e, 100, 0.0);
        e.fuse_position(&PositionFix {
            t_us: e.time_us() - 500_000,
            north_m: noise[k % 6],
            east_m: -noise[(k + 3) % 6],
            std_m: 0.3,
        })
        .unwrap();
    }
    let s = e.state();
    let sd = e.position_covariance()[0][0].sqrt();
    assert!(s.x_m.abs() < 0.15 && s.y_m.abs() < 0.15, "{s:?}");
    assert!(sd < 0.15, "std {sd}");
}

#[test]
fn the_configuration_is_validated_by_name() {
    let bad = NavConfig {
        tilt_time_constant_s: 0.0,
        ..NavConfig::default()
    };
    let e = Estimator::new(Vehicle::observer(), bad, &NavState::default(), 0).unwrap_err();
    assert_eq!(format!("{e}"), "tilt_time_constant_s must be > 0");
    let bad = NavConfig {
        model_accel_noise_m_s2_sqrt_hz: f32::NAN,
        ..NavConfig::default()
    };
    assert!(Estimator::new(Vehicle::observer(), bad, &NavState::default(), 0).is_err());
    let nan_start = NavState {
        x_m: f32::NAN,
        ..NavState::default()
    };
    assert!(Estimator::new(Vehicle::observer(), NavConfig::default(), &nan_start, 0).is_err());
}

/// A fix `dist_m` from the origin in the direction `k` times the golden angle.
fn scattered(t_us: u64, k: u32, dist_m: f32) -> PositionFix {
    let a = k as f32 * 2.399_963;
    PositionFix {
        t_us,
        north_m: dist_m * a.cos(),
        east_m: dist_m * a.sin(),
        std_m: 0.3,
    }
}

#[test]
fn outliers_that_do_not_agree_with_each_other_never_move_the_estimate_however_many() {
    let mut e = at_rest();
    fly(&mut e, 200, 0.0);
    // Two fixes in three are outliers 10-19 m off in scattered directions (the majority),
    // every third a true fix at the origin.
    for k in 0..90 {
        fly(&mut e, 100, 0.0);
        if k % 3 == 2 {
            e.fuse_position(&scattered(e.time_us(), k, 0.0)).unwrap();
        } else {
            let d = 10.0 + (k % 7) as f32 * 1.5;
            assert_eq!(
                e.fuse_position(&scattered(e.time_us(), k, d)),
                Err(Refusal::Outlier),
                "{k}"
            );
        }
        let s = e.state();
        assert!(s.x_m.abs() < 1e-3 && s.y_m.abs() < 1e-3, "{k}: {s:?}");
    }
    assert_eq!(e.health().resets, 0);
    assert_eq!(e.health().position_outliers, 60);
}

#[test]
fn a_persistent_step_is_followed_through_outliers_and_a_minority_of_agreeing_ones_is_not() {
    let mut e = at_rest();
    fly(&mut e, 200, 0.0);
    // True fixes at the origin, with every third an outlier 3 m north: the outliers agree
    // with each other but are the minority, so the estimate stays.
    for k in 0..30u32 {
        fly(&mut e, 100, 0.0);
        let n = if k % 3 == 0 {
            3.0
        } else {
            0.05 * ((k % 5) as f32 - 2.0)
        };
        let _ = e.fuse_position(&PositionFix {
            t_us: e.time_us(),
            north_m: n,
            east_m: 0.0,
            std_m: 0.3,
        });
        assert!(e.state().x_m.abs() < 0.2, "{k}: {:?}", e.state());
    }
    assert_eq!(e.health().resets, 0);
    // Then the transceiver moves 3 m east: every fix after is 3 m off (with noise), with a
    // far outlier every fourth fix. Followed within CLUSTER_MIN agreeing fixes plus the
    // outliers between them.
    let mut followed_after = None;
    for k in 0..30u32 {
        fly(&mut e, 100, 0.0);
        let fix = if k % 4 == 3 {
            scattered(e.time_us(), k, 15.0)
        } else {
            PositionFix {
                t_us: e.time_us(),
                north_m: 0.1 * ((k % 3) as f32 - 1.0),
                east_m: 3.0 + 0.1 * ((k % 5) as f32 - 2.0),
                std_m: 0.3,
            }
        };
        let _ = e.fuse_position(&fix);
        if followed_after.is_none() && (e.state().y_m - 3.0).abs() < 0.3 {
            followed_after = Some(k + 1);
        }
    }
    let n = followed_after.expect("the step was never followed");
    assert!(n as usize <= CLUSTER_MIN + 2, "followed after {n} fixes");
    assert_eq!(e.health().resets, 1);
    assert!((e.state().y_m - 3.0).abs() < 0.2, "{:?}", e.state());
}

#[test]
fn an_uncertain_start_is_not_ready_for_position_modes_until_the_fixes_say_where_it_is() {
    // The launch point known to 5 m and the heading to 0.6 rad (the estimator is told both
    // 5 m and 30 degrees off; the compass reads north).
    let start = NavState {
        x_m: 5.0,
        z_m: 2.0,
        yaw_rad: 0.52,
        ..NavState::default()
    };
    let cfg = NavConfig {
        initial_position_std_m: 5.0,
        initial_heading_std_rad: 0.6,
        ..NavConfig::default()
    };
    let mut e = Estimator::new(Vehicle::observer(), cfg, &start, 0).unwrap();
    assert_eq!(e.position_ready(), Err(NotReady::PositionUncertain));
    // The compass alone: the heading comes to north, the position stays unknown.
    fly(&mut e, 100, 0.0);
    assert!(e.state().yaw_rad.abs() < 0.15, "{:?}", e.state());
    assert_eq!(e.position_ready(), Err(NotReady::PositionUncertain));
    let mut ready_after = None;
    for k in 0..30u32 {
        fly(&mut e, 100, 0.0);
        e.fuse_position(&PositionFix {
            t_us: e.time_us(),
            north_m: 0.1 * ((k % 5) as f32 - 2.0),
            east_m: 0.0,
            std_m: 0.3,
        })
        .unwrap();
        if ready_after.is_none() && e.position_ready().is_ok() {
            ready_after = Some(k + 1);
        }
    }
    let n = ready_after.expect("never ready");
    assert!(n <= 3, "ready after {n} fixes");
    let std = e.position_covariance()[0][0].sqrt();
    assert!(std < POSITION_READY_STD_M, "{std}");
    assert!(e.state().x_m.abs() < 0.2, "{:?}", e.state());
    // A known heading but an unknown one: not ready for the heading's sake.
    let e = Estimator::new(
        Vehicle::observer(),
        NavConfig {
            initial_heading_std_rad: 0.6,
            ..NavConfig::default()
        },
        &start,
        0,
    )
    .unwrap();
    assert_eq!(e.position_ready(), Err(NotReady::HeadingUncertain));
}
