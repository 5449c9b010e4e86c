//! The USBL outlier counter counts what the estimator received: an outlier drawn
//! in the run's last latency window never arrives and is not counted as injected.

use host_sim::closed_loop::runner::{run, RunOptions};
use sim_scenario::Scenario;

#[test]
fn an_outlier_that_never_arrives_is_not_counted() {
    // Every fix an outlier, 1 Hz, 0.9 s latency; the run ends 0.5 s after a ping, so the
    // last fix drawn is still on its way.
    let toml = r#"
name = "outlier-count"
plane = "3d"
controller = "tracking"
duration_s = 20.5
[reference]
kind = "circle"
center_m = [0.0, 5.0, 2.0]
radius_m = 5.0
speed_m_s = 0.25
[initial]
z_m = 2.0
[navigation]
source = "estimator"
[sensors.imu]
[sensors.depth]
[sensors.compass]
[sensors.dvl]
[sensors.usbl]
latency_s = 0.9
outlier_fraction = 1.0
"#;
    let sc = Scenario::from_toml(toml, "test").unwrap();
    let out = run(
        &sc.resolve().unwrap(),
        &RunOptions {
            record: true,
            ..RunOptions::default()
        },
    )
    .unwrap();
    let s = &out.summary;
    let delivered = out.usbl_fixes.iter().filter(|f| f.outlier).count() as u64;
    assert!(out
        .usbl_fixes
        .iter()
        .all(|f| f.t_arrival_s <= s.simulated_s + 1e-9));
    // The ping of 20 s would arrive at 20.9 s, after the end: it is drawn, never received.
    let last_ping_s = out
        .usbl_fixes
        .iter()
        .map(|f| f.t_valid_s)
        .fold(0.0, f64::max);
    assert!(last_ping_s < s.simulated_s - 0.5, "{last_ping_s}");
    assert_eq!(s.navigation.usbl_outliers_injected, delivered);
    assert!(delivered >= 19, "{delivered}");
    assert!(
        s.navigation.usbl_fixes_rejected <= s.navigation.usbl_outliers_injected,
        "{} rejected of {} injected",
        s.navigation.usbl_fixes_rejected,
        s.navigation.usbl_outliers_injected
    );
}
