//! `host-sim topside` with a scenario of the topside layout (`[deployment] control =
//! "topside"`, issue 25): never flown silently as the onboard layout.

use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::host_sim;

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The built-in `nav-circle-3d` (the estimator on the full sensor suite) in the topside
/// layout, as a scenario file in `dir`.
fn topside_scenario(dir: &Path) -> PathBuf {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios/nav-circle-3d.toml");
    let text = std::fs::read_to_string(src).unwrap();
    let text = text.split("\n[expect]").next().unwrap();
    let p = dir.join("layout.toml");
    std::fs::write(&p, format!("{text}\n[deployment]\ncontrol = \"topside\"\n")).unwrap();
    p
}

#[test]
fn a_topside_layout_scenario_is_refused_not_flown_onboard() {
    let dir = common::scratch("topside-layout", "refused");
    let sc = topside_scenario(&dir);
    let o = host_sim(
        &dir,
        &[
            "topside",
            "--sim",
            sc.to_str().unwrap(),
            "--mavlink",
            "udpout:127.0.0.1:9",
            "--duration",
            "1",
            "--speedup",
            "50",
        ],
    );
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("deployment.control = \"topside\""),
        "{}",
        text(&o)
    );
}
