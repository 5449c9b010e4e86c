//! `host-sim replay LOG`: the figures of a simulated run, drawn from a recorded dive (a
//! `.tlog` of `rov-topside`, QGroundControl or MAVProxy).
//!
//! A `.tlog` is a sequence of records: an 8-byte big-endian UNIX time in microseconds, then
//! one MAVLink frame (v2, or v1). The vehicle's `LOCAL_POSITION_NED` gives the time (its
//! `time_boot_ms`), position and velocity of each sample; the latest `ATTITUDE` the attitude
//! and rates; the latest `SERVO_OUTPUT_RAW` the three pulse widths, turned into thrust through
//! the Observer's pulse curve. There is no reference in a log, so the error panels stay empty;
//! `summary.json` counts what was read.

use crate::closed_loop::{RunOutput, Sample, Summary};
use anyhow::{bail, Context, Result};
use controller_core::alloc::PwmMap;
use controller_core::params::{Vehicle, VehicleParams};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::MavlinkReader;
use std::path::{Path, PathBuf};

/// `host-sim replay` options.
#[derive(clap::Args, Debug, Clone)]
pub struct ReplayArgs {
    /// The .tlog to draw.
    pub log: PathBuf,
    /// Output folder (default out/replay-<log stem>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// One record of a .tlog.
#[derive(Debug, Clone)]
pub struct TlogRecord {
    /// UNIX time of the record (us).
    pub unix_us: u64,
    /// Sender's system id.
    pub system_id: u32,
    /// The message.
    pub msg: MavMessage,
}

/// Read every record of a .tlog; frames that do not parse (another dialect, damage) are
/// skipped and counted.
pub fn read_tlog(path: &Path) -> Result<(Vec<TlogRecord>, u64)> {
    let bytes = std::fs::read(path).with_context(|| format!("read {}", path.display()))?;
    let mut out = Vec::new();
    let mut skipped = 0u64;
    let mut i = 0usize;
    while i + 8 < bytes.len() {
        let unix_us = u64::from_be_bytes(bytes[i..i + 8].try_into()?);
        let rest = &bytes[i + 8..];
        let len = match rest.first() {
            // v2: 10-byte header, payload, CRC, optional 13-byte signature.
            Some(0xFD) if rest.len() >= 3 => {
                let sig = if rest[2] & 1 != 0 { 13 } else { 0 };
                10 + usize::from(rest[1]) + 2 + sig
            }
            // v1: 6-byte header, payload, CRC.
            Some(0xFE) if rest.len() >= 2 => 6 + usize::from(rest[1]) + 2,
            _ => bail!(
                "{}: byte {} is not the start of a MAVLink frame: not a .tlog",
                path.display(),
                i + 8
            ),
        };
        if rest.len() < len {
            // A record cut off at the end (the recorder was stopped mid-write).
            skipped += 1;
            break;
        }
        let mut r = MavlinkReader::new(&rest[..len]);
        match r.read_any_message::<MavMessage>() {
            Ok((header, msg)) => out.push(TlogRecord {
                unix_us,
                system_id: header.system_id,
                msg,
            }),
            Err(_) => skipped += 1,
        }
        i += 8 + len;
    }
    Ok((out, skipped))
}

/// The samples of a dive: one per `LOCAL_POSITION_NED` of the vehicle (system `vehicle_id`).
pub fn samples(records: &[TlogRecord], vehicle_id: u32) -> Vec<Sample> {
    let pwm = PwmMap::for_vehicle(&Vehicle::observer());
    let lever = f64::from(VehicleParams::OBSERVER.thruster_lever_arm_m);
    let mut att = [0.0f64; 6];
    let mut pulses = [1500.0f64; 3];
    let mut out = Vec::new();
    for r in records.iter().filter(|r| r.system_id == vehicle_id) {
        match &r.msg {
            MavMessage::ATTITUDE(a) => {
                att = [
                    a.roll,
                    a.pitch,
                    a.yaw,
                    a.rollspeed,
                    a.pitchspeed,
                    a.yawspeed,
                ]
                .map(f64::from);
            }
            MavMessage::SERVO_OUTPUT_RAW(s) => {
                pulses = [s.servo1_raw, s.servo2_raw, s.servo3_raw].map(f64::from);
            }
            MavMessage::LOCAL_POSITION_NED(p) => {
                let (sy, cy) = att[2].sin_cos();
                let (vx, vy) = (f64::from(p.vx), f64::from(p.vy));
                let thrust = pulses.map(|us| f64::from(pwm.thrust_n(us as f32)));
                let forces = [
                    thrust[0] + thrust[1],
                    lever * (thrust[0] - thrust[1]),
                    thrust[2],
                ];
                let mut s = Sample {
                    t_s: f64::from(p.time_boot_ms) * 1e-3,
                    nav_pos_m: [p.x, p.y, p.z].map(f64::from),
                    ref_pos_m: [f64::NAN; 3],
                    ref_vel_m_s: [f64::NAN; 3],
                    pos_err_m: [f64::NAN; 3],
                    pos_err_norm_m: f64::NAN,
                    vel_err_m_s: [f64::NAN; 3],
                    angle_err_rad: f64::NAN,
                    requested: forces,
                    achieved: forces,
                    thrust_cmd_n: thrust,
                    thrust_n: thrust,
                    pulse_us: pulses,
                    ..Sample::default()
                };
                s.state.eta = [
                    f64::from(p.x),
                    f64::from(p.y),
                    f64::from(p.z),
                    att[0],
                    att[1],
                    att[2],
                ];
                s.state.nu = [
                    cy * vx + sy * vy,
                    -sy * vx + cy * vy,
                    f64::from(p.vz),
                    att[3],
                    att[4],
                    att[5],
                ];
                out.push(s);
            }
            _ => {}
        }
    }
    out
}

/// Read a .tlog and write the run's files (summary, CSV, figures) into `dir`.
pub fn replay(log: &Path, dir: &Path) -> Result<RunOutput> {
    let (records, skipped) = read_tlog(log)?;
    // The vehicle: the sender of submarine heartbeats, or else the first sender of positions.
    let vehicle_id = records
        .iter()
        .find_map(|r| match &r.msg {
            MavMessage::HEARTBEAT(h)
                if h.mavtype == mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_SUBMARINE =>
            {
                Some(r.system_id)
            }
            _ => None,
        })
        .or_else(|| {
            records.iter().find_map(|r| {
                matches!(r.msg, MavMessage::LOCAL_POSITION_NED(_)).then_some(r.system_id)
            })
        });
    let Some(vehicle_id) = vehicle_id else {
        bail!("{}: no vehicle positions in the log", log.display());
    };
    let log_samples = samples(&records, vehicle_id);
    if log_samples.len() < 2 {
        bail!(
            "{}: fewer than two LOCAL_POSITION_NED samples",
            log.display()
        );
    }
    let first = log_samples[0].state.eta;
    let last = log_samples[log_samples.len() - 1];
    let name = log
        .file_stem()
        .map_or("replay".into(), |s| s.to_string_lossy().to_string());
    let summary = Summary {
        scenario: name,
        plane: "3d".into(),
        controller: "recorded".into(),
        reference: "none".into(),
        duration_s: last.t_s - log_samples[0].t_s,
        simulated_s: last.t_s,
        final_position_error_m: f64::NAN,
        max_abs_thruster_force_n: log_samples
            .iter()
            .flat_map(|s| s.thrust_n)
            .fold(0.0, |a: f64, f| a.max(f.abs())),
        stop_reason: format!(
            "replayed {} records ({} skipped) of {} samples",
            records.len(),
            skipped,
            log_samples.len()
        ),
        verdict: format!(
            "recorded dive: moved {:.2} m north, {:.2} m east, {:.2} m down",
            last.state.eta[0] - first[0],
            last.state.eta[1] - first[1],
            last.state.eta[2] - first[2]
        ),
        control_steps: log_samples.len() as u64,
        final_state: last
            .state
            .eta
            .iter()
            .chain(last.state.nu.iter())
            .copied()
            .collect(),
        ..Summary::default()
    };
    let out = RunOutput {
        summary,
        log: log_samples,
        usbl_fixes: Vec::new(),
    };
    crate::output::write_run(dir, &out)?;
    Ok(out)
}

/// `host-sim replay`.
pub fn main(a: ReplayArgs) -> Result<()> {
    let dir = a.out.clone().unwrap_or_else(|| {
        let stem = a
            .log
            .file_stem()
            .map_or("log".into(), |s| s.to_string_lossy().to_string());
        PathBuf::from("out").join(format!("replay-{stem}"))
    });
    let out = replay(&a.log, &dir)?;
    println!("{}: {}", out.summary.stop_reason, out.summary.verdict);
    println!("outputs in {}", dir.display());
    Ok(())
}
