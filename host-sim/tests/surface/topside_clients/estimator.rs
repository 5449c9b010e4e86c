//! Missions flown on the vehicle's own estimator, started and fed from the surface, held
//! against the served vehicle's truth log and the software run of the same scenario.

use super::*;

/// One row of the truth log with a telemetry frame sent (the shared reader drops the rows
/// before the first, whose `shown_*` are empty): time (s), true position, the vehicle's
/// estimate, and the latest frame sent to the surface (its time stamp, s, and the position
/// it carried).
struct Row {
    t_s: f64,
    truth_m: [f64; 3],
    nav_m: [f64; 3],
    shown_t_s: f64,
    shown_m: [f64; 3],
}

fn read_truth(path: &std::path::Path) -> Vec<Row> {
    let columns = [
        "t_s",
        "x_m",
        "y_m",
        "z_m",
        "nav_x_m",
        "nav_y_m",
        "nav_z_m",
        "shown_t_s",
        "shown_x_m",
        "shown_y_m",
        "shown_z_m",
    ];
    gcs::truth_columns(path, columns)
        .into_iter()
        .map(|v| Row {
            t_s: v[0],
            truth_m: [v[1], v[2], v[3]],
            nav_m: [v[4], v[5], v[6]],
            shown_t_s: v[7],
            shown_m: [v[8], v[9], v[10]],
        })
        .collect()
}

/// `nav-circle-3d` served by `host-sim vehicle` and flown by pymavlink through `rov-topside
/// --tcp`: the simulated vehicle navigates on its own estimator, fed with the simulated
/// sensors, and the ground station sees that estimate. The
/// client (`clients/pymavlink_estimator.py`) uploads a mission, arms, flies it in AUTO and
/// prints every `LOCAL_POSITION_NED`; they are held against the served vehicle's truth log
/// (`.truth.csv`: the true state, the vehicle's estimate and the position its latest
/// telemetry frame carried, each control period): every position shown is the one its
/// frame carried, not the truth, and the estimate is within 10 cm RMS of
/// the truth after 10 s, as in the software run of the same scenario over the same 150 s
/// (7.6 cm, `out/nav-circle-3d/summary.json`; its first 40 s alone are 11.1 cm: the
/// estimator converges on the USBL fixes).
pub(crate) fn pymavlink_flies_a_mission_on_the_vehicles_own_estimator() {
    if !crate::long_test(
        "topside_clients::estimator::pymavlink_flies_a_mission_on_the_vehicles_own_estimator",
        45,
    ) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    fly_on_the_estimator("topside-estimator", None);
}

/// The same, the estimator restarted from the surface (`MAV_CMD_USER_1`) at 60 s of the
/// vehicle's clock, mid-mission: the same bound, the 10 s after the restart not scored. The
/// restart agrees with the fixes, so it starts at the estimate's own position, known as well
/// as the estimate knew it, and the vehicle keeps what its estimator learned of the
/// instruments and the water (docs/navigation.md).
pub(crate) fn the_surface_restarts_the_vehicles_estimator_mid_dive() {
    if !crate::long_test(
        "topside_clients::estimator::the_surface_restarts_the_vehicles_estimator_mid_dive",
        45,
    ) {
        return;
    }
    if !pymavlink_or_skip() {
        return;
    }
    fly_on_the_estimator("topside-estimator-restart", Some(60.0));
}

/// The software run of `nav-circle-3d` (`host-sim run`): its estimation RMS after 10 s
/// (m), the figure the surface path is held to within 10 % + 1 cm.
const SOFTWARE_ESTIMATION_RMS_M: f64 = 0.0754;

fn fly_on_the_estimator(name: &str, restart_s: Option<f64>) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let port = free_udp_port();
    // The surface program built first (a build after a change takes longer than the ground
    // station waits for a heartbeat), then the ground station, listening before the dive
    // starts (`READY`).
    gcs::rov_topside();
    let mut client = Command::new("python3")
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/clients/pymavlink_estimator.py"
        ))
        .arg(port.to_string())
        // The scenario's duration: the figure over the span of its software run.
        .arg("150")
        .args(restart_s.map(|s| s.to_string()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut client_out = std::io::BufReader::new(client.stdout.take().unwrap());
    let mut ready = String::new();
    std::io::BufRead::read_line(&mut client_out, &mut ready).unwrap();
    assert_eq!(ready.trim(), "READY", "the pymavlink client did not start");
    let topside = dive(
        "nav-circle-3d",
        port,
        &dir.join("est.tlog"),
        &dir.join("params.json"),
        // The vehicle's clock starts when the surface connects: the mission starts at the
        // same time of the vehicle's clock, whatever the load when the programs start.
        &[
            "--duration",
            "400",
            "--speedup",
            "4",
            "--surface-nav",
            "--wait-surface",
        ],
    );
    let mut stdout = String::new();
    std::io::Read::read_to_string(&mut client_out, &mut stdout).unwrap();
    let out = client.wait_with_output().unwrap();
    let truth_path = topside.truth();
    stop(topside);
    let pass: Vec<&str> = stdout.lines().filter(|l| !l.starts_with("POS")).collect();
    println!(
        "{}\n{}",
        pass.join("\n"),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "the pymavlink client failed");

    let rows = read_truth(&truth_path);

    // Each telemetry frame the vehicle sent the surface, by its time stamp (ms, the
    // `time_boot_ms` of what the surface shows of it), with the truth log's row of the tick
    // that sent it.
    let mut sent: std::collections::BTreeMap<i64, &Row> = std::collections::BTreeMap::new();
    for r in &rows {
        sent.entry((r.shown_t_s * 1e3).round() as i64).or_insert(r);
    }
    // Each position the ground station saw must be the one its telemetry frame carried: the
    // vehicle's estimate of that tick, as it was when the frame was built.
    let shown: Vec<Vec<f64>> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("POS "))
        .map(|line| {
            line.split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect()
        })
        .collect();
    let (mut matched, mut sq, mut n_err, mut off_truth) = (0usize, 0.0, 0usize, 0.0f64);
    for v in &shown {
        let Some(row) = sent.get(&(v[0].round() as i64)) else {
            continue;
        };
        matched += 1;
        assert!(
            (0..3).all(|k| (v[k + 1] - row.shown_m[k]).abs() < 1e-3),
            "LOCAL_POSITION_NED at {:.3} s is not the position its telemetry frame carried: \
             {:?} vs {:?}",
            v[0] / 1e3,
            &v[1..4],
            row.shown_m
        );
        let e2: f64 = (0..3)
            .map(|k| (row.nav_m[k] - row.truth_m[k]).powi(2))
            .sum();
        off_truth = off_truth.max(e2.sqrt());
        let transient_s = restart_s.map_or(10.0, |r| r + 10.0);
        if row.t_s >= 10.0 && !(row.t_s >= transient_s - 10.0 && row.t_s < transient_s) {
            sq += e2;
            n_err += 1;
        }
    }
    // A frame sent after the truth log's last row (the vehicle stopped) has no row.
    assert!(
        matched * 20 >= shown.len() * 19,
        "{matched} of {} shown positions found among the frames the vehicle sent",
        shown.len()
    );
    assert!(
        matched >= 100,
        "{matched} positions matched to the truth log"
    );
    assert!(n_err >= 100, "{n_err} positions after 10 s");
    let rms = (sq / n_err as f64).sqrt();
    println!(
        "{matched} of {} LOCAL_POSITION_NED matched to the truth log; estimate against the \
         truth: RMS {:.2} cm after 10 s over {n_err}, largest {:.2} cm",
        shown.len(),
        rms * 100.0,
        off_truth * 100.0
    );
    // The truth is not what is shown: an estimate differs from it.
    assert!(off_truth > 1e-3, "the positions shown are the truth");
    let bound = 1.1 * SOFTWARE_ESTIMATION_RMS_M + 0.01;
    assert!(
        rms <= bound,
        "estimation RMS {rms:.4} m > {bound:.4} m (the software run's {SOFTWARE_ESTIMATION_RMS_M} m + 10 % + 1 cm)"
    );
}
