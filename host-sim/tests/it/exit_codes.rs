//! Exit codes and verdicts: `run` exits 1 when the run diverged, went non-finite,
//! lost control or missed its scenario's `[expect]` targets, 0 otherwise; the verdict
//! compares with the scenario's own targets. These run the built binary.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common;
use common::host_sim;

/// A fresh folder for one test.
fn scratch(tag: &str) -> PathBuf {
    common::scratch("exit", tag)
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// A scenario file: the built-in `base` with `name` and `extra` appended (its own `[expect]`
/// dropped).
fn from_builtin(dir: &Path, base: &str, name: &str, extra: &str) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenarios")
        .join(format!("{base}.toml"));
    let text = std::fs::read_to_string(src).unwrap();
    let text = text.split("\n[expect]").next().unwrap();
    let text = text.replace(&format!("name = \"{base}\""), &format!("name = \"{name}\""));
    let p = dir.join(format!("{name}.toml"));
    std::fs::write(&p, format!("{text}\n{extra}")).unwrap();
    p
}

#[test]
fn a_run_that_meets_its_targets_exits_0_and_one_that_misses_them_1() {
    let dir = scratch("targets");
    let meets = from_builtin(&dir, "line-3d", "meets", "[expect]\nrms_last80_m = 0.02\n");
    let o = host_sim(&dir, &["run", meets.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("meets its targets"), "{}", text(&o));
    let misses = from_builtin(&dir, "line-3d", "misses", "[expect]\nrms_last80_m = 1e-9\n");
    let o = host_sim(&dir, &["run", misses.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("MISSES its targets"), "{}", text(&o));
    // Without targets: the figures, no judgement, exit 0.
    let none = from_builtin(&dir, "line-3d", "none", "");
    let o = host_sim(&dir, &["run", none.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("no targets declared"), "{}", text(&o));
}

#[test]
fn a_run_that_diverges_exits_1() {
    let dir = scratch("diverges");
    let o = host_sim(&dir, &["run", "paper-xz", "--out", "o"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("thrust command > 10 kN"), "{}", text(&o));
}

#[test]
fn an_unannounced_half_second_delay_that_spins_the_vehicle_is_lost_heading_control() {
    let dir = scratch("spin");
    let f = from_builtin(&dir, "circle-3d", "spin", "[disturbance]\ndelay_s = 0.5\n");
    let o = host_sim(&dir, &["run", f.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("lost heading control"), "{}", text(&o));
    assert!(text(&o).contains("DIVERGED"), "{}", text(&o));
}

#[test]
fn the_usbl_circle_meets_its_own_30_cm_and_does_not_say_it_does_not_track() {
    let dir = scratch("usbl");
    let o = host_sim(&dir, &["run", "nav-usbl-circle-3d", "--out", "o"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("meets its targets"), "{}", text(&o));
    assert!(!text(&o).contains("does not track"), "{}", text(&o));
}

/// `hil` judges its run as `run` does (it exited 0 on a miss before): the firmware library
/// in process (`--in-process`, no QEMU needed) on a scenario whose target it cannot meet.
#[test]
fn hil_exits_1_when_its_run_misses_its_targets_and_0_when_it_meets_them() {
    let dir = scratch("hil");
    let misses = from_builtin(
        &dir,
        "line-3d",
        "hil-misses",
        "[expect]\nrms_last80_m = 1e-9\n",
    );
    let args = |f: &Path| {
        vec![
            "hil".to_string(),
            f.to_str().unwrap().to_string(),
            "--in-process".into(),
            "--duration".into(),
            "20".into(),
        ]
    };
    let run = |f: &Path| {
        let a = args(f);
        host_sim(&dir, &a.iter().map(String::as_str).collect::<Vec<_>>())
    };
    let o = run(&misses);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("MISSES its targets"), "{}", text(&o));
    let meets = from_builtin(
        &dir,
        "line-3d",
        "hil-meets",
        "[expect]\nrms_last80_m = 0.02\n",
    );
    let o = run(&meets);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}
