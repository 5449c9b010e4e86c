//! `host-sim identify LOG --out vehicle.toml`: a vehicle's model fitted from a recorded run
//! (a dive's raw tether log as `rov-topside` writes it, a run's `timeseries.csv`, or the
//! run's folder holding one), written as a vehicle file that
//! `vehicle = ...` and the surface's `--vehicle` load; the validation figure beside it.
//! docs/identification.md describes the manoeuvre, the fit and the anchor.

use crate::checks::refused;
use anyhow::{anyhow, bail, Context, Result};
use identify::physical::MODEL_NAMES;
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

/// The record named by `log` (a tether log, a `timeseries.csv` or a run folder).
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
