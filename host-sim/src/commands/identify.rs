//! `host-sim identify LOG --out vehicle.toml`: a vehicle's model fitted from a recorded run
//! (a dive's raw tether log as `rov-topside` writes it, a run's `timeseries.csv`, or the
//! run's folder holding one), written as a vehicle file that
//! `vehicle = ...` and the surface's `--vehicle` load; the validation figure beside it.
//! docs/identification.md describes the manoeuvre, the fit and the anchor.

use super::replay::{self, read_tlog};
use crate::checks::refused;
use anyhow::{anyhow, bail, Context, Result};
use identify::physical::MODEL_NAMES;
use identify::record::RecordSample;
use identify::sway::{Sway, SWAY_NAMES};
use identify::thrusters::ThrustCurve;
use identify::{tether_record, vehicle_file::anchor_text, Anchor, Record};
use sim_scenario::vehicle;
use std::path::{Path, PathBuf};

/// `host-sim identify` options.
#[derive(clap::Args, Debug, Clone)]
pub struct IdentifyArgs {
    /// A dive's tether log (`rov-topside`'s `.tether`: the vehicle's own telemetry), a run's
    /// `timeseries.csv`, or the run's output folder.
    pub log: PathBuf,
    /// The vehicle file to write.
    #[arg(long)]
    pub out: PathBuf,
    /// The vehicle file the vehicle flew the manoeuvre with (its pulse curve, dry mass,
    /// rigid inertias and the terms not fitted); the Observer's by default.
    #[arg(long, value_name = "FILE")]
    pub prior: Option<PathBuf>,
    /// The installed thrusters' published curve (a thruster file: `max_forward_n`,
    /// `max_reverse_n`, `error` as a 95 % fraction, optional `[pulse]`): the record's thrust
    /// is computed with it, and its thrust ahead gives the force scale within its error, so
    /// the net buoyancy is identified.
    #[arg(long, value_name = "FILE")]
    pub thrusters: Option<PathBuf>,
    /// The net buoyancy B - W (N, positive floats up) measured by weighing the vehicle in
    /// water: a force scale, so that the thrust scales are identified too; with
    /// `--thrusters` the two are combined. With neither, the prior's thrust curve ahead is
    /// taken as exact.
    #[arg(long, value_name = "N", allow_hyphen_values = true)]
    pub net_buoyancy_n: Option<f64>,
    /// Standard deviation of `--net-buoyancy-n` (N).
    #[arg(long, value_name = "N", default_value_t = 0.05)]
    pub net_buoyancy_std_n: f64,
    /// The validation figure (default: beside --out, `<out stem>-validation.png`).
    #[arg(long, value_name = "PNG")]
    pub plot: Option<PathBuf>,
}

/// The record named by `log` (a tether log, a `.tlog`, a `timeseries.csv` or a run folder).
pub fn read_log(log: &Path) -> Result<Record> {
    let path = if log.is_dir() {
        log.join("timeseries.csv")
    } else {
        log.to_path_buf()
    };
    let mut head = [0u8; 32];
    let n = std::fs::File::open(&path)
        .and_then(|mut f| std::io::Read::read(&mut f, &mut head))
        .with_context(|| format!("cannot read {}", path.display()))?;
    if head
        .get(..n)
        .is_some_and(|h| h.starts_with(topside::tether_log::MAGIC))
    {
        let frames = topside::tether_log::decode(&topside::tether_log::read(&path)?);
        let telemetry = frames.replies.iter().filter_map(|(_, _, r)| match r {
            protocol::Reply::Telemetry(t) => Some(t),
            _ => None,
        });
        let t = tether_record::from_telemetry(telemetry, frames.dropped, &path)?;
        let velocity = match t.velocity {
            tether_record::VelocitySource::Dvl { reports } => {
                format!("surge and sway from {reports} DVL reports")
            }
            tether_record::VelocitySource::Estimate => {
                "no DVL report: surge and sway from the on-board estimate, which is \
                 model-aided with the prior (the surge values lean toward it)"
                    .to_string()
            }
        };
        println!(
            "{}: the vehicle's telemetry, {} samples ({} lost frames filled, {} undecodable \
             frames in the log); {velocity}",
            path.display(),
            t.record.samples.len(),
            t.filled,
            t.dropped_frames
        );
        return Ok(t.record);
    }
    // A .tlog: an 8-byte time stamp, then a MAVLink frame's start.
    if head.get(8).is_some_and(|b| *b == 0xFD || *b == 0xFE)
        || path.extension().is_some_and(|e| e == "tlog")
    {
        let (records, undecoded) = read_tlog(&path)?;
        let t =
            record_from_tlog(&records).with_context(|| format!("{}: the .tlog", path.display()))?;
        let velocity = match t.velocity {
            tether_record::VelocitySource::Dvl { reports } => format!(
                "surge and sway from {reports} DVL reports (DEBUG_VECT \"{DVL_DEBUG_VECT}\"); \
                 rates, attitude and heave the on-board estimate's"
            ),
            tether_record::VelocitySource::Estimate => "velocities, rates and attitude the \
                 on-board estimate's (no DVL report in the log): surge leans toward the vehicle \
                 file the vehicle flew with"
                .to_string(),
        };
        println!(
            "{}: the surface's MAVLink log, {} samples at {:.1} Hz of the vehicle's clock ({} \
             filled, {} undecodable frames); {velocity}",
            path.display(),
            t.record.samples.len(),
            1.0 / t.record.period_s(),
            t.filled,
            undecoded
        );
        return Ok(t.record);
    }
    Record::from_timeseries_csv(&path)
}

/// Run `host-sim identify`.
pub fn main(a: IdentifyArgs) -> Result<()> {
    let weighed = match a.net_buoyancy_n {
        None => None,
        Some(v) => {
            if !v.is_finite() || v.abs() < 0.2 {
                return Err(refused(anyhow!(
                    "--net-buoyancy-n {v}: a measured net buoyancy of at least 0.2 N either way \
                     (a neutral vehicle gives no force scale; leave it out to use the thrust curve)"
                )));
            }
            if !(a.net_buoyancy_std_n.is_finite() && a.net_buoyancy_std_n >= 0.0) {
                return Err(refused(anyhow!(
                    "--net-buoyancy-std-n must be finite and >= 0"
                )));
            }
            Some((v, a.net_buoyancy_std_n))
        }
    };
    let flown = match &a.prior {
        Some(p) => vehicle::load(p).map_err(refused)?,
        None => vehicle::parse(vehicle::OBSERVER_TOML, "observer.toml")?,
    };
    let (prior, anchor) = match &a.thrusters {
        Some(file) => {
            let curve = ThrustCurve::load(file).map_err(refused)?;
            (
                curve.installed_in(&flown).map_err(refused)?,
                curve.anchor(weighed),
            )
        }
        None => (
            flown,
            match weighed {
                Some((value_n, std_n)) => Anchor::NetBuoyancy { value_n, std_n },
                None => Anchor::ThrustCurve { rel_std: 0.0 },
            },
        ),
    };
    let rec = read_log(&a.log).map_err(refused)?;
    let out = identify::identify(&rec, &prior, anchor).map_err(refused)?;
    let source = a.log.display().to_string();
    vehicle::check(&out.params)
        .context("the identified vehicle is not flyable; nothing written")?;
    let text = identify::vehicle_file::to_toml(&out.params, &out.identified, &out.sway, &source)?;
    // The file must load as written (a round trip through the same parser as `vehicle =`).
    vehicle::parse(&text, "the identified file")?;
    std::fs::write(&a.out, &text).with_context(|| format!("cannot write {}", a.out.display()))?;
    let plot = a.plot.clone().unwrap_or_else(|| {
        let stem = a
            .out
            .file_stem()
            .map_or_else(|| "vehicle".into(), |s| s.to_string_lossy().into_owned());
        a.out.with_file_name(format!("{stem}-validation.png"))
    });
    crate::output::identify_plot::plot(&plot, &out.validation, &out.prior_validation)?;
    let id = &out.identified;
    println!("identified from {source} ({} samples):", rec.samples.len());
    println!("  force scale: {}", anchor_text(anchor));
    for (((name, unit), v), (lo, hi)) in MODEL_NAMES
        .iter()
        .zip(id.model.values())
        .zip(id.lo.iter().zip(id.hi.iter()))
    {
        println!("  {name:<22} {v:>10.4}  95 % [{lo:.4}, {hi:.4}] {unit}");
    }
    match &out.sway {
        Sway::Fitted(s) => {
            for (((name, unit), v), (lo, hi)) in SWAY_NAMES
                .iter()
                .zip(s.values())
                .zip(s.lo.iter().zip(s.hi.iter()))
            {
                println!("  {name:<22} {v:>10.4}  95 % [{lo:.4}, {hi:.4}] {unit}");
            }
            if let Some(why) = &s.drags_not_determined {
                println!("  {why}");
            }
            println!(
                "  sway from the turns: held-out RMS v {:.4} m/s (the prior's ratios: {:.4})",
                s.held_out_rms_m_s, s.ratios_held_out_rms_m_s
            );
        }
        Sway::Prior { reason } => {
            println!("  sway: the prior's ratios to surge, +-50 % (not measured: {reason})")
        }
    }
    let [su, sr, sw] = out.validation.rms();
    let [pu, pr, pw] = out.prior_validation.rms();
    println!(
        "held-out RMS (identified / prior): u {su:.4} / {pu:.4} m/s, r {sr:.4} / {pr:.4} rad/s, w {sw:.4} / {pw:.4} m/s"
    );
    println!("wrote {} and {}", a.out.display(), plot.display());
    if !(su.is_finite() && sr.is_finite() && sw.is_finite()) {
        bail!("the identified model's prediction is not finite");
    }
    Ok(())
}

/// A record read from a `.tlog`, and what the reading found.
pub struct TlogRecord {
    /// The samples, on a steady period of the vehicle's clock.
    pub record: Record,
    /// Samples missing inside the armed span, filled by interpolation.
    pub filled: usize,
    /// Where surge and sway come from.
    pub velocity: tether_record::VelocitySource,
}

/// The `DEBUG_VECT` name under which a DVL's report is read from a `.tlog`: `time_usec` its
/// time of validity on the vehicle's clock, `x`, `y` the measured surge and sway (m/s). The
/// surface does not send it yet (docs/identification.md: what a `.tlog` lacks).
pub const DVL_DEBUG_VECT: &str = "DVL";

/// The longest gap between two samples of a `.tlog` that is filled (stream periods).
pub const TLOG_MAX_FILLED_PERIODS: u64 = 5;

/// One period of the surface's streams, as far as it was read.
#[derive(Default)]
struct Partial {
    t_ms: u32,
    attitude: Option<[f64; 6]>,
    velocity_ned: Option<[f64; 3]>,
    pulses: Option<[f64; 3]>,
}

impl Partial {
    /// The sample, when the period's three messages were read: body `u`, `v` from the NED
    /// velocity turned by the yaw; `w` is what the surface sends as `vz` (the body heave).
    fn sample(&self) -> Option<(u64, RecordSample)> {
        let [roll, pitch, yaw, p, q, r] = self.attitude?;
        let [vn, ve, w] = self.velocity_ned?;
        let (sy, cy) = yaw.sin_cos();
        Some((
            u64::from(self.t_ms) * 1000,
            RecordSample {
                t_s: f64::from(self.t_ms) * 1e-3,
                vel_m_s: [cy * vn + sy * ve, -sy * vn + cy * ve, w],
                rate_rad_s: [p, q, r],
                tilt_rad: [roll, pitch],
                pulse_us: self.pulses?,
            },
        ))
    }
}

/// The fit's record from a `.tlog` of `rov-topside`: per period of its streams, the
/// vehicle's `ATTITUDE` (attitude, body rates), `LOCAL_POSITION_NED` (NED velocity; `vz` the
/// body heave) and `SERVO_OUTPUT_RAW` (the three pulses) stamped with the same time of the
/// vehicle's clock; the span while the vehicle's `HEARTBEAT` says armed; gaps of at most
/// [`TLOG_MAX_FILLED_PERIODS`] periods filled by interpolation, a longer one refused.
pub fn record_from_tlog(records: &[replay::TlogRecord]) -> Result<TlogRecord> {
    use mavlink::dialects::ardupilotmega::{MavMessage, MavModeFlag, MavType};
    let vehicle = records
        .iter()
        .find_map(|r| match &r.msg {
            MavMessage::HEARTBEAT(h) if h.mavtype == MavType::MAV_TYPE_SUBMARINE => {
                Some(r.system_id)
            }
            _ => None,
        })
        .ok_or_else(|| anyhow!("no submarine's HEARTBEAT: no vehicle in the log"))?;
    let mut armed = false;
    let mut dvl: Vec<(f64, [f64; 2])> = Vec::new();
    let mut cur = Partial::default();
    let mut timed: Vec<(u64, RecordSample)> = Vec::new();
    let mut push = |p: &Partial, armed: bool| {
        if let (true, Some(s)) = (armed, p.sample()) {
            if timed.last().is_none_or(|(t, _)| s.0 > *t) {
                timed.push(s);
            }
        }
    };
    for r in records.iter().filter(|r| r.system_id == vehicle) {
        match &r.msg {
            MavMessage::HEARTBEAT(h) => {
                armed = h
                    .base_mode
                    .contains(MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED);
            }
            MavMessage::DEBUG_VECT(d) if d.name.to_str() == Ok(DVL_DEBUG_VECT) => {
                let t_s = d.time_usec as f64 * 1e-6;
                if dvl.last().is_none_or(|(t, _)| t_s > *t) {
                    dvl.push((t_s, [f64::from(d.x), f64::from(d.y)]));
                }
            }
            MavMessage::ATTITUDE(a) => {
                push(&cur, armed);
                cur = Partial {
                    t_ms: a.time_boot_ms,
                    attitude: Some(
                        [
                            a.roll,
                            a.pitch,
                            a.yaw,
                            a.rollspeed,
                            a.pitchspeed,
                            a.yawspeed,
                        ]
                        .map(f64::from),
                    ),
                    ..Partial::default()
                };
            }
            MavMessage::LOCAL_POSITION_NED(l) if l.time_boot_ms == cur.t_ms => {
                cur.velocity_ned = Some([l.vx, l.vy, l.vz].map(f64::from));
            }
            // SERVO_OUTPUT_RAW's time is the vehicle's clock in microseconds, 32 bits.
            MavMessage::SERVO_OUTPUT_RAW(o) if o.time_usec == cur.t_ms.wrapping_mul(1000) => {
                cur.pulses = Some([o.servo1_raw, o.servo2_raw, o.servo3_raw].map(f64::from));
            }
            _ => {}
        }
    }
    push(&cur, armed);
    let mut steps: Vec<u64> = timed.windows(2).map(|w| w[1].0 - w[0].0).collect();
    steps.sort_unstable();
    let Some(&period_us) = steps.get(steps.len() / 2) else {
        bail!("fewer than two armed samples (ATTITUDE, LOCAL_POSITION_NED and SERVO_OUTPUT_RAW of one period)");
    };
    let mut samples = Vec::with_capacity(timed.len());
    let mut filled = 0usize;
    for w in timed.windows(2) {
        let [(ta, a), (tb, b)] = w else { continue };
        if samples.is_empty() {
            samples.push(*a);
        }
        let periods = (tb - ta + period_us / 2) / period_us.max(1);
        if periods > TLOG_MAX_FILLED_PERIODS {
            bail!(
                "no sample for {:.3} s after t = {:.3} s on the vehicle's clock (at most \
                 {TLOG_MAX_FILLED_PERIODS} stream periods of {:.3} s are filled)",
                (tb - ta) as f64 * 1e-6,
                *ta as f64 * 1e-6,
                period_us as f64 * 1e-6
            );
        }
        for k in 1..periods {
            let f = k as f64 / periods as f64;
            let mix = |x: f64, y: f64| x + (y - x) * f;
            samples.push(RecordSample {
                t_s: mix(a.t_s, b.t_s),
                vel_m_s: std::array::from_fn(|i| mix(a.vel_m_s[i], b.vel_m_s[i])),
                rate_rad_s: std::array::from_fn(|i| mix(a.rate_rad_s[i], b.rate_rad_s[i])),
                tilt_rad: std::array::from_fn(|i| mix(a.tilt_rad[i], b.tilt_rad[i])),
                pulse_us: a.pulse_us,
            });
            filled += 1;
        }
        samples.push(*b);
    }
    // On the steady period: the time of each sample is its place in it.
    let t0 = samples.first().map_or(0.0, |s| s.t_s);
    let dt = period_us as f64 * 1e-6;
    let mut k = 0.0;
    for s in &mut samples {
        s.t_s = t0 + k * dt;
        k += 1.0;
    }
    let mut record = Record { samples };
    let velocity = tether_record::with_dvl_reports(&mut record, &dvl, Path::new("the .tlog"))?;
    Ok(TlogRecord {
        record,
        filled,
        velocity,
    })
}
