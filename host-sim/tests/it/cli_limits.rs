//! The command line's limits: inputs a script can give are refused before any work
//! starts, with exit code 2 and a reason, and nothing is written outside the output folder.
//! These run the built binary.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common;
use common::host_sim;

/// A fresh folder for one test.
fn scratch(tag: &str) -> PathBuf {
    common::scratch("cli", tag)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A short 3-D line scenario with `name`, and `extra` TOML appended.
fn scenario_file(dir: &Path, file: &str, name: &str, extra: &str) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(
        &p,
        format!(
            "name = {name:?}\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 2.0\n\
             [reference]\nkind = \"line\"\nstart_m = [0.0, 0.0, 2.0]\nspeed_m_s = 0.3\n\
             [initial]\nz_m = 2.0\n{extra}"
        ),
    )
    .unwrap();
    p
}

#[test]
fn a_scenario_named_dot_dot_is_refused_and_writes_nothing() {
    let dir = scratch("dotdot");
    let work = dir.join("work");
    std::fs::create_dir_all(&work).unwrap();
    for name in ["..", ".", ".hidden"] {
        let f = scenario_file(&dir, "s.toml", name, "");
        let o = host_sim(&work, &["run", f.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "name {name:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("name"), "{}", stderr(&o));
        assert!(
            !work.join("summary.json").exists(),
            "wrote into the working folder"
        );
        assert!(
            !work.join("out").exists(),
            "created the output folder: {name:?}"
        );
    }
}

#[test]
fn a_run_too_long_to_hold_is_refused_before_it_allocates() {
    let dir = scratch("duration");
    let f = scenario_file(&dir, "long.toml", "long", "");
    let text = std::fs::read_to_string(&f)
        .unwrap()
        .replace("duration_s = 2.0", "duration_s = 1e6");
    std::fs::write(&f, text).unwrap();
    let o = host_sim(&dir, &["run", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("duration_s"), "{}", stderr(&o));
    assert!(!dir.join("out").exists());
}

#[test]
fn a_campaign_too_large_for_one_process_points_to_shard() {
    let dir = scratch("runs");
    let o = host_sim(
        &dir,
        &["monte-carlo", "mc-circle-3d", "--runs", "100000000"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--shard I/N, N >= 100"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.join("out").exists());
}

#[test]
fn hil_noise_above_one_is_not_a_probability() {
    let dir = scratch("noise");
    let o = host_sim(&dir, &["hil", "line-3d", "--in-process", "--noise", "1.5"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("not a probability"), "{}", stderr(&o));
}

#[test]
fn a_known_delay_the_law_cannot_fly_is_refused_with_the_reason() {
    let dir = scratch("delay");
    let f = scenario_file(
        &dir,
        "d.toml",
        "d",
        "[disturbance]\ndelay_s = 0.4\ndelay_known = true\n",
    );
    let o = host_sim(&dir, &["run", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("limit-cycles"), "{}", stderr(&o));
    // The measured limit itself is flown.
    let f = scenario_file(
        &dir,
        "d.toml",
        "d",
        "[disturbance]\ndelay_s = 0.3\ndelay_known = true\n",
    );
    let o = host_sim(&dir, &["run", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn a_buoyancy_the_vertical_thruster_cannot_hold_is_refused() {
    let dir = scratch("buoyancy");
    // The vehicle's own check of a vehicle (the firmware's SetVehicle): half the smaller
    // vertical thrust (15 N reverse) to spare for control, 7.5 N either way. 15 N heavy sank
    // and 18 N light sat 20 cm above its line when they were flown.
    for (b, ok) in [
        (-18.0, false),
        (-15.0, false),
        (-7.5, true),
        (21.0, false),
        (18.0, false),
        (7.5, true),
    ] {
        let f = scenario_file(
            &dir,
            "b.toml",
            "b",
            &format!("[disturbance]\nbuoyancy_offset_n = {b}\n"),
        );
        let o = host_sim(&dir, &["run", f.to_str().unwrap()]);
        if ok {
            assert_ne!(o.status.code(), Some(2), "{b} N: {}", stderr(&o));
        } else {
            assert_eq!(o.status.code(), Some(2), "{b} N: {}", stderr(&o));
            assert!(
                stderr(&o).contains("cannot hold the depth")
                    && stderr(&o).contains("more than half the vertical thrust"),
                "{}",
                stderr(&o)
            );
        }
    }
}

#[test]
fn a_delay_line_too_long_to_hold_is_refused_before_it_allocates() {
    let dir = scratch("delayline");
    // 1e5 s of delay at 0.1 ms plant steps: 1e9 states (96 GB) in the delay line.
    let f = scenario_file(&dir, "dl.toml", "dl", "[disturbance]\ndelay_s = 99000.0\n");
    let text = std::fs::read_to_string(&f).unwrap().replace(
        "duration_s = 2.0",
        "duration_s = 100000.0\ncontrol_period_s = 0.1\nplant_dt_s = 0.0001",
    );
    std::fs::write(&f, text).unwrap();
    let o = host_sim(&dir, &["run", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("delay_s"), "{}", stderr(&o));
    assert!(!dir.join("out").exists());
}

/// `hil --wall-limit`: a run that cannot finish in its wall-clock budget stops with the
/// reason and the option that gives it more; 0 is refused by the parser (exit 2).
#[test]
fn hil_stops_at_its_wall_clock_limit_and_names_the_option() {
    let dir = scratch("wall-limit");
    // Heavy noise: every corrupted frame costs a reply timeout, ~30 s of wall a second.
    let o = host_sim(
        &dir,
        &[
            "hil",
            "line-3d",
            "--in-process",
            "--noise",
            "0.5",
            "--duration",
            "60",
            "--wall-limit",
            "1",
        ],
    );
    assert!(!o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("wall-clock limit of 1 s") && e.contains("--wall-limit"),
        "{e}"
    );
    let o = host_sim(
        &dir,
        &["hil", "line-3d", "--in-process", "--wall-limit", "0"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}
