//! The parameter list: names, checks, the saved file.

use super::*;
use crate::surface::params_file::{load, save, saved_system_id};

#[test]
fn names_fit_mavlink_and_are_unique() {
    for (i, p) in PARAMS.iter().enumerate() {
        assert!(p.name.len() <= 16, "{}", p.name);
        assert!(
            PARAMS[i + 1..].iter().all(|q| q.name != p.name),
            "{}",
            p.name
        );
    }
}

#[test]
fn defaults_pass_every_check_and_round_trip_the_failsafe() {
    let s = Settings::new(VehicleParams::OBSERVER);
    for group in GROUPS {
        s.check(group).unwrap();
    }
    assert_eq!(s.failsafe.to_firmware().unwrap(), Failsafe::DEFAULT);
    assert_eq!(
        group(&PARAMS[find("VEH_PWM_MAX").unwrap().0]),
        Group::Vehicle
    );
    assert_eq!(
        group(&PARAMS[find("FS_NAV_STALE").unwrap().0]),
        Group::Failsafe
    );
    assert_eq!(group(&PARAMS[find("PXY_C4").unwrap().0]), Group::Paper);
}

#[test]
fn the_passkey_is_a_whole_number_and_0_means_no_takeover() {
    let mut s = Settings::new(VehicleParams::OBSERVER);
    assert_eq!(s.passkey(), None);
    s.control_passkey = 4321.0;
    s.check(Group::Control).unwrap();
    assert_eq!(s.passkey().as_deref(), Some("4321"));
    for bad in [0.5, -1.0, 1e6, f32::NAN] {
        s.control_passkey = bad;
        assert!(s.check(Group::Control).is_err(), "{bad}");
    }
    assert_eq!(
        group(&PARAMS[find("CTRL_PASSKEY").unwrap().0]),
        Group::Control
    );
    let (a, mut b) = (
        Settings::new(VehicleParams::OBSERVER),
        Settings::new(VehicleParams::OBSERVER),
    );
    b.vehicle.mass_kg += 1.0;
    assert!(a.same_group(&b, Group::Tracking) && !a.same_group(&b, Group::Vehicle));
}

#[test]
fn ardusubs_names_are_the_same_settings() {
    let mut s = Settings::new(VehicleParams::OBSERVER);
    let (_, wpnav) = find("WPNAV_SPEED").unwrap();
    (wpnav.set)(&mut s, 35.0);
    assert!((s.mission_speed_m_s - 0.35).abs() < 1e-6);
    assert_eq!(group(wpnav), Group::Mission);
    let (_, fs) = find("FS_PILOT_TIMEOUT").unwrap();
    (fs.set)(&mut s, 0.8);
    assert_eq!(s.failsafe.pilot_stale_s, 0.8);
    assert!(read_only("ARMING_CHECK").is_some());
    assert_eq!(count(), all().count());
    assert!(all().all(|p| p.name.len() <= 16));
}

#[test]
fn every_parameter_reads_back_what_was_written() {
    let mut g = Settings::new(VehicleParams::OBSERVER);
    for (i, p) in PARAMS.iter().enumerate() {
        (p.set)(&mut g, 100.0 + i as f32);
    }
    for (i, p) in PARAMS.iter().enumerate() {
        // An ArduSub name of the same setting reads the latest write.
        if PARAMS[i + 1..].iter().any(|q| (q.get)(&g) == (p.get)(&g)) {
            continue;
        }
        assert_eq!((p.get)(&g), 100.0 + i as f32, "{}", p.name);
    }
}

#[test]
fn a_saved_file_loads_back_and_a_bad_one_is_refused_by_name() {
    let dir = std::env::temp_dir().join(format!("rov-params-{}", std::process::id()));
    let path = dir.join("p.json");
    let defaults = Settings::new(VehicleParams::OBSERVER);
    let mut g = defaults;
    g.gains.tracking.xy_kp *= 1.5;
    g.vehicle.mass_kg = 12.5;
    g.failsafe.pilot_stale_s = 0.8;
    save(&path, &g).unwrap();
    assert_eq!(load(&path, defaults).unwrap(), g);
    std::fs::write(&path, r#"{"TRK_NOPE": 1.0}"#).unwrap();
    assert!(format!("{:#}", load(&path, defaults).unwrap_err()).contains("TRK_NOPE"));
    for bad in [
        r#"{"TRK_XY_KP": -1.0}"#,
        r#"{"VEH_BUOY": 9.0}"#,
        r#"{"FS_HB_NEUTRAL": 3.0}"#,
        r#"{"FS_HB_DISARM": 0.3}"#,
    ] {
        std::fs::write(&path, bad).unwrap();
        let e = format!("{:#}", load(&path, defaults).unwrap_err());
        assert!(e.contains("refused"), "{bad}: {e}");
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn health_and_surface_parameters_save_load_and_name_their_groups() {
    let dir = std::env::temp_dir().join(format!("rov-params-health-{}", std::process::id()));
    let path = dir.join("p.json");
    let defaults = Settings::new(VehicleParams::OBSERVER);
    for (name, g) in [
        ("BATT_LOW_VOLT", Group::Health),
        ("FS_LEAK_ENABLE", Group::Health),
        ("FS_PRESS_MAX", Group::Health),
        ("DEPTH_LIMIT_M", Group::Health),
        ("FS_GCS_ENABLE", Group::Surface),
        ("PILOT_SPEED_UP", Group::Surface),
        ("SYSID_THISMAV", Group::Surface),
        ("FS_HB_DISARM", Group::Failsafe),
    ] {
        assert_eq!(group(find(name).unwrap().1), g, "{name}");
    }
    let mut g = defaults;
    g.health.low_volt = 14.5;
    g.health.depth_limit_m = 20.0;
    g.surface.gcs_enable = 2.0;
    g.surface.sysid_thismav = 2.0;
    save(&path, &g).unwrap();
    assert_eq!(load(&path, defaults).unwrap(), g);
    assert_eq!(saved_system_id(&path), Some(2));
    for bad in [
        r#"{"BATT_CRT_VOLT": 15.0, "BATT_LOW_VOLT": 14.0}"#,
        r#"{"SYSID_THISMAV": 0.0}"#,
    ] {
        std::fs::write(&path, bad).unwrap();
        let e = format!("{:#}", load(&path, defaults).unwrap_err());
        assert!(e.contains("refused"), "{bad}: {e}");
    }
    // No id saved, or one out of range: none.
    assert_eq!(saved_system_id(&path), None);
    std::fs::write(&path, r#"{"TRK_XY_KP": 1.0}"#).unwrap();
    assert_eq!(saved_system_id(&path), None);
    assert_eq!(saved_system_id(&dir.join("absent.json")), None);
    let _ = std::fs::remove_dir_all(dir);
}
