//! Scenario files: the built-ins parse, defaults apply, and bad files give clear errors.

use sim_scenario::{ControllerKind, Plane, ReferenceSpec, Scenario, BUILT_IN};

fn err(text: &str) -> String {
    format!("{:#}", Scenario::from_toml(text, "test.toml").unwrap_err())
}

const MINIMAL: &str = r#"
name = "t"
plane = "xy"
controller = "paper"
duration_s = 5.0
[reference]
kind = "paper"
"#;

#[test]
fn planar_built_ins_parse() {
    for b in BUILT_IN {
        let s = toml::from_str::<Scenario>(b.toml).unwrap_or_else(|e| panic!("{}: {e}", b.name));
        assert_eq!(s.name, b.name, "file stem and name differ");
        if s.plane != Plane::ThreeD {
            Scenario::load(b.name).unwrap_or_else(|e| panic!("{}: {e:#}", b.name));
        }
    }
}

#[test]
fn defaults_apply() {
    let s = Scenario::from_toml(MINIMAL, "m").unwrap();
    assert_eq!(s.control_period_s, 0.01);
    assert_eq!(s.plant_dt_s, 0.001);
    assert_eq!(s.plant_steps_per_control(), 10);
    assert_eq!(s.controller, ControllerKind::Paper);
    assert_eq!(
        s.reference,
        ReferenceSpec::Paper {
            h_r_m: 10.0,
            t_f_s: 100.0
        }
    );
    assert!(s.thrusters.saturate);
    assert_eq!(
        s.initial.to_plant(),
        sim_world::plant::PlantState::default()
    );
    assert!(!s.disturbance.noise);
    assert_eq!(s.disturbance.delay_s, 0.0);
}

#[test]
fn unknown_keys_are_rejected_and_named() {
    let e = err(&format!(
        "{MINIMAL}\n[initial]\nx_m = 1.0\nroll_rad = 0.2\n"
    ));
    assert!(e.contains("roll_rad"), "{e}");
    let e = err(&MINIMAL.replace("duration_s", "duration"));
    assert!(e.contains("duration"), "{e}");
    let e = err(&format!("{MINIMAL}h_r = 3.0\n"));
    assert!(e.contains("h_r"), "{e}");
    let e = err(&format!(
        "{MINIMAL}\n[disturbance]\ncurrent = [0.1, 0.0, 0.0]\n"
    ));
    assert!(e.contains("current"), "{e}");
}

#[test]
fn bad_values_are_named() {
    let e = err(&MINIMAL.replace("duration_s = 5.0", "duration_s = -1.0"));
    assert!(e.contains("duration_s must be > 0"), "{e}");
    let e = err(&MINIMAL.replace("plane = \"xy\"", "plane = \"yz\""));
    assert!(e.contains("yz") && e.contains("xz"), "{e}");
    let e = err(&MINIMAL.replace("controller = \"paper\"", "controller = \"pid\""));
    assert!(e.contains("pid"), "{e}");
    let e = err(&MINIMAL.replace("kind = \"paper\"", "kind = \"spiral\""));
    assert!(e.contains("spiral"), "{e}");
    let e = err(&MINIMAL.replace(
        "duration_s = 5.0",
        "duration_s = 5.0\ncontrol_period_s = 0.0125",
    ));
    assert!(e.contains("whole multiple"), "{e}");
    let e = err(&MINIMAL.replace("plane = \"xy\"", "plane = \"3d\""));
    assert!(e.contains("no 3-D mode"), "{e}");
    let e = err(&format!("{MINIMAL}t_f_s = 0.0\n"));
    assert!(e.contains("reference.t_f_s must be > 0"), "{e}");
    let e = err(&format!("{MINIMAL}\n[disturbance]\ndelay_s = -0.1\n"));
    assert!(e.contains("disturbance.delay_s must be >= 0"), "{e}");
    let e = err(&format!(
        "{MINIMAL}\n[disturbance]\nbuoyancy_offset_n = 500.0\n"
    ));
    assert!(e.contains("buoyancy_offset_n"), "{e}");
    let e = err("name = \"x\"\nplane = \"xy\"\n");
    assert!(e.contains("missing field"), "{e}");
    let e = err(&MINIMAL.replace("name = \"t\"", "name = \"a b/c\""));
    assert!(e.contains("may contain only"), "{e}");
}

#[test]
fn load_reports_unknown_names() {
    let e = format!("{:#}", Scenario::load("no-such-scenario").unwrap_err());
    assert!(e.contains("paper-xz"), "lists the built-ins: {e}");
    let e = format!(
        "{:#}",
        Scenario::load("/nonexistent/file.toml").unwrap_err()
    );
    assert!(e.contains("cannot read"), "{e}");
}

#[test]
fn every_reference_kind_parses_with_defaults() {
    for (kind, extra) in [
        ("hold", ""),
        ("line", "heading_rad = 0.5"),
        ("circle", "radius_m = 3.0"),
        ("lawnmower", "legs = 2"),
        ("helix", "depth_rate_m_s = 0.1"),
    ] {
        let text = format!(
            "name = \"k\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 1.0\n[reference]\nkind = \"{kind}\"\n{extra}\n"
        );
        let s: Scenario = toml::from_str(&text).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(s.reference.kind(), kind);
    }
}

/// A line's speed is checked once, by the core's `Reference::validate`: the scenario file and
/// the core refuse the same speeds (0 and below) with the same words, and accept the same.
#[test]
fn line_speed_is_refused_by_the_scenario_as_by_the_core() {
    use controller_core::reference::Reference;
    use controller_core::Error;
    let line = |speed: &str| {
        format!(
            "name = \"l\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 1.0\n\
             [reference]\nkind = \"line\"\nspeed_m_s = {speed}\n"
        )
    };
    let core = |speed_m_s: f32| {
        Reference::Line {
            start_m: [0.0; 3],
            heading_rad: 0.0,
            speed_m_s,
        }
        .validate()
    };
    for (text, value) in [("0.0", 0.0_f32), ("-0.2", -0.2)] {
        let core_err = core(value).unwrap_err();
        assert_eq!(
            core_err,
            Error::NotPositive("speed_m_s"),
            "core, speed {text}"
        );
        let e = err(&line(text));
        assert!(
            e.contains(&format!("reference.{core_err}")),
            "speed {text}: the scenario's refusal is the core's, named by key: {e}"
        );
        assert!(e.contains("reference.speed_m_s must be > 0"), "{e}");
        assert!(e.contains("kind = \"line\""), "{e}");
    }
    assert_eq!(core(0.2), Ok(()));
    Scenario::from_toml(&line("0.2"), "l.toml").unwrap();
    // A speed finite in f64 but not in the vehicle's f32 is refused, and said so.
    let e = err(&line("1e40"));
    assert!(e.contains("reference.speed_m_s is not finite"), "{e}");
    assert!(e.contains("f32"), "{e}");
}
