//! Missions flown on the vehicle's own estimator, started and fed from the surface, held
//! against the served vehicle's truth log and the software run of the same scenario.

use super::*;

/// One row of the truth log: time (s), true position, the vehicle's estimate.
struct Row {
    t_s: f64,
    truth_m: [f64; 3],
    nav_m: [f64; 3],
}

fn read_truth(path: &std::path::Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| cols.iter().position(|c| *c == name).unwrap();
    let (t, x, y, z) = (col("t_s"), col("x_m"), col("y_m"), col("z_m"));
    let (nx, ny, nz) = (col("nav_x_m"), col("nav_y_m"), col("nav_z_m"));
    lines
        .filter(|l| !l.is_empty())
        .filter_map(|l| {
            let v: Vec<f64> = l
                .split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect();
            // A killed process may leave its last line unfinished.
            (v.len() == cols.len()).then(|| Row {
                t_s: v[t],
                truth_m: [v[x], v[y], v[z]],
                nav_m: [v[nx], v[ny], v[nz]],
            })
        })
        .collect()
}

/// `nav-circle-3d` served by `host-sim vehicle` and flown by pymavlink through `rov-topside
/// --tcp`: the simulated vehicle navigates on its own estimator, fed with the simulated
/// sensors, and the ground station sees that estimate. The
/// client (`clients/pymavlink_estimator.py`) uploads a mission, arms, flies it in AUTO and
/// prints every `LOCAL_POSITION_NED`; they are held against the topside's truth log
/// (`.truth.csv`: the true state and the vehicle's estimate of each control period): the
/// positions shown are the estimate, not the truth, and the estimate is within 10 cm RMS of
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
    let period_s = rows[1].t_s - rows[0].t_s;

    // Each position the ground station saw, with the truth log's row of its time stamp: the
    // stamp is the control tick's time, and the row of that tick is this one, the one after or
    // the one before, depending on when a server writes its row; the offset that the shown
    // positions agree with is found from them, then every shown position must agree.
    let shown: Vec<Vec<f64>> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("POS "))
        .map(|line| {
            line.split_whitespace()
                .map(|x| x.parse().unwrap())
                .collect()
        })
        .collect();
    let row_of = |v: &[f64], offset: f64| {
        let t_s = v[0] / 1e3 + offset * period_s;
        let i = ((t_s - rows[0].t_s) / period_s).round();
        rows.get(i as usize)
            .filter(|r| i >= 0.0 && (r.t_s - t_s).abs() < 0.6 * period_s)
    };
    let agrees = |v: &[f64], r: &Row| (0..3).all(|k| (v[k + 1] - r.nav_m[k]).abs() < 1e-3);
    let offset = [0.0, 1.0, -1.0]
        .into_iter()
        .max_by_key(|&o| {
            shown
                .iter()
                .filter(|v| row_of(v, o).is_some_and(|r| agrees(v, r)))
                .count()
        })
        .unwrap();
    let (mut matched, mut sq, mut n_err, mut off_truth) = (0usize, 0.0, 0usize, 0.0f64);
    let mut disagree = 0usize;
    for v in &shown {
        let Some(row) = row_of(v, offset) else {
            continue;
        };
        matched += 1;
        // A USBL fix fused in the same tick after the frame was built moves the row's
        // estimate horizontally: while the estimator converges on its first fixes (the
        // first seconds) that can be decimetres; after 10 s it is a converged estimate's
        // correction (2 cm seen), so a shown position off its row is off by less than
        // 5 cm horizontally and by millimetres at most in depth, and such rows are rare (below).
        if !agrees(v, row) {
            disagree += 1;
            let restarting = restart_s.is_some_and(|r| (r..r + 10.0).contains(&row.t_s));
            let horizontal_m = (v[1] - row.nav_m[0]).hypot(v[2] - row.nav_m[1]);
            let depth_m = (v[3] - row.nav_m[2]).abs();
            assert!(
                row.t_s < 10.0 || restarting || (horizontal_m < 0.05 && depth_m < 5e-3),
                "LOCAL_POSITION_NED at {:.2} s is not the vehicle's estimate: {:?} vs {:?}",
                row.t_s,
                &v[1..4],
                row.nav_m
            );
        }
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
    assert!(
        matched >= 100,
        "{matched} positions matched to the truth log"
    );
    assert!(n_err >= 100, "{n_err} positions after 10 s");
    assert!(
        disagree * 20 <= matched,
        "{disagree} of {matched} shown positions are not the vehicle's estimate"
    );
    let rms = (sq / n_err as f64).sqrt();
    println!(
        "{matched} LOCAL_POSITION_NED matched to the truth log; estimate against the truth: \
         RMS {:.2} cm after 10 s over {n_err}, largest {:.2} cm",
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
