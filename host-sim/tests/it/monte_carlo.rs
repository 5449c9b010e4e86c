//! Monte Carlo: reproducible for a seed, different for another seed, perturbations bounded.

use controller_core::params::VehicleParams;
use host_sim::commands::monte_carlo::{
    merge_shards, perturb_params, random_current, run_batch, shard_range, summarize, write_batch,
    McConfig, McRun,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sim_scenario::{Plane, Scenario};

const SHORT: &str = r#"
name = "mc-short"
plane = "xy"
controller = "paper"
duration_s = 4.0
[reference]
kind = "paper"
t_f_s = 40.0
[initial]
x_m = 0.2
[disturbance]
current_m_s = [0.1, 0.0, 0.0]
noise = true
delay_s = 0.01
"#;

fn cfg(seed: u64) -> McConfig {
    McConfig {
        runs: 8,
        seed,
        perturb: 0.2,
        progress: false,
    }
}

#[test]
fn batch_is_reproducible_for_a_seed() {
    let sc = Scenario::from_toml(SHORT, "short").unwrap();
    let (a, ra) = run_batch(&sc.resolve().unwrap(), &cfg(7), (0, 1)).unwrap();
    let (b, rb) = run_batch(&sc.resolve().unwrap(), &cfg(7), (0, 1)).unwrap();
    assert_eq!(a.runs, 8);
    assert_eq!(
        serde_json::to_string(&ra).unwrap(),
        serde_json::to_string(&rb).unwrap()
    );
    assert_eq!(a.rms_position_error_m, b.rms_position_error_m);
    assert_eq!(a.max_abs_thruster_force_n, b.max_abs_thruster_force_n);
    let (_, rc) = run_batch(&sc.resolve().unwrap(), &cfg(8), (0, 1)).unwrap();
    assert_ne!(
        serde_json::to_string(&ra).unwrap(),
        serde_json::to_string(&rc).unwrap(),
        "another seed must give other runs"
    );
    // Currents have the scenario's magnitude, in the plane.
    for r in &ra.runs {
        let c = r.current_m_s;
        assert!(((c[0] * c[0] + c[1] * c[1]).sqrt() - 0.1).abs() < 1e-12 && c[2] == 0.0);
    }
}

#[test]
fn perturbation_is_bounded_and_touches_every_parameter() {
    let base = VehicleParams::OBSERVER;
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..200 {
        let p = perturb_params(&base, 0.2, &mut rng);
        p.validate().expect("perturbed set must stay physical");
        let pairs = [
            (base.mass_kg, p.mass_kg),
            (base.x_udot_kg, p.x_udot_kg),
            (base.y_vdot_kg, p.y_vdot_kg),
            (base.z_wdot_kg, p.z_wdot_kg),
            (base.m_qdot_kg_m2, p.m_qdot_kg_m2),
            (base.n_rdot_kg_m2, p.n_rdot_kg_m2),
            (base.x_u, p.x_u),
            (base.y_v, p.y_v),
            (base.z_w, p.z_w),
            (base.m_q, p.m_q),
            (base.n_r, p.n_r),
            (base.x_uu, p.x_uu),
            (base.y_vv, p.y_vv),
            (base.z_ww, p.z_ww),
            (base.m_qq, p.m_qq),
            (base.n_rr, p.n_rr),
            (base.i_x_kg_m2, p.i_x_kg_m2),
            (base.i_y_kg_m2, p.i_y_kg_m2),
            (base.i_z_kg_m2, p.i_z_kg_m2),
            (base.z_g_m, p.z_g_m),
        ];
        for (b, q) in pairs {
            let k = q / b - 1.0;
            assert!(k.abs() <= 0.2 + 1e-5, "{b} -> {q}");
            assert_ne!(b, q);
        }
        // The thrusters and gravity are not hydrodynamic or inertial: unchanged.
        assert_eq!(p.thrust_max_forward_n, base.thrust_max_forward_n);
        assert_eq!(p.gravity_m_s2, base.gravity_m_s2);
    }
    let c = random_current(Plane::ThreeD, 0.2, &mut rng);
    assert!(((c[0] * c[0] + c[1] * c[1]).sqrt() - 0.2).abs() < 1e-12 && c[2] == 0.0);
}

#[test]
fn shards_cover_every_run_once() {
    for runs in [1usize, 7, 8, 100, 101] {
        for n in 1..=9usize {
            let mut seen = vec![0u32; runs];
            for i in 0..n {
                for k in shard_range(runs, i, n) {
                    seen[k] += 1;
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "runs {runs}, {n} shards");
        }
    }
}

/// Four shards merged give the same `summary.json`, `runs.json` and `runs.csv` as one run of
/// the campaign, byte for byte; a missing or doubled shard is refused.
#[test]
fn four_shards_merged_equal_one_run_byte_for_byte() {
    let sc = Scenario::from_toml(SHORT, "short").unwrap();
    let base = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("mc-shards");
    let _ = std::fs::remove_dir_all(&base);
    let whole = base.join("whole");
    let (s, r) = run_batch(&sc.resolve().unwrap(), &cfg(5), (0, 1)).unwrap();
    write_batch(&whole, &s, &r).unwrap();
    let mut dirs = Vec::new();
    for i in 0..4 {
        let d = base.join(format!("shard-{i}"));
        let (s, r) = run_batch(&sc.resolve().unwrap(), &cfg(5), (i, 4)).unwrap();
        assert_eq!(r.runs.len(), 2);
        write_batch(&d, &s, &r).unwrap();
        dirs.push(d);
    }
    let merged = base.join("merged");
    let (ms, mr) = merge_shards(&dirs).unwrap();
    write_batch(&merged, &ms, &mr).unwrap();
    for f in ["summary.json", "runs.json", "runs.csv"] {
        let a = std::fs::read(whole.join(f)).unwrap();
        let b = std::fs::read(merged.join(f)).unwrap();
        assert!(
            a == b,
            "{f} differs between the whole run and the merged shards"
        );
    }
    let e = merge_shards(&dirs[..3]).unwrap_err().to_string();
    assert!(e.contains("missing"), "{e}");
    let mut twice = dirs.clone();
    twice.push(dirs[0].clone());
    let e = merge_shards(&twice).unwrap_err().to_string();
    assert!(e.contains("two shards"), "{e}");
}

/// Every statistic of a campaign's `summary.json` is a number: a diverged or non-finite run
/// is counted apart with the rule that judged it, never as an infinite figure (`null` in
/// JSON); a figure no run has (the estimation RMS of runs shorter than 10 s) is over 0 runs.
#[test]
fn every_statistic_is_a_number_and_a_diverged_run_is_counted_apart_by_its_rule() {
    let sc = Scenario::from_toml(SHORT, "short").unwrap();
    let (s, r) = run_batch(&sc.resolve().unwrap(), &cfg(7), (0, 1)).unwrap();
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("null"), "{json}");
    assert_eq!(s.rms_position_error_m.runs, 8);
    assert_eq!(s.rms_estimation_error_m.runs, 0, "{json}");

    // Two runs judged lost, one non-finite: the statistics are over the other five.
    let mut runs = r.runs.clone();
    let lost = |r: &mut McRun, rule: &str, figure: f64| {
        r.diverged = rule != "non_finite";
        r.nan_detected = rule == "non_finite";
        r.rms_position_error_m = f64::INFINITY;
        r.rule = Some(rule.into());
        r.rule_figure = Some(figure);
    };
    lost(&mut runs[1], "runaway", 2.2);
    lost(&mut runs[4], "runaway", 3.1);
    lost(&mut runs[6], "non_finite", 1.5);
    let s = summarize(&r.campaign, &runs);
    let json = serde_json::to_string(&s).unwrap();
    assert!(!json.contains("null"), "{json}");
    assert_eq!((s.diverged_runs, s.nan_runs), (2, 1));
    assert_eq!(s.diverged_by_rule.get("runaway"), Some(&2), "{json}");
    assert_eq!(s.diverged_by_rule.get("non_finite"), Some(&1), "{json}");
    assert_eq!(s.rms_position_error_m.runs, 5);
    let kept: Vec<f64> = runs
        .iter()
        .filter(|r| r.rule.is_none())
        .map(|r| r.rms_position_error_m)
        .collect();
    let max = kept.iter().copied().fold(0.0, f64::max);
    assert_eq!(s.rms_position_error_m.max, max);
    assert!(s.rms_position_error_m.max.is_finite());
}
