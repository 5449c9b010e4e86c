//! The ranges against the discrete loop they are derived from, simulated.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use super::*;

/// The largest error magnitude in the last fifth of a simulated run of the discrete PID loop
/// on a double integrator (`e'' = a`), the acceleration held for `t_s` and computed from the
/// state one period earlier, over the first fifth's: below 1 when the loop decays. Starts at
/// a unit error, at rest. The integral is the law's (`I += e T`, then used).
fn decay_ratio(kp: f32, kd: f32, ki: f32, t_s: f32, duration_s: f32) -> f64 {
    let (kp, kd, ki, t) = (f64::from(kp), f64::from(kd), f64::from(ki), f64::from(t_s));
    let (mut e, mut v, mut i, mut a_held) = (1.0f64, 0.0f64, 0.0f64, 0.0f64);
    let n = (f64::from(duration_s) / t) as usize;
    let (mut first, mut last) = (0.0f64, 0.0f64);
    for k in 0..n {
        i += e * t;
        let a = -kp * e - kd * v - ki * i;
        // The force computed now acts from the next period (one period of delay).
        e += v * t + 0.5 * a_held * t * t;
        v += a_held * t;
        a_held = a;
        if k < n / 5 {
            first = first.max(e.abs());
        }
        if k >= n - n / 5 {
            last = last.max(e.abs());
        }
    }
    last / first
}

/// Sign changes of the velocity over a run (the loop ringing at the period: bang-bang once
/// the thrusters saturate).
fn velocity_sign_flips(kd: f32, t_s: f32, steps: usize) -> usize {
    let (kd, t) = (f64::from(kd), f64::from(t_s));
    let (mut v, mut a_held, mut flips) = (1.0f64, 0.0f64, 0);
    for _ in 0..steps {
        let a = -kd * v;
        let next = v + a_held * t;
        if next.signum() != v.signum() && next != 0.0 {
            flips += 1;
        }
        v = next;
        a_held = a;
    }
    flips
}

#[test]
fn the_defaults_are_within_every_range() {
    assert_eq!(check_tracking(&TrackingGains::DEFAULT), Ok(()));
    assert_eq!(
        check_paper(&PaperXzGains::PAPER, &PaperXyGains::PAPER),
        Ok(())
    );
}

#[test]
fn the_constants_are_the_derivation() {
    assert_eq!(RATE_GAIN_MAX, 12.5);
    assert_eq!(POSITION_GAIN_MAX, 156.25);
    assert!((INTEGRAL_GAIN_MAX - 488.28125).abs() < 1e-3);
    assert!((RATE_GAIN_MIN - 0.1).abs() < 1e-7);
    assert!((POSITION_GAIN_MIN - 0.01).abs() < 1e-8);
    assert!((INTEGRAL_GAIN_MIN - 0.001).abs() < 1e-9);
}

#[test]
fn the_velocity_loop_rings_above_the_rate_bound_and_not_at_it() {
    let t = CONTROL_PERIOD_S;
    // With one period of delay: real poles up to k_d T = 1/4, no sign flip.
    assert_eq!(velocity_sign_flips(RATE_GAIN_MAX, t, 400), 0);
    // Complex poles above: the velocity rings (8 s).
    assert!(velocity_sign_flips(0.5 / t, t, 400) >= 20);
    // 999 (k_d T = 20): growing, a flip about every other period.
    assert!(velocity_sign_flips(999.0, t, 400) >= 160);
}

#[test]
fn every_accepted_pid_loop_decays_and_the_refused_ends_do_not() {
    let t = CONTROL_PERIOD_S;
    let grid = |lo: f32, hi: f32, n: usize| -> Vec<f32> {
        (0..n)
            .map(|k| lo * (hi / lo).powf(k as f32 / (n - 1) as f32))
            .collect()
    };
    let mut accepted = 0;
    let mut worst = 0.0f64;
    for &kp in &grid(POSITION_GAIN_MIN, POSITION_GAIN_MAX, 9) {
        for &kd in &grid(RATE_GAIN_MIN, RATE_GAIN_MAX, 9) {
            for &ki in &grid(INTEGRAL_GAIN_MIN, INTEGRAL_GAIN_MAX, 9) {
                let mut g = TrackingGains::DEFAULT;
                (g.depth_kp, g.depth_kd, g.depth_ki) = (kp, kd, ki);
                if check_tracking(&g).is_err() {
                    continue;
                }
                accepted += 1;
                // Long enough for the slowest pole: about k_p / k_d for a loop with much
                // more damping than stiffness; for a ringing one the damping left after the
                // delay and the integral, at least (k_p T / 2 + 3 k_i / k_p) / 2.
                let left = 0.25 * kp * t + 1.5 * ki / kp;
                let r = decay_ratio(kp, kd, ki, t, 60.0 + 20.0 * kd / kp + 10.0 / left);
                worst = worst.max(r);
                assert!(r < 0.5, "kp {kp} kd {kd} ki {ki}: ratio {r}");
            }
        }
    }
    println!("{accepted} accepted combinations, worst decay ratio {worst:.3e}");
    assert!(accepted >= 40, "{accepted}");
    // Outside: k_d T = 1.5 (unstable from 1 with one period of delay), and past the Routh
    // edge k_i = k_p k_d.
    assert!(decay_ratio(3.0, 1.5 / t, 1.0, t, 60.0) > 1.0);
    assert!(decay_ratio(3.0, 3.0, 9.5, t, 600.0) > 1.0);
    // 999 and a switched-off rate gain with an integral.
    assert!(decay_ratio(3.0, 999.0, 1.0, t, 8.0) > 1.0);
    assert!(decay_ratio(3.0, 1.0e-30, 1.0, t, 600.0) > 1.0);
}

#[test]
fn out_of_range_gains_are_refused_naming_the_range() {
    type Set = fn(&mut TrackingGains, f32);
    let gains: [(&str, Set); 13] = [
        ("xy_kp", |g, v| g.xy_kp = v),
        ("xy_kd", |g, v| g.xy_kd = v),
        ("xy_ki", |g, v| g.xy_ki = v),
        ("xz_kp", |g, v| g.xz_kp = v),
        ("xz_kd", |g, v| g.xz_kd = v),
        ("xz_ki", |g, v| g.xz_ki = v),
        ("depth_kp", |g, v| g.depth_kp = v),
        ("depth_kd", |g, v| g.depth_kd = v),
        ("depth_ki", |g, v| g.depth_ki = v),
        ("pitch_kp", |g, v| g.pitch_kp = v),
        ("pitch_kd", |g, v| g.pitch_kd = v),
        ("yaw_kp", |g, v| g.yaw_kp = v),
        ("yaw_kd", |g, v| g.yaw_kd = v),
    ];
    for (name, set) in gains {
        for v in [999.0, 1.0e-30] {
            let mut g = TrackingGains::DEFAULT;
            set(&mut g, v);
            match check_tracking(&g) {
                Err(Error::GainRange {
                    name: n,
                    value,
                    min,
                    max,
                }) => {
                    assert_eq!((n, value), (name, v), "{name} = {v}");
                    assert!(min > 0.0 && min <= max && (v < min || v > max), "{name}");
                }
                other => panic!("{name} = {v}: {other:?}"),
            }
        }
    }
    // A coupled range: xy_kd = 0.5 with xy_kp = 1 and xy_ki = 0.15 needs
    // k_d >= 2 k_p T + 4 k_i / k_p = 0.64.
    let g = TrackingGains {
        xy_kd: 0.5,
        ..TrackingGains::DEFAULT
    };
    let e = check_tracking(&g).unwrap_err();
    match e {
        Error::GainRange {
            name: "xy_kd",
            min,
            max,
            ..
        } => assert!((min - 0.64).abs() < 1e-6 && max == 12.5, "{e:?}"),
        other => panic!("{other:?}"),
    }
    let text = e.to_string();
    assert!(
        text.contains("xy_kd = 0.5 is outside 0.640..=12.500"),
        "{text}"
    );
}

#[test]
fn the_paper_laws_first_order_gains_are_held_to_the_rate_range() {
    let xy = PaperXyGains {
        c1u: 999.0,
        ..PaperXyGains::PAPER
    };
    assert!(matches!(
        check_paper(&PaperXzGains::PAPER, &xy),
        Err(Error::GainRange {
            name: "paper_xy.c1u",
            ..
        })
    ));
    let xz = PaperXzGains {
        k: 1.0e-30,
        ..PaperXzGains::PAPER
    };
    assert!(matches!(
        check_paper(&xz, &PaperXyGains::PAPER),
        Err(Error::GainRange {
            name: "paper_xz.k",
            ..
        })
    ));
}
