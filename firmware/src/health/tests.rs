use super::*;

const MS: u64 = 1_000;

fn params() -> HealthParams {
    HealthParams {
        batt_low_volt: 14.0,
        batt_crt_volt: 13.0,
        batt_low_mah: 3_000.0,
        batt_crt_mah: 1_000.0,
        ..HealthParams::DEFAULT
    }
}

/// The pin voltages the power-sense module gives for `volts` and `amps`.
fn sample(p: &HealthParams, volts: f32, amps: f32) -> HealthSample {
    HealthSample {
        volt_pin_v: Some(volts / p.batt_volt_mult),
        curr_pin_v: Some(amps / p.batt_amp_pervlt + p.batt_amp_offset_v),
        ..HealthSample::default()
    }
}

/// Run the monitor every 10 ms from `t0_us` for `dur_us`; the first action and its time.
fn run(
    m: &mut HealthMonitor,
    t0_us: u64,
    dur_us: u64,
    s: &HealthSample,
) -> Option<(u64, FailsafeAction)> {
    let mut first = None;
    let mut t = t0_us;
    while t <= t0_us + dur_us {
        let r = m.update(t, s);
        if first.is_none() && r.action != FailsafeAction::None {
            first = Some((t, r.action));
        }
        t += 10 * MS;
    }
    first
}

#[test]
fn the_power_sense_scales_give_volts_and_amps() {
    let p = params();
    let mut m = HealthMonitor::new(p).unwrap();
    let r = m.update(0, &sample(&p, 15.2, 12.5));
    assert!(
        (r.battery.voltage_v - 15.2).abs() < 1e-3,
        "{}",
        r.battery.voltage_v
    );
    assert!(
        (r.battery.current_a - 12.5).abs() < 1e-3,
        "{}",
        r.battery.current_a
    );
    assert_eq!(r.faults, 0);
    assert_eq!(r.action, FailsafeAction::None);
}

#[test]
fn low_voltage_warns_after_the_timer_and_critical_surfaces_within_a_second() {
    let p = params();
    let mut m = HealthMonitor::new(p).unwrap();
    assert_eq!(run(&mut m, 0, 1_000 * MS, &sample(&p, 15.0, 5.0)), None);
    // Low: 13.5 V; the warning after BATT_LOW_TIMER (0.5 s), not before.
    let (t, a) = run(&mut m, 1_010 * MS, 2_000 * MS, &sample(&p, 13.5, 5.0)).unwrap();
    assert_eq!(a, FailsafeAction::Warn);
    let delay = t - 1_010 * MS;
    assert!((500 * MS..=520 * MS).contains(&delay), "{delay}");
    assert_ne!(m.latest().faults & fault::BATTERY_LOW, 0);
    // Critical: 12.5 V; surface, once, within 1 s.
    let t0 = 3_020 * MS;
    let (t, a) = run(&mut m, t0, 2_000 * MS, &sample(&p, 12.5, 5.0)).unwrap();
    assert_eq!(a, FailsafeAction::Surface);
    assert!(t - t0 <= 1_000 * MS, "{}", t - t0);
    assert_eq!(m.latest().faults & HEALTH_FAULTS, fault::BATTERY_CRITICAL);
    // Latched: back at 15 V it stays critical, and the action is not repeated.
    assert_eq!(
        run(&mut m, 5_100 * MS, 1_000 * MS, &sample(&p, 15.0, 0.0)),
        None
    );
    assert_ne!(m.latest().faults & fault::BATTERY_CRITICAL, 0);
}

#[test]
fn a_sag_shorter_than_the_timer_is_not_low() {
    let p = params();
    let mut m = HealthMonitor::new(p).unwrap();
    for k in 0..100u64 {
        // 0.4 s under, 0.2 s over, repeated.
        let v = if k % 60 < 40 { 12.0 } else { 15.0 };
        let r = m.update(k * 10 * MS, &sample(&p, v, 40.0));
        assert_eq!(r.faults, 0, "at step {k}");
    }
}

#[test]
fn consumed_mah_integrates_the_current_and_drives_the_mah_thresholds() {
    let p = HealthParams {
        batt_capacity_mah: 1_000.0,
        batt_low_mah: 300.0,
        batt_crt_mah: 100.0,
        ..HealthParams::DEFAULT
    };
    let mut m = HealthMonitor::new(p).unwrap();
    // 36 A for 60 s is 600 mAh: 400 left, still normal.
    let s = sample(&p, 15.0, 36.0);
    let mut actions = Vec::new();
    let mut t = 0;
    while t <= 60_000 * MS {
        m.update(t, &s);
        t += 10 * MS;
    }
    let b = m.latest().battery;
    assert!((b.consumed_mah - 600.0).abs() < 1.0, "{}", b.consumed_mah);
    assert!((b.remaining_pct - 40.0).abs() < 0.2, "{}", b.remaining_pct);
    // Time left at 36 A: 400 mAh is 40 s at a constant current; at constant power from
    // 15 V down to the empty 12 V, the mean voltage to come is 13.5 V: 36 s.
    let left = b.time_remaining_s.unwrap();
    assert!((left - 36.0).abs() < 0.5, "{left}");
    assert_eq!(m.latest().faults, 0);
    // 20 s more: low (300 left) at ~70 s, critical (100 left) at ~90 s.
    while t <= 100_000 * MS {
        let r = m.update(t, &s);
        if r.action != FailsafeAction::None {
            actions.push((t, r.action));
        }
        t += 10 * MS;
    }
    assert_eq!(actions.len(), 2, "{actions:?}");
    let (t_low, a_low) = actions[0];
    let (t_crt, a_crt) = actions[1];
    assert_eq!(a_low, FailsafeAction::Warn);
    assert_eq!(a_crt, FailsafeAction::Surface);
    assert!((t_low as f32 * 1e-6 - 70.0).abs() < 0.1, "{t_low}");
    assert!((t_crt as f32 * 1e-6 - 90.0).abs() < 0.1, "{t_crt}");
}

#[test]
fn leak_counts_after_its_debounce_and_surfaces_within_half_a_second() {
    let p = params();
    let mut m = HealthMonitor::new(p).unwrap();
    let dry = sample(&p, 15.0, 5.0);
    let wet = HealthSample {
        leak_wet: true,
        ..dry
    };
    assert_eq!(run(&mut m, 0, 500 * MS, &dry), None);
    // A 150 ms splash does not count.
    assert_eq!(run(&mut m, 510 * MS, 150 * MS, &wet), None);
    assert_eq!(run(&mut m, 670 * MS, 500 * MS, &dry), None);
    // Wet from 1.18 s: surface after the 0.2 s debounce (<= 0.5 s).
    let t0 = 1_180 * MS;
    let (t, a) = run(&mut m, t0, 1_000 * MS, &wet).unwrap();
    assert_eq!(a, FailsafeAction::Surface);
    let delay = t - t0;
    assert!(
        (LEAK_CONFIRM_US..=LEAK_CONFIRM_US + 10 * MS).contains(&delay),
        "{delay}"
    );
    assert!(delay <= 500 * MS);
    assert_eq!(m.latest().faults & HEALTH_FAULTS, fault::LEAK);
}

#[test]
fn the_leak_action_follows_fs_leak_enable() {
    for (enable, expect) in [
        (0, None),
        (1, Some(FailsafeAction::Warn)),
        (2, Some(FailsafeAction::Surface)),
    ] {
        let p = HealthParams {
            fs_leak_enable: FailsafeAction::from_leak_enable(enable).unwrap(),
            ..params()
        };
        let mut m = HealthMonitor::new(p).unwrap();
        let wet = HealthSample {
            leak_wet: true,
            ..sample(&p, 15.0, 5.0)
        };
        assert_eq!(run(&mut m, 0, 1_000 * MS, &wet).map(|(_, a)| a), expect);
    }
    assert_eq!(FailsafeAction::from_leak_enable(3), None);
}

#[test]
fn enclosure_pressure_and_temperature_warn_after_two_seconds() {
    let p = params();
    let mut m = HealthMonitor::new(p).unwrap();
    let hot = HealthSample {
        enclosure_c: Some(70.0),
        enclosure_pa: Some(101_000.0),
        ..sample(&p, 15.0, 5.0)
    };
    let (t, a) = run(&mut m, 0, 3_000 * MS, &hot).unwrap();
    assert_eq!(a, FailsafeAction::Warn);
    assert_eq!(t, ENCLOSURE_CONFIRM_US);
    let pressed = HealthSample {
        enclosure_pa: Some(110_000.0),
        ..sample(&p, 15.0, 5.0)
    };
    let mut m = HealthMonitor::new(p).unwrap();
    assert!(run(&mut m, 0, 3_000 * MS, &pressed).is_some());
    assert_eq!(m.latest().faults & HEALTH_FAULTS, fault::ENCLOSURE);
}

#[test]
fn a_new_event_acts_but_one_that_holds_does_not_act_again() {
    let p = params();
    let mut m = HealthMonitor::new(p).unwrap();
    let crit = sample(&p, 12.0, 5.0);
    let (_, a) = run(&mut m, 0, 1_000 * MS, &crit).unwrap();
    assert_eq!(a, FailsafeAction::Surface);
    // The pilot took over; the enclosure warning that starts later only warns.
    let hot = HealthSample {
        enclosure_c: Some(80.0),
        ..crit
    };
    let (_, a) = run(&mut m, 1_010 * MS, 3_000 * MS, &hot).unwrap();
    assert_eq!(a, FailsafeAction::Warn);
}

#[test]
fn the_depth_limit_warns_at_90_percent_and_caps_heave() {
    let p = HealthParams {
        depth_limit_m: 10.0,
        ..params()
    };
    let mut m = HealthMonitor::new(p).unwrap();
    let at = |d: f32| HealthSample {
        depth_m: Some(d),
        ..sample(&p, 15.0, 5.0)
    };
    assert_eq!(m.update(0, &at(8.9)).faults, 0);
    let r = m.update(10 * MS, &at(9.0));
    assert_eq!(r.faults, fault::DEPTH_LIMIT);
    assert_eq!(r.action, FailsafeAction::Warn);
    let lim = m.depth_limit().unwrap();
    assert!(lim.refuses(10.5));
    assert!(!lim.refuses(9.5));
    assert!(lim.refuses(f32::NAN));
    // Far above: a full downward command passes; at the limit at rest: no downward thrust;
    // descending onto it: an upward push; an upward command is never changed.
    assert_eq!(lim.cap(40.0, 2.0, 0.0, 40.0), 40.0);
    assert!(lim.cap(40.0, 10.0, 0.0, 40.0) <= 0.0);
    assert!(lim.cap(40.0, 9.8, 0.3, 40.0) < 0.0);
    assert_eq!(lim.cap(-30.0, 10.5, 0.0, 40.0), -30.0);
    assert_eq!(DepthLimit::new(0.0), None);
}

#[test]
fn bad_parameters_are_refused_and_change_nothing() {
    let mut m = HealthMonitor::new(params()).unwrap();
    let bad = [
        HealthParams {
            batt_volt_mult: f32::NAN,
            ..params()
        },
        HealthParams {
            batt_crt_volt: 15.0,
            ..params()
        },
        HealthParams {
            batt_capacity_mah: 0.0,
            ..params()
        },
        HealthParams {
            depth_limit_m: -1.0,
            ..params()
        },
    ];
    for b in bad {
        assert!(m.set_params(b).is_err(), "{b:?}");
        assert_eq!(*m.params(), params());
    }
}

#[test]
fn the_default_parameters_are_valid() {
    assert_eq!(HealthParams::DEFAULT.validate(), Ok(()));
    assert_eq!(
        *HealthMonitor::with_defaults().params(),
        *HealthMonitor::new(HealthParams::DEFAULT).unwrap().params()
    );
}
