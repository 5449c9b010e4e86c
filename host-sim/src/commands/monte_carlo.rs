//! Monte Carlo: the same scenario over many perturbed plants.
//!
//! Run `i` of a batch draws from its own ChaCha8 stream (`seed`, stream `i`), so a batch is
//! reproducible for a seed whatever the thread scheduling. Each run:
//! - multiplies every hydrodynamic and inertial parameter of the **plant** (mass, added
//!   masses and inertias, linear and quadratic drags, inertias, `z_g`) by `1 + U(-p, p)`; the
//!   controller keeps the nominal model;
//! - draws a random current direction at the scenario's current magnitude: in the plane for
//!   `xz` / `xy`, a random horizontal direction for `3d`;
//! - draws its own measurement-noise seed.
//!
//! Runs go in parallel with rayon, with an indicatif progress bar.
//!
//! A campaign can be split over machines: `--shard I/N` runs the I-th of N contiguous slices
//! of the run indices (run `i` draws from stream `i` whatever the slice), and `host-sim merge`
//! joins the slices' `runs.json` into the same `summary.json`, `runs.csv` and histogram as one
//! run of the whole campaign, byte for byte (`docs/monte-carlo.md`: a Slurm job array and a
//! Kubernetes indexed Job).

use crate::closed_loop::runner::{run, run_two, RunOptions, RunOutput};
use anyhow::{Context, Result};
use controller_core::params::VehicleParams;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim_scenario::setup::RunSetup;
use sim_scenario::{Plane, Scenario};
use std::path::Path;
use std::time::Instant;

/// Batch settings.
#[derive(Debug, Clone, Copy)]
pub struct McConfig {
    /// Number of runs.
    pub runs: usize,
    /// Master seed.
    pub seed: u64,
    /// Largest relative perturbation `p` (0.2 = +-20 %).
    pub perturb: f64,
    /// Show a progress bar.
    pub progress: bool,
}

/// `f64` in JSON with the non-finite values a diverged run has (`"inf"`, `"-inf"`,
/// `"NaN"`; plain JSON has none), read back exactly.
mod json_f64 {
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            s.serialize_f64(*v)
        } else {
            s.serialize_str(&v.to_string())
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Num {
        F(f64),
        S(String),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Num::deserialize(d)? {
            Num::F(v) => Ok(v),
            Num::S(t) => t.parse().map_err(serde::de::Error::custom),
        }
    }
}

/// One run of a batch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct McRun {
    /// Index in the batch.
    pub index: usize,
    /// Current used (inertial, m/s).
    pub current_m_s: [f64; 3],
    /// RMS position error over the run.
    #[serde(with = "json_f64")]
    pub rms_position_error_m: f64,
    /// RMS position error over the last 80 %.
    #[serde(with = "json_f64")]
    pub rms_position_error_last80_m: f64,
    /// Final position error.
    #[serde(with = "json_f64")]
    pub final_position_error_m: f64,
    /// Largest thruster command.
    #[serde(with = "json_f64")]
    pub max_abs_thruster_force_n: f64,
    /// Share of saturated control ticks.
    #[serde(with = "json_f64")]
    pub saturated_fraction: f64,
    /// Diverged.
    pub diverged: bool,
    /// NaN seen.
    pub nan_detected: bool,
    /// RMS of the navigation position against the truth after 10 s (the estimator's error,
    /// or the truth path's noise).
    #[serde(with = "json_f64")]
    pub rms_estimation_error_m: f64,
    /// Share of ticks with the position NEES inside its 95 % bound (NaN on the truth path).
    #[serde(with = "json_f64")]
    pub nees_in_bounds_fraction: f64,
    /// The rule that judged the run diverged, non-finite or out of control
    /// (`docs/scenarios.md`), none for a run that completed in control.
    #[serde(default)]
    pub rule: Option<String>,
    /// The figure that fired `rule`, in the rule's unit.
    #[serde(default)]
    pub rule_figure: Option<f64>,
}

/// An estimation error RMS above this (or not finite) counts as a diverged filter (m).
pub const FILTER_DIVERGED_M: f64 = 1.0;

/// Percentiles of a batch figure over the runs that completed in control (a diverged,
/// non-finite or lost run is counted apart, in `diverged_runs` / `nan_runs`, never as a
/// figure): every value is a number; with no such run, `runs` is 0 and the values are 0.
#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub struct Percentiles {
    /// Runs the figure is over (those that completed in control, with a finite figure).
    pub runs: usize,
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Largest.
    pub max: f64,
}

/// What defines a campaign: runs with the same campaign and index are the same run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Campaign {
    /// Scenario name.
    pub scenario: String,
    /// Runs in the whole campaign.
    pub runs: usize,
    /// Master seed.
    pub seed: u64,
    /// Relative perturbation bound.
    pub perturb: f64,
    /// Current magnitude used in every run (m/s).
    pub current_magnitude_m_s: f64,
    /// The scenario applies thruster limits.
    pub saturate: bool,
    /// The larger thrust limit of the scenario's vehicle (N).
    pub thrust_limit_n: f64,
}

/// `DIR/runs.json`: the campaign, which slice this is, and every run of it (full precision,
/// so that merged slices give the same figures as one run).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardRuns {
    /// The campaign.
    pub campaign: Campaign,
    /// `[i, n]`: the i-th of n slices (`[0, 1]` for a whole campaign).
    pub shard: [usize; 2],
    /// The runs of this slice, by index.
    pub runs: Vec<McRun>,
}

/// The run indices of slice `i` of `n` of a campaign of `runs` runs: contiguous, the first
/// `runs % n` slices one longer.
pub fn shard_range(runs: usize, i: usize, n: usize) -> std::ops::Range<usize> {
    let n = n.max(1);
    let (q, r) = (runs / n, runs % n);
    let start = i * q + i.min(r);
    let len = q + usize::from(i < r);
    start.min(runs)..(start + len).min(runs)
}

/// The most runs one process holds: each keeps about 100 B of results in memory and
/// about 350 B in `runs.json`, so 1,000,000 runs take about 0.1 GB and 0.35 GB.
pub const MAX_RUNS_PER_PROCESS: usize = 1_000_000;

/// The most runs `merge` joins (their results all in memory, about 1 GB).
pub const MAX_MERGED_RUNS: usize = 10_000_000;

/// Check a campaign of `runs` (the slice `shard` of it) before any work: one process runs
/// at most [`MAX_RUNS_PER_PROCESS`]; a larger campaign is refused with the `--shard` that
/// fits (each slice on its own machine or job, joined with `host-sim merge`).
pub fn check_campaign(runs: usize, shard: (usize, usize)) -> Result<()> {
    if runs == 0 {
        anyhow::bail!("--runs must be >= 1");
    }
    let here = shard_range(runs, shard.0, shard.1).len();
    if here > MAX_RUNS_PER_PROCESS {
        let slices = runs.div_ceil(MAX_RUNS_PER_PROCESS);
        anyhow::bail!(
            "{here} runs in one process is too many (at most {MAX_RUNS_PER_PROCESS}: each run \
             keeps about 100 B of results in memory and 350 B in runs.json): split the campaign \
             with --shard I/N, N >= {slices} (e.g. --shard 0/{slices} ... --shard {}/{slices}, \
             one job each), and join the folders with host-sim merge",
            slices - 1
        );
    }
    Ok(())
}

/// Parse `I/N` (0 <= I < N).
pub fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| anyhow::anyhow!("--shard takes I/N, e.g. 0/4 (got {s:?})"))?;
    let (i, n): (usize, usize) = (
        i.trim().parse().context("--shard I")?,
        n.trim().parse().context("--shard N")?,
    );
    if n == 0 || i >= n {
        anyhow::bail!("--shard I/N needs 0 <= I < N (got {i}/{n})");
    }
    Ok((i, n))
}

/// `DIR/summary.json` of a batch.
#[derive(Debug, Clone, Serialize)]
pub struct McSummary {
    /// Scenario name.
    pub scenario: String,
    /// Runs.
    pub runs: usize,
    /// Master seed.
    pub seed: u64,
    /// Relative perturbation bound.
    pub perturb: f64,
    /// Current magnitude used in every run (m/s).
    pub current_magnitude_m_s: f64,
    /// Runs that produced a NaN.
    pub nan_runs: usize,
    /// Runs that diverged (stopped beyond the physical, or control lost at the end).
    pub diverged_runs: usize,
    /// The diverged and non-finite runs by the rule that judged them (`docs/scenarios.md`).
    pub diverged_by_rule: std::collections::BTreeMap<String, usize>,
    /// Runs whose navigation error RMS is over [`FILTER_DIVERGED_M`] or not finite.
    pub diverged_filters: usize,
    /// RMS navigation (estimation) error of each run after its first 10 s.
    pub rms_estimation_error_m: Percentiles,
    /// RMS position error over each run.
    pub rms_position_error_m: Percentiles,
    /// RMS position error over the last 80 % of each run.
    pub rms_position_error_last80_m: Percentiles,
    /// Final position error.
    pub final_position_error_m: Percentiles,
    /// Largest thruster command over all runs (N).
    pub max_abs_thruster_force_n: f64,
    /// Every thruster command stayed within the real limits.
    pub thrust_within_limits: bool,
}

/// Multiply every hydrodynamic and inertial parameter by `1 + U(-p, p)`.
pub fn perturb_params(base: &VehicleParams, p: f64, rng: &mut ChaCha8Rng) -> VehicleParams {
    let mut v = *base;
    let mut f = |x: &mut f32| {
        let k = if p > 0.0 {
            rng.random_range(-p..=p)
        } else {
            0.0
        };
        *x = (f64::from(*x) * (1.0 + k)) as f32;
    };
    f(&mut v.mass_kg);
    f(&mut v.x_udot_kg);
    f(&mut v.y_vdot_kg);
    f(&mut v.z_wdot_kg);
    f(&mut v.m_qdot_kg_m2);
    f(&mut v.n_rdot_kg_m2);
    f(&mut v.x_u);
    f(&mut v.y_v);
    f(&mut v.z_w);
    f(&mut v.m_q);
    f(&mut v.n_r);
    f(&mut v.x_uu);
    f(&mut v.y_vv);
    f(&mut v.z_ww);
    f(&mut v.m_qq);
    f(&mut v.n_rr);
    f(&mut v.i_x_kg_m2);
    f(&mut v.i_y_kg_m2);
    f(&mut v.i_z_kg_m2);
    f(&mut v.z_g_m);
    v
}

/// A random current of magnitude `mag` for the plane.
pub fn random_current(plane: Plane, mag: f64, rng: &mut ChaCha8Rng) -> [f64; 3] {
    let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
    let (s, c) = a.sin_cos();
    match plane {
        Plane::Xz => [mag * c, 0.0, mag * s],
        Plane::Xy | Plane::ThreeD => [mag * c, mag * s, 0.0],
    }
}

fn percentiles(values: &[f64]) -> Percentiles {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    let at = |q: f64| {
        let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len().max(1)) - 1;
        v.get(i).copied().unwrap_or(0.0)
    };
    Percentiles {
        runs: v.len(),
        p50: at(0.5),
        p95: at(0.95),
        max: at(1.0),
    }
}

/// The figures a campaign keeps of run `index` (its current `current_m_s`).
fn mc_run(index: usize, current_m_s: [f64; 3], out: RunOutput) -> McRun {
    let s = out.summary;
    let lost = s.diverged || s.nan_detected;
    let rule = s.rule.filter(|_| lost);
    McRun {
        index,
        current_m_s,
        rms_position_error_m: s.rms_position_error_m,
        rms_position_error_last80_m: s.rms_position_error_last80_m,
        final_position_error_m: s.final_position_error_m,
        max_abs_thruster_force_n: s.max_abs_thruster_force_n,
        saturated_fraction: s.saturated_fraction,
        diverged: s.diverged,
        nan_detected: s.nan_detected,
        rms_estimation_error_m: s.rms_estimation_error_m,
        nees_in_bounds_fraction: s.navigation.nees_in_bounds_fraction.unwrap_or(f64::NAN),
        rule_figure: rule.as_ref().map(|r| r.figure),
        rule: rule.map(|r| r.name),
    }
}

/// Run a batch: the whole campaign (`shard = (0, 1)`) or one slice of it. Returns the
/// summary of the runs done and the runs.
pub fn run_batch(
    sc: &RunSetup,
    cfg: &McConfig,
    shard: (usize, usize),
) -> Result<(McSummary, ShardRuns)> {
    check_campaign(cfg.runs, shard)?;
    let wall = Instant::now();
    let cpu = cpu_time::ProcessTime::try_now().ok();
    let campaign = Campaign {
        scenario: sc.name.clone(),
        runs: cfg.runs,
        seed: cfg.seed,
        perturb: cfg.perturb,
        current_magnitude_m_s: sc.current_magnitude_m_s(),
        saturate: sc.thrusters.saturate,
        thrust_limit_n: f64::from(
            sc.vehicle_params
                .thrust_max_forward_n
                .max(sc.vehicle_params.thrust_max_reverse_n),
        ),
    };
    let mag = campaign.current_magnitude_m_s;
    let base = crate::closed_loop::runner::nominal_plant_params(sc);
    let indices = shard_range(cfg.runs, shard.0, shard.1);
    let pb = if cfg.progress {
        ProgressBar::new(indices.len() as u64)
    } else {
        ProgressBar::with_draw_target(Some(indices.len() as u64), ProgressDrawTarget::hidden())
    };
    pb.set_style(
        ProgressStyle::with_template(
            "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} ({per_sec}, eta {eta})",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_message(format!("monte-carlo {}", sc.name));
    // Run `i`'s draws: its plant parameters, its current, its noise seed.
    let draw = |i: usize| {
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(i as u64);
        let params = perturb_params(&base, cfg.perturb, &mut rng);
        let current = random_current(sc.plane, mag, &mut rng);
        let noise_seed: u64 = rng.random();
        let opts = RunOptions {
            record: false,
            plant_params: Some(params),
            current_m_s: Some(current),
            noise_seed: Some(noise_seed),
            ..RunOptions::default()
        };
        (i, current, opts)
    };
    // Two runs at a time, stepped together (`run_two`: each run's figures are those of the
    // run alone, whichever run it is paired with).
    let indices: Vec<usize> = indices.collect();
    let results: Vec<Result<Vec<McRun>>> = indices
        .par_chunks(2)
        .map(|pair| {
            let draws: Vec<_> = pair.iter().map(|&i| draw(i)).collect();
            let outs: Vec<RunOutput> = match draws.as_slice() {
                [(i, _, a), (j, _, b)] => run_two(sc, [a, b])
                    .with_context(|| format!("monte-carlo runs {i} and {j}"))?
                    .into(),
                [(i, _, a)] => vec![run(sc, a).with_context(|| format!("monte-carlo run {i}"))?],
                _ => Vec::new(),
            };
            pb.inc(pair.len() as u64);
            Ok(draws
                .iter()
                .zip(outs)
                .map(|(&(i, current, _), out)| mc_run(i, current, out))
                .collect())
        })
        .collect();
    pb.finish_and_clear();
    let runs: Vec<McRun> = results
        .into_iter()
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    let shard_runs = ShardRuns {
        campaign,
        shard: [shard.0, shard.1],
        runs,
    };
    let summary = summarize(&shard_runs.campaign, &shard_runs.runs);
    if cfg.progress {
        eprintln!(
            "{}",
            throughput_line(
                shard_runs.runs.len(),
                wall.elapsed().as_secs_f64(),
                cpu.and_then(|c| c.try_elapsed().ok())
                    .map(|d| d.as_secs_f64())
            )
        );
    }
    Ok((summary, shard_runs))
}

/// `N runs in W s (C CPU-s: R runs per CPU-second, on T threads)`: the campaign's cost per
/// run whatever the machine's number of cores (the CPU time is the whole process's).
pub fn throughput_line(runs: usize, wall_s: f64, cpu_s: Option<f64>) -> String {
    match cpu_s.filter(|c| *c > 0.0) {
        Some(c) => format!(
            "{runs} runs in {wall_s:.1} s ({c:.2} CPU-s: {:.1} runs per CPU-second, on {} threads)",
            runs as f64 / c,
            rayon::current_num_threads()
        ),
        None => format!("{runs} runs in {wall_s:.1} s (CPU time not available here)"),
    }
}

/// The summary of a set of runs of a campaign.
pub fn summarize(campaign: &Campaign, runs: &[McRun]) -> McSummary {
    // A run that diverged or produced a NaN is counted apart (`diverged_runs`, `nan_runs`,
    // `diverged_by_rule`), not in the percentiles: its partial-run figures would flatter it
    // and an infinite one is no number; runs.csv keeps the raw numbers.
    let col = |f: fn(&McRun) -> f64| {
        runs.iter()
            .filter(|r| !r.diverged && !r.nan_detected)
            .map(f)
            .collect::<Vec<f64>>()
    };
    let mut by_rule = std::collections::BTreeMap::new();
    for r in runs.iter().filter(|r| r.diverged || r.nan_detected) {
        let rule = r.rule.clone().unwrap_or_else(|| "unnamed".into());
        *by_rule.entry(rule).or_insert(0) += 1;
    }
    let max_thrust = runs
        .iter()
        .map(|r| r.max_abs_thruster_force_n)
        .fold(0.0, f64::max);
    let limit = campaign.thrust_limit_n;
    let within = runs
        .iter()
        .all(|r| r.max_abs_thruster_force_n <= limit + 1e-6);
    McSummary {
        scenario: campaign.scenario.clone(),
        runs: runs.len(),
        seed: campaign.seed,
        perturb: campaign.perturb,
        current_magnitude_m_s: campaign.current_magnitude_m_s,
        nan_runs: runs.iter().filter(|r| r.nan_detected).count(),
        diverged_runs: runs.iter().filter(|r| r.diverged).count(),
        diverged_by_rule: by_rule,
        diverged_filters: runs
            .iter()
            .filter(|r| {
                r.rms_estimation_error_m.is_nan() || r.rms_estimation_error_m > FILTER_DIVERGED_M
            })
            .count(),
        rms_estimation_error_m: percentiles(&col(|r| r.rms_estimation_error_m)),
        rms_position_error_m: percentiles(&col(|r| r.rms_position_error_m)),
        rms_position_error_last80_m: percentiles(&col(|r| r.rms_position_error_last80_m)),
        final_position_error_m: percentiles(&col(|r| r.final_position_error_m)),
        max_abs_thruster_force_n: max_thrust,
        thrust_within_limits: within && campaign.saturate,
    }
}

/// Join the slices in `dirs` (each with the `runs.json` of `monte-carlo --shard`) into the
/// whole campaign. Refuses slices of different campaigns, a run present twice, or a
/// missing run, naming it.
pub fn merge_shards(dirs: &[std::path::PathBuf]) -> Result<(McSummary, ShardRuns)> {
    let mut campaign: Option<Campaign> = None;
    let mut runs: Vec<McRun> = Vec::new();
    for d in dirs {
        let path = d.join("runs.json");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let part: ShardRuns = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a monte-carlo runs.json", path.display()))?;
        match &campaign {
            None => {
                if part.campaign.runs > MAX_MERGED_RUNS {
                    anyhow::bail!(
                        "a campaign of {} runs cannot be merged on one machine (at most \
                         {MAX_MERGED_RUNS}, all in memory); each shard's summary.json stands \
                         on its own",
                        part.campaign.runs
                    );
                }
                campaign = Some(part.campaign.clone());
            }
            Some(c) if *c != part.campaign => anyhow::bail!(
                "{} is from another campaign ({:?}, expected {:?})",
                path.display(),
                part.campaign,
                c
            ),
            Some(_) => {}
        }
        runs.extend(part.runs);
    }
    let campaign = campaign.ok_or_else(|| anyhow::anyhow!("no shard folders given"))?;
    runs.sort_by_key(|r| r.index);
    for w in runs.windows(2) {
        if let [a, b] = w {
            if a.index == b.index {
                anyhow::bail!("run {} is in two shards", a.index);
            }
        }
    }
    let have: std::collections::BTreeSet<usize> = runs.iter().map(|r| r.index).collect();
    if let Some(missing) = (0..campaign.runs).find(|i| !have.contains(i)) {
        anyhow::bail!(
            "run {missing} of {} is missing: give every shard's folder",
            campaign.runs
        );
    }
    if let Some(extra) = runs.iter().find(|r| r.index >= campaign.runs) {
        anyhow::bail!(
            "run {} is outside the campaign of {}",
            extra.index,
            campaign.runs
        );
    }
    let summary = summarize(&campaign, &runs);
    Ok((
        summary,
        ShardRuns {
            campaign,
            shard: [0, 1],
            runs,
        },
    ))
}

/// Write `summary.json`, `runs.json`, `runs.csv` and `histogram.png` into `dir`.
pub fn write_batch(dir: &Path, summary: &McSummary, shard: &ShardRuns) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    std::fs::write(
        dir.join("summary.json"),
        serde_json::to_string_pretty(summary)? + "\n",
    )?;
    std::fs::write(
        dir.join("runs.json"),
        serde_json::to_string_pretty(shard)? + "\n",
    )?;
    let runs = &shard.runs;
    let mut csv = String::from(
        "index,cx_m_s,cy_m_s,cz_m_s,rms_position_error_m,rms_position_error_last80_m,final_position_error_m,max_abs_thruster_force_n,saturated_fraction,diverged,nan_detected,rms_estimation_error_m,nees_in_bounds_fraction,rule,rule_figure\n",
    );
    for r in runs {
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.index,
            r.current_m_s[0],
            r.current_m_s[1],
            r.current_m_s[2],
            r.rms_position_error_m,
            r.rms_position_error_last80_m,
            r.final_position_error_m,
            r.max_abs_thruster_force_n,
            r.saturated_fraction,
            r.diverged,
            r.nan_detected,
            r.rms_estimation_error_m,
            r.nees_in_bounds_fraction,
            r.rule.as_deref().unwrap_or(""),
            r.rule_figure.map_or(String::new(), |v| v.to_string())
        ));
    }
    std::fs::write(dir.join("runs.csv"), csv)?;
    let v: Vec<f64> = runs.iter().map(|r| r.rms_position_error_m).collect();
    crate::output::plots::histogram(
        &dir.join("histogram.png"),
        &format!(
            "{}: RMS position error over {} runs (+-{:.0} % parameters, {:.2} m/s current)",
            summary.scenario,
            summary.runs,
            100.0 * summary.perturb,
            summary.current_magnitude_m_s
        ),
        "RMS position error (m)",
        &v,
        30,
    )
}

/// Arguments of `host-sim monte-carlo`.
#[derive(Debug, clap::Args)]
pub struct McArgs {
    /// Built-in name or path to a scenario file.
    pub scenario: String,
    /// Number of runs.
    #[arg(long)]
    pub runs: usize,
    /// Master seed (the batch is reproducible for a seed).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Largest relative parameter perturbation (0.2 = +-20 %).
    #[arg(long, default_value_t = 0.2)]
    pub perturb: f64,
    /// Run only the I-th of N slices of the campaign (0-based), e.g. `--shard 3/16`;
    /// join the slices' folders with `host-sim merge`.
    #[arg(long, value_name = "I/N")]
    pub shard: Option<String>,
    /// Output folder (default out/monte-carlo-<scenario>[-shard-I-of-N]).
    #[arg(long)]
    pub out: Option<std::path::PathBuf>,
}

/// Run `host-sim monte-carlo`: the inputs checked (refused before any work), the batch run
/// and written.
pub fn main(a: McArgs) -> Result<()> {
    use crate::checks::refused;
    let shard = a
        .shard
        .as_deref()
        .map(parse_shard)
        .transpose()
        .map_err(refused)?;
    check_campaign(a.runs, shard.unwrap_or((0, 1))).map_err(refused)?;
    let perturb = a.perturb;
    if !(0.0..1.0).contains(&perturb) {
        return Err(refused(anyhow::anyhow!(
            "--perturb must be in [0, 1) (got {perturb})"
        )));
    }
    let sc = Scenario::load_setup(&a.scenario).map_err(refused)?;
    let cfg = McConfig {
        runs: a.runs,
        seed: a.seed,
        perturb,
        progress: true,
    };
    let (summary, rs) = run_batch(&sc, &cfg, shard.unwrap_or((0, 1)))?;
    let dir = a.out.unwrap_or_else(|| {
        let suffix = shard.map_or(String::new(), |(i, n)| format!("-shard-{i}-of-{n}"));
        std::path::PathBuf::from("out").join(format!("monte-carlo-{}{suffix}", sc.name))
    });
    write_batch(&dir, &summary, &rs)?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    println!("outputs in {}", dir.display());
    Ok(())
}
