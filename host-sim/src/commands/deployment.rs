//! `host-sim deployment`: the measurements of the topside layout against the onboard one
//!, with the firmware library's two roles in process over the byte-level tether
//! model ([`crate::tether::topside_layout`], [`sim_world::tether_wire`]).
//!
//! - tracking: the navigation scenarios flown both ways (true position, RMS over the last
//!   80 %); the topside layout must be within 10 % + 1 cm of the onboard one;
//! - latency: an IMU sample on the node -> the pulse it causes on the node, as a histogram,
//!   at the chosen rate and at 1 Mbd; p99 <= 10 ms;
//! - delay margin: added one-way latency 0-500 ms, without and with the delay told to the
//!   laws; told, the error may grow by at most 5 cm over the zero-latency run up to 100 ms;
//! - a cut of the node link: the node neutral within 100 ms of the last good frame, latched
//!   at 1 s; the ground station's `Telemetry` shows the loss within 250 ms of the cut;
//! - byte corruption at 1e-3 and 1e-2: no wrong command applied on the node.
//!
//! Exit codes as the rest of the tool: 0 every bound met, 1 a bound missed (the figures are
//! printed all the same), 2 refused arguments, 3 a run that could not complete.

use crate::closed_loop::RunOptions;
use crate::tether::topside_layout::{
    run_layout, told_delay_s, Control, LayoutOutput, MAX_TOLD_DELAY_S,
};
use anyhow::{bail, Result};
use serde::Serialize;
use sim_scenario::Scenario;
use sim_world::tether_wire::DEFAULT_BAUD;

/// The navigation scenarios compared: full sensor suite, and USBL only.
pub const TRACKING_SCENARIOS: [&str; 4] = [
    "nav-circle-3d",
    "nav-lawnmower-3d",
    "nav-usbl-circle-3d",
    "nav-usbl-current-3d",
];

/// The scenario of the latency, delay, cut and corruption measurements.
pub const PROBE_SCENARIO: &str = "nav-circle-3d";

/// The added one-way latencies of the delay sweep (s).
pub const SWEEP_LATENCIES_S: [f64; 11] = [
    0.0, 0.025, 0.05, 0.075, 0.1, 0.125, 0.15, 0.2, 0.3, 0.4, 0.5,
];

/// The bounds the topside layout is held to (docs/deployment.md).
pub mod bound {
    /// Topside tracking within this share of the onboard RMS...
    pub const TRACKING_REL: f64 = 0.10;
    /// ...plus this (m).
    pub const TRACKING_ABS_M: f64 = 0.01;
    /// p99 of the sensor-to-thruster latency (ms).
    pub const LATENCY_P99_MS: f64 = 10.0;
    /// With the delay told, the growth of the error over the zero-latency run (m)...
    pub const DELAY_GROWTH_M: f64 = 0.05;
    /// ...up to this one-way latency (s).
    pub const DELAY_UP_TO_S: f64 = 0.1;
    /// The node neutral after its last good frame (s).
    pub const NEUTRAL_S: f64 = 0.1;
    /// The node latched after its last good frame (s): at 1 s, one node pass of slack.
    pub const LATCHED_S: f64 = 1.0;
    /// The ground station sees the loss after the cut (s).
    pub const GROUND_S: f64 = 0.25;
}

/// One scenario flown both ways.
#[derive(Debug, Clone, Serialize)]
pub struct TrackingRow {
    /// Scenario.
    pub scenario: String,
    /// The onboard layout (`host-sim run`: the core and its estimator on the vehicle), m.
    pub onboard_rms_last80_m: f64,
    /// The topside layout, m.
    pub topside_rms_last80_m: f64,
    /// The bound: onboard x 1.1 + 1 cm.
    pub bound_m: f64,
    /// Met.
    pub met: bool,
}

/// A latency histogram at one rate.
#[derive(Debug, Clone, Serialize)]
pub struct LatencyRow {
    /// Rate (Bd).
    pub baud: u32,
    /// The node link's period (us).
    pub link_period_us: u32,
    /// Samples.
    pub n: usize,
    /// Quantiles from the newest sample in the uplink (ms).
    pub p50_ms: f64,
    /// 99th percentile (ms).
    pub p99_ms: f64,
    /// Largest (ms).
    pub max_ms: f64,
    /// p99 from the oldest sample the increments cover (ms).
    pub p99_oldest_ms: f64,
    /// (bin start ms, count), 0.5 ms bins.
    pub histogram: Vec<(f64, u64)>,
    /// p99 within 10 ms.
    pub met: bool,
}

/// One latency of the sweep.
#[derive(Debug, Clone, Serialize)]
pub struct DelayRow {
    /// Added one-way latency (s).
    pub latency_s: f64,
    /// RMS over the last 80 %, the laws not told (m).
    pub rms_not_told_m: f64,
    /// Not told, the run diverged or lost control (the reason).
    pub not_told_lost: Option<String>,
    /// The same with the delay told (m); none when the delay is over what the laws take.
    pub rms_told_m: Option<f64>,
    /// The delay told (s).
    pub told_delay_s: f64,
    /// Told, with the increments stamped at the node's sample time (`stamp_node_time`), m.
    pub rms_told_node_time_m: Option<f64>,
    /// The topside's last round trip, not told (ms).
    pub round_trip_ms: Option<f64>,
}

/// The cut of the node link.
#[derive(Debug, Clone, Serialize)]
pub struct CutRow {
    /// The cut (s).
    pub cut_s: f64,
    /// The node's last good frame before it (s).
    pub last_good_frame_s: Option<f64>,
    /// Neutral, after the last good frame (s).
    pub neutral_after_s: Option<f64>,
    /// Disarmed and latched, after the last good frame (s).
    pub latched_after_s: Option<f64>,
    /// The ground station's first `Telemetry` with the loss, after the cut (s).
    pub ground_after_s: Option<f64>,
    /// Every bound met.
    pub met: bool,
}

/// Byte corruption at one rate.
#[derive(Debug, Clone, Serialize)]
pub struct CorruptionRow {
    /// Share of bytes corrupted.
    pub rate: f64,
    /// Downlinks the node applied.
    pub applied: u64,
    /// Of them, different from what the topside sent.
    pub wrong: u64,
    /// Downlinks the node refused as corrupt.
    pub node_refused: u16,
    /// Uplinks the topside refused as corrupt.
    pub topside_refused: u32,
    /// RMS over the last 80 % (m).
    pub rms_last80_m: f64,
}

/// Everything `host-sim deployment` measured.
#[derive(Debug, Clone, Serialize)]
pub struct DeploymentReport {
    /// The node link's rate (Bd).
    pub baud: u32,
    /// Tracking.
    pub tracking: Vec<TrackingRow>,
    /// Latency at `baud` and at 1 Mbd.
    pub latency: Vec<LatencyRow>,
    /// The delay sweep.
    pub delay: Vec<DelayRow>,
    /// The delay margin met: told, within 5 cm of the zero-latency run up to 100 ms.
    pub delay_met: bool,
    /// The cut.
    pub cut: CutRow,
    /// Byte corruption.
    pub corruption: Vec<CorruptionRow>,
}

impl DeploymentReport {
    /// Every bound met.
    pub fn met(&self) -> bool {
        self.tracking.iter().all(|r| r.met)
            && self.latency.iter().all(|r| r.met)
            && self.delay_met
            && self.cut.met
            && self.corruption.iter().all(|r| r.wrong == 0)
    }
}

/// A built-in scenario in the topside layout at `baud`.
pub fn topside(name: &str, baud: u32) -> Result<Scenario> {
    let mut sc = Scenario::load(name)?;
    sc.deployment.control = Control::Topside;
    sc.deployment.tether_baud = baud;
    sc.deployment.validate()?;
    Ok(sc)
}

/// Fly `sc` in the topside layout for `duration_s` (the scenario's without).
pub fn fly(sc: &Scenario, duration_s: Option<f64>) -> Result<LayoutOutput> {
    let opts = RunOptions {
        duration_s,
        ..RunOptions::default()
    };
    run_layout(sc, &opts)
}

/// Tracking of one scenario both ways.
pub fn tracking(name: &str, baud: u32, duration_s: Option<f64>) -> Result<TrackingRow> {
    let opts = RunOptions {
        duration_s,
        ..RunOptions::default()
    };
    let onboard = crate::closed_loop::runner::run(&Scenario::load_setup(name)?, &opts)?;
    let top = fly(&topside(name, baud)?, duration_s)?;
    let on = onboard.summary.rms_position_error_last80_m;
    let tp = top.run.summary.rms_position_error_last80_m;
    let bound_m = on * (1.0 + bound::TRACKING_REL) + bound::TRACKING_ABS_M;
    Ok(TrackingRow {
        scenario: name.into(),
        onboard_rms_last80_m: on,
        topside_rms_last80_m: tp,
        bound_m,
        met: tp.is_finite() && tp <= bound_m && !top.run.summary.diverged,
    })
}

/// The latency histogram at `baud`, the link period the rate's default.
pub fn latency(baud: u32, duration_s: Option<f64>) -> Result<LatencyRow> {
    latency_at(baud, None, duration_s)
}

/// The shortest link period at `baud`, in whole IMU periods, that keeps the link at most
/// half busy (us; the node's IMU period when the rate allows it).
pub fn shortest_link_period_us(baud: u32) -> u32 {
    let imu = firmware::node::NodeConfig::DEFAULT.imu_period_us;
    let max = firmware::node_link::LINK_PERIOD_US;
    (1..=max / imu)
        .map(|k| k * imu)
        .find(|&p| firmware::node_link::check_link_period(p, imu, baud).is_ok())
        .unwrap_or(max)
}

/// The latency histogram at `baud` with the link period `link_period_s` (the rate's
/// default without).
pub fn latency_at(
    baud: u32,
    link_period_s: Option<f64>,
    duration_s: Option<f64>,
) -> Result<LatencyRow> {
    let mut sc = topside(PROBE_SCENARIO, baud)?;
    sc.deployment.link_period_s = link_period_s;
    sc.deployment.validate()?;
    let link_period_us = sc.deployment.link_period_us();
    let out = fly(&sc, duration_s)?;
    let l = &out.report.latency;
    let q = |q: f64| l.quantile_ms(q).unwrap_or(f64::INFINITY);
    let p99 = q(0.99);
    Ok(LatencyRow {
        baud,
        link_period_us,
        n: l.samples_us.len(),
        p50_ms: q(0.5),
        p99_ms: p99,
        max_ms: q(1.0),
        p99_oldest_ms: out
            .report
            .latency_oldest
            .quantile_ms(0.99)
            .unwrap_or(f64::INFINITY),
        histogram: l.histogram(0.5),
        met: !l.samples_us.is_empty() && p99 <= bound::LATENCY_P99_MS,
    })
}

/// One latency of the sweep, not told and told.
pub fn delay(latency_s: f64, baud: u32, duration_s: Option<f64>) -> Result<DelayRow> {
    let mut sc = topside(PROBE_SCENARIO, baud)?;
    sc.deployment.tether_latency_s = latency_s;
    let out = fly(&sc, duration_s)?;
    let round_trip_ms = out.report.round_trip_us.map(|t| f64::from(t) * 1e-3);
    let run = out.run.summary;
    let not_told = run.rms_position_error_last80_m;
    let not_told_lost = run
        .diverged
        .then(|| run.lost_control.unwrap_or(run.stop_reason));
    sc.deployment.tell_delay = true;
    let told = told_delay_s(&sc.deployment);
    // A told delay over the laws' limit is refused: no run, no figure.
    let told_ok = told <= f64::from(MAX_TOLD_DELAY_S);
    let rms = |sc: &Scenario| -> Result<Option<f64>> {
        if !told_ok {
            return Ok(None);
        }
        Ok(Some(
            fly(sc, duration_s)?.run.summary.rms_position_error_last80_m,
        ))
    };
    let rms_told = rms(&sc)?;
    sc.deployment.stamp_node_time = true;
    let rms_told_node_time = rms(&sc)?;
    Ok(DelayRow {
        latency_s,
        rms_not_told_m: not_told,
        not_told_lost,
        rms_told_m: rms_told,
        told_delay_s: told,
        rms_told_node_time_m: rms_told_node_time,
        round_trip_ms,
    })
}

/// Whether the sweep meets the margin: told, within 5 cm of the zero-latency told run up to
/// 100 ms.
pub fn delay_met(rows: &[DelayRow]) -> bool {
    let Some(base) = rows
        .iter()
        .find(|r| r.latency_s == 0.0)
        .and_then(|r| r.rms_told_m)
    else {
        return false;
    };
    rows.iter()
        .filter(|r| r.latency_s <= bound::DELAY_UP_TO_S + 1e-9)
        .all(|r| {
            r.rms_told_m
                .is_some_and(|m| m <= base + bound::DELAY_GROWTH_M)
        })
}

/// A cut of the node link at `cut_s`, flown 3 s past it.
pub fn cut(cut_s: f64, baud: u32) -> Result<CutRow> {
    let mut sc = topside(PROBE_SCENARIO, baud)?;
    sc.deployment.tether_cut_s = Some(cut_s);
    let out = fly(&sc, Some(cut_s + 3.0))?;
    let r = &out.report;
    // To the microsecond (both are pass times on the virtual clock).
    let after = |t: Option<f64>, from: Option<f64>| Some(((t? - from?) * 1e6).round() * 1e-6);
    let neutral = after(r.node_neutral_s, r.last_good_frame_s);
    let latched = after(r.node_latched_s, r.last_good_frame_s);
    let ground = after(r.ground_saw_loss_s, Some(cut_s));
    // The node's pass is 100 us: latched "at 1 s" is within a pass of it.
    let pass_s = crate::tether::topside_layout::PASS_US as f64 * 1e-6;
    let met = neutral.is_some_and(|t| t <= bound::NEUTRAL_S + 1e-9)
        && latched.is_some_and(|t| t <= bound::LATCHED_S + pass_s + 1e-9)
        && ground.is_some_and(|t| t <= bound::GROUND_S + 1e-9);
    Ok(CutRow {
        cut_s,
        last_good_frame_s: r.last_good_frame_s,
        neutral_after_s: neutral,
        latched_after_s: latched,
        ground_after_s: ground,
        met,
    })
}

/// Byte corruption at `rate` on both directions.
pub fn corruption(rate: f64, baud: u32, duration_s: Option<f64>) -> Result<CorruptionRow> {
    let mut sc = topside(PROBE_SCENARIO, baud)?;
    sc.deployment.tether_corruption = rate;
    let out = fly(&sc, duration_s)?;
    let r = &out.report;
    Ok(CorruptionRow {
        rate,
        applied: r.downlinks_applied,
        wrong: r.wrong_commands_applied,
        node_refused: r.node_counters.corrupt,
        topside_refused: r.topside_counters.corrupt,
        rms_last80_m: out.run.summary.rms_position_error_last80_m,
    })
}

/// Every measurement.
pub fn measure(baud: u32, duration_s: Option<f64>, cut_s: f64) -> Result<DeploymentReport> {
    let tracking = TRACKING_SCENARIOS
        .iter()
        .map(|n| tracking(n, baud, duration_s))
        .collect::<Result<Vec<_>>>()?;
    let mut rates = vec![baud];
    if baud != 1_000_000 {
        rates.push(1_000_000);
    }
    let mut latency = rates
        .iter()
        .map(|&b| latency(b, duration_s))
        .collect::<Result<Vec<_>>>()?;
    // At `baud`, the shortest period the half-busy rule allows, when it is not the default.
    let shortest = shortest_link_period_us(baud);
    if latency
        .first()
        .is_some_and(|l| l.link_period_us != shortest)
    {
        latency.push(latency_at(
            baud,
            Some(f64::from(shortest) * 1e-6),
            duration_s,
        )?);
    }
    let delay = SWEEP_LATENCIES_S
        .iter()
        .map(|&l| delay(l, baud, duration_s))
        .collect::<Result<Vec<_>>>()?;
    let delay_ok = delay_met(&delay);
    let cut = cut(cut_s, baud)?;
    let corruption = [1e-3, 1e-2]
        .iter()
        .map(|&r| corruption(r, baud, duration_s))
        .collect::<Result<Vec<_>>>()?;
    Ok(DeploymentReport {
        baud,
        tracking,
        latency,
        delay,
        delay_met: delay_ok,
        cut,
        corruption,
    })
}

fn cm(m: f64) -> String {
    format!("{:.1}", m * 100.0)
}

fn opt_ms(t: Option<f64>) -> String {
    t.map_or("never".into(), |t| format!("{:.1} ms", t * 1e3))
}

/// The report as text tables.
pub fn print(r: &DeploymentReport) {
    let ok = |b: bool| if b { "met" } else { "MISSED" };
    println!(
        "topside layout: the firmware library's topside App and node in process, over the \
         byte-level tether model at {} Bd",
        r.baud
    );
    println!("\ntracking (true position, RMS over the last 80 %, cm): bound onboard x 1.1 + 1 cm");
    println!(
        "{:<22} {:>8} {:>8} {:>8}  verdict",
        "scenario", "onboard", "topside", "bound"
    );
    for t in &r.tracking {
        println!(
            "{:<22} {:>8} {:>8} {:>8}  {}",
            t.scenario,
            cm(t.onboard_rms_last80_m),
            cm(t.topside_rms_last80_m),
            cm(t.bound_m),
            ok(t.met)
        );
    }
    println!("\nsensor-to-thruster latency (IMU sample on the node -> its pulse on the node), {PROBE_SCENARIO}:");
    for l in &r.latency {
        println!(
            "{:>9} Bd, link period {:.1} ms: n {}, p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms (bound p99 <= {} ms: {}); from the oldest sample of the increments p99 {:.1} ms",
            l.baud,
            f64::from(l.link_period_us) * 1e-3,
            l.n,
            l.p50_ms,
            l.p99_ms,
            l.max_ms,
            bound::LATENCY_P99_MS,
            ok(l.met),
            l.p99_oldest_ms
        );
        let max = l.histogram.iter().map(|h| h.1).max().unwrap_or(1).max(1);
        for (b, n) in l.histogram.iter().filter(|h| h.1 > 0) {
            let bar = "#".repeat(((*n as f64 / max as f64) * 40.0).ceil() as usize);
            println!("    {:>6.1}-{:<6.1} ms {:>6} {bar}", b, b + 0.5, n);
        }
    }
    println!(
        "\ndelay margin ({PROBE_SCENARIO}, RMS over the last 80 %, cm): told, within {} cm of the \
         zero-latency run up to {} ms: {}",
        bound::DELAY_GROWTH_M * 100.0,
        bound::DELAY_UP_TO_S * 1e3,
        ok(r.delay_met)
    );
    println!(
        "{:>12} {:>10} {:>10} {:>12} {:>15} {:>14}",
        "one-way ms", "not told", "told", "told delay", "told, node time", "round trip ms"
    );
    for d in &r.delay {
        let line = format!(
            "{:>12.0} {:>10} {:>10} {:>9.0} ms {:>15} {:>14}  {}",
            d.latency_s * 1e3,
            cm(d.rms_not_told_m),
            d.rms_told_m.map_or("over max".into(), cm),
            d.told_delay_s * 1e3,
            d.rms_told_node_time_m.map_or("over max".into(), cm),
            d.round_trip_ms.map_or("none".into(), |t| format!("{t:.1}")),
            d.not_told_lost.as_deref().unwrap_or("")
        );
        println!("{}", line.trim_end());
    }
    let c = &r.cut;
    println!(
        "\ncut at {} s: last good frame on the node at {}; neutral {} after it (<= 100 ms), \
         disarmed and latched {} after it (at 1 s); the ground station saw the loss {} after \
         the cut (<= 250 ms): {}",
        c.cut_s,
        c.last_good_frame_s
            .map_or("never".into(), |t| format!("{t:.4} s")),
        opt_ms(c.neutral_after_s),
        opt_ms(c.latched_after_s),
        opt_ms(c.ground_after_s),
        ok(c.met)
    );
    println!("\nbyte corruption (both directions):");
    for k in &r.corruption {
        println!(
            "  {:.0e}: {} downlinks applied, {} wrong ({}), {} refused by the node, {} uplinks \
             refused by the topside; RMS last 80 % {} cm",
            k.rate,
            k.applied,
            k.wrong,
            ok(k.wrong == 0),
            k.node_refused,
            k.topside_refused,
            cm(k.rms_last80_m)
        );
    }
    println!(
        "\n{}",
        if r.met() {
            "every bound met"
        } else {
            "a bound was missed (above)"
        }
    );
}

/// Arguments of `host-sim deployment`.
#[derive(Debug, clap::Args)]
pub struct DeploymentArgs {
    /// The node link's rate (Bd); the latency is also measured at 1 Mbd.
    #[arg(long, default_value_t = DEFAULT_BAUD)]
    pub baud: u32,
    /// Simulated duration of each run instead of the scenarios' (s).
    #[arg(long)]
    pub duration: Option<f64>,
    /// When the node link is cut in the cut run (s).
    #[arg(long, default_value_t = 60.0)]
    pub cut_at: f64,
    /// Write the report as JSON here too.
    #[arg(long)]
    pub json: Option<std::path::PathBuf>,
}

/// `host-sim deployment`: the report, and whether every bound was met.
pub fn main(a: DeploymentArgs) -> Result<bool> {
    let check = || -> Result<()> {
        sim_world::tether_wire::WireSpec {
            baud: a.baud,
            ..Default::default()
        }
        .validate()
        .map_err(|e| anyhow::anyhow!("--baud: {e}"))?;
        if let Some(d) = a.duration {
            if !(d.is_finite() && d > 0.0) {
                bail!("--duration must be a time > 0 s (got {d})");
            }
        }
        if !(a.cut_at.is_finite() && a.cut_at > 0.0) {
            bail!("--cut-at must be a time > 0 s (got {})", a.cut_at);
        }
        Ok(())
    };
    check().map_err(crate::checks::refused)?;
    let r = measure(a.baud, a.duration, a.cut_at)?;
    print(&r);
    if let Some(p) = &a.json {
        std::fs::write(p, serde_json::to_string_pretty(&r)? + "\n")?;
    }
    Ok(r.met())
}
