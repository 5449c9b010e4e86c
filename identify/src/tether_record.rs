//! A dive's raw tether log (`rov-topside`'s `.tether`, decoded by `topside::tether_log`) as
//! the fit's record: the vehicle's own `Telemetry` frames, each carrying the navigation state its laws
//! flew on (the on-board estimate: DVL velocities, gyro rates, attitude) and the pulse widths
//! written to the ESCs. This is what a real dive leaves at the surface; no plant truth in it.
//!
//! Surge and sway are the DVL's own measurements, which every frame carries (the latest one
//! the vehicle accepted, `Telemetry::dvl`), interpolated linearly between their times of
//! validity to the control period: the estimate between two DVL reports is predicted with
//! the vehicle file the vehicle was given (model-aided), so its surge dynamics would be
//! partly the prior's. A log without DVL reports (a vehicle without one) keeps the estimate's
//! velocities, and says so ([`TetherRecord::velocity`]); a DVL silent longer than
//! [`MAX_DVL_GAP_S`] inside the armed span is refused with its time.
//!
//! The record is the armed span of the log (first to last armed frame). Telemetry comes once
//! per control period; a frame lost on the tether (a corrupted or dropped frame) leaves a gap
//! that is filled by linear interpolation when it is at most [`MAX_FILLED_GAP_PERIODS`]
//! periods long, and counted; a longer gap is refused with its time, since the fit integrates
//! over the record and a long hole would be invented data.

use super::record::{Record, RecordSample};
use anyhow::{bail, Result};
use protocol::Telemetry;
use std::path::Path;

/// The longest gap between two telemetry frames that is filled (control periods).
pub const MAX_FILLED_GAP_PERIODS: u64 = 5;

/// The longest time between two DVL reports bridged by interpolation (s): five periods of
/// a 5 Hz DVL.
pub const MAX_DVL_GAP_S: f64 = 1.0;

/// Where the record's surge and sway velocities come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VelocitySource {
    /// The DVL's measurements in the telemetry (this many distinct reports).
    Dvl {
        /// Distinct DVL reports in the record's span.
        reports: usize,
    },
    /// The on-board estimate (the log holds no DVL report).
    Estimate,
}

/// A record read from a tether log, and what the reading found.
#[derive(Debug, Clone)]
pub struct TetherRecord {
    /// The samples, one per control period of the vehicle's clock.
    pub record: Record,
    /// Telemetry frames missing inside the armed span, filled by interpolation.
    pub filled: usize,
    /// Frames of the log that did not decode (either direction).
    pub dropped_frames: usize,
    /// Where surge and sway come from.
    pub velocity: VelocitySource,
}

fn sample(t: &Telemetry) -> RecordSample {
    let n = &t.nav;
    let f = f64::from;
    RecordSample {
        t_s: t.t_us as f64 * 1e-6,
        vel_m_s: [f(n.u_m_s), f(n.v_m_s), f(n.w_m_s)],
        rate_rad_s: [f(n.p_rad_s), f(n.q_rad_s), f(n.r_rad_s)],
        tilt_rad: [f(n.roll_rad), f(n.pitch_rad)],
        pulse_us: t.pulse_us.map(f64::from),
    }
}

fn lerp(a: &RecordSample, b: &RecordSample, s: f64) -> RecordSample {
    let mix = |x: f64, y: f64| x + (y - x) * s;
    let mix3 = |x: [f64; 3], y: [f64; 3]| [mix(x[0], y[0]), mix(x[1], y[1]), mix(x[2], y[2])];
    RecordSample {
        t_s: mix(a.t_s, b.t_s),
        vel_m_s: mix3(a.vel_m_s, b.vel_m_s),
        rate_rad_s: mix3(a.rate_rad_s, b.rate_rad_s),
        tilt_rad: [
            mix(a.tilt_rad[0], b.tilt_rad[0]),
            mix(a.tilt_rad[1], b.tilt_rad[1]),
        ],
        // The ESCs hold a pulse until the next one: no interpolation.
        pulse_us: a.pulse_us,
    }
}

/// The record of `telemetry` (in the order received): duplicates (a step answered twice)
/// and frames older than the latest are skipped; the armed span is kept.
pub fn from_telemetry<'a>(
    telemetry: impl Iterator<Item = &'a Telemetry>,
    dropped_frames: usize,
    path: &Path,
) -> Result<TetherRecord> {
    let mut armed: Vec<&Telemetry> = Vec::new();
    let mut last_t_us = None;
    for t in telemetry {
        if last_t_us.is_some_and(|l| t.t_us <= l) {
            continue;
        }
        last_t_us = Some(t.t_us);
        armed.push(t);
    }
    let first = armed.iter().position(|t| t.armed);
    let last = armed.iter().rposition(|t| t.armed);
    let (Some(first), Some(last)) = (first, last) else {
        bail!(
            "{}: no armed telemetry in the tether log ({} frames)",
            path.display(),
            armed.len()
        );
    };
    let span = armed.get(first..=last).unwrap_or_default();
    // The control period: the commonest step between frames (lost frames make longer ones).
    let mut steps: Vec<u64> = span
        .windows(2)
        .filter_map(|w| match w {
            [a, b] => Some(b.t_us - a.t_us),
            _ => None,
        })
        .collect();
    steps.sort_unstable();
    let Some(&period_us) = steps.get(steps.len() / 2) else {
        bail!("{}: fewer than two armed telemetry frames", path.display());
    };
    if period_us == 0 {
        bail!("{}: the telemetry's time does not rise", path.display());
    }
    let mut samples: Vec<RecordSample> = Vec::with_capacity(span.len());
    let mut filled = 0usize;
    for pair in span.windows(2) {
        let [a, b] = pair else { continue };
        let (sa, sb) = (sample(a), sample(b));
        if samples.is_empty() {
            samples.push(sa);
        }
        let periods = (b.t_us - a.t_us + period_us / 2) / period_us;
        if periods > MAX_FILLED_GAP_PERIODS {
            bail!(
                "{}: no telemetry for {:.3} s after t = {:.3} s on the vehicle's clock \
                 (at most {MAX_FILLED_GAP_PERIODS} control periods are filled)",
                path.display(),
                (b.t_us - a.t_us) as f64 * 1e-6,
                sa.t_s
            );
        }
        for k in 1..periods {
            samples.push(lerp(&sa, &sb, k as f64 / periods as f64));
            filled += 1;
        }
        samples.push(sb);
    }
    let mut record = Record { samples };
    let velocity = dvl_velocities(&mut record, span, path)?;
    record.check()?;
    Ok(TetherRecord {
        record,
        filled,
        dropped_frames,
        velocity,
    })
}

/// The distinct DVL reports of `span`, in time order: `(t_s, [u, v])`.
fn dvl_reports(span: &[&Telemetry]) -> Vec<(f64, [f64; 2])> {
    let mut out: Vec<(f64, [f64; 2])> = Vec::new();
    let mut last_t_us = 0u64;
    for t in span {
        let d = t.dvl;
        if d.is_some() && d.t_us > last_t_us {
            last_t_us = d.t_us;
            out.push((d.t_us as f64 * 1e-6, d.velocity_m_s.map(f64::from)));
        }
    }
    out
}

/// `s`'s surge and sway set to `uv_m_s`, and its heave made again from the depth rate with
/// them: the estimator's body heave is its depth rate turned to the body axes with its own
/// surge and sway (`w = (z_dot + s_theta u - c_theta s_phi v) / (c_theta c_phi)`), so at a
/// few degrees of pitch its surge's error is in the heave too.
fn set_horizontal(s: &mut RecordSample, uv_m_s: [f64; 2]) {
    let [u, v, w] = s.vel_m_s;
    let [roll, pitch] = s.tilt_rad;
    let (sr, cr) = roll.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    let den = cp * cr;
    let [u_m, v_m] = uv_m_s;
    s.vel_m_s = [u_m, v_m, w];
    // As the estimator turns it (a steeper tilt keeps the depth rate itself).
    if den > 0.1 {
        let z_dot = -sp * u + cp * sr * v + den * w;
        s.vel_m_s[2] = (z_dot + sp * u_m - cp * sr * v_m) / den;
    }
}

/// Surge and sway of `record` replaced by the DVL's reports, interpolated to each sample's
/// time; the samples outside the reports' span are dropped (nothing is extrapolated). The
/// estimate's velocities stay when the span holds no DVL report.
fn dvl_velocities(record: &mut Record, span: &[&Telemetry], path: &Path) -> Result<VelocitySource> {
    with_dvl_reports(record, &dvl_reports(span), path)
}

/// Surge and sway of `record` replaced by the DVL's `reports` (time of validity on the
/// vehicle's clock (s), measured surge and sway (m/s), in time order), as
/// [`dvl_velocities`] does; `path` names the log in the errors.
pub fn with_dvl_reports(
    record: &mut Record,
    reports: &[(f64, [f64; 2])],
    path: &Path,
) -> Result<VelocitySource> {
    let (Some(&(first, _)), Some(&(last, _))) = (reports.first(), reports.last()) else {
        return Ok(VelocitySource::Estimate);
    };
    for pair in reports.windows(2) {
        if let [(ta, _), (tb, _)] = pair {
            if tb - ta > MAX_DVL_GAP_S {
                bail!(
                    "{}: no DVL report for {:.3} s after t = {ta:.3} s on the vehicle's clock \
                     (at most {MAX_DVL_GAP_S} s is bridged)",
                    path.display(),
                    tb - ta
                );
            }
        }
    }
    record.samples.retain(|s| s.t_s >= first && s.t_s <= last);
    let mut k = 0usize;
    for s in &mut record.samples {
        while reports.get(k + 1).is_some_and(|&(t, _)| t < s.t_s) {
            k += 1;
        }
        let (Some(&(ta, va)), Some(&(tb, vb))) = (reports.get(k), reports.get(k + 1)) else {
            // The last report's own time.
            if let Some(&(_, v)) = reports.get(k) {
                set_horizontal(s, v);
            }
            continue;
        };
        let w = if tb > ta {
            (s.t_s - ta) / (tb - ta)
        } else {
            0.0
        };
        set_horizontal(
            s,
            [va[0] + (vb[0] - va[0]) * w, va[1] + (vb[1] - va[1]) * w],
        );
    }
    Ok(VelocitySource::Dvl {
        reports: reports.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn telemetry(t_ms: u64, armed: bool, u: f32) -> Telemetry {
        let mut t = Telemetry {
            t_us: t_ms * 1000,
            armed,
            pulse_us: [1600, 1400, 1500],
            ..Telemetry::default()
        };
        t.nav.u_m_s = u;
        t
    }

    #[test]
    fn the_armed_span_is_kept_and_a_lost_frame_is_filled() {
        let mut frames: Vec<Telemetry> = (0..5).map(|k| telemetry(20 * k, false, 0.0)).collect();
        frames.extend(
            (5..300)
                .filter(|&k| k != 100)
                .map(|k| telemetry(20 * k, true, k as f32)),
        );
        frames.push(telemetry(20 * 300, false, 0.0));
        let r = from_telemetry(frames.iter(), 3, Path::new("log")).unwrap();
        assert_eq!(r.velocity, VelocitySource::Estimate);
        assert_eq!(r.filled, 1);
        assert_eq!(r.dropped_frames, 3);
        assert_eq!(r.record.samples.len(), 295);
        assert!((r.record.samples[0].t_s - 0.1).abs() < 1e-9);
        let gap = &r.record.samples[95];
        assert!((gap.t_s - 2.0).abs() < 1e-9 && (gap.vel_m_s[0] - 100.0).abs() < 1e-6);
        assert_eq!(gap.pulse_us, [1600.0, 1400.0, 1500.0]);
        assert!((r.record.period_s() - 0.02).abs() < 1e-9);
    }

    #[test]
    fn a_long_gap_and_a_log_never_armed_are_refused_with_their_reason() {
        let mut frames: Vec<Telemetry> = (0..200).map(|k| telemetry(20 * k, true, 0.1)).collect();
        frames.extend((210..400).map(|k| telemetry(20 * k, true, 0.1)));
        let e = from_telemetry(frames.iter(), 0, Path::new("log")).unwrap_err();
        assert!(e.to_string().contains("no telemetry for 0.220 s"), "{e}");
        let idle: Vec<Telemetry> = (0..200).map(|k| telemetry(20 * k, false, 0.0)).collect();
        let e = from_telemetry(idle.iter(), 0, Path::new("log")).unwrap_err();
        assert!(e.to_string().contains("no armed telemetry"), "{e}");
    }

    /// Telemetry every 20 ms whose estimate says `u = 9`, with a DVL report every 200 ms
    /// (valid 40 ms before the frame that first carries it) of `u = t`, `v = -t`; none
    /// between `gap_ms.0` and `gap_ms.1`.
    fn with_dvl(gap_ms: (u64, u64)) -> Vec<Telemetry> {
        let mut dvl = protocol::DvlReport::default();
        (0..500u64)
            .map(|k| {
                let t_ms = 20 * k;
                let mut t = telemetry(t_ms, true, 9.0);
                let due = t_ms >= 40 && (t_ms - 40) % 200 == 0;
                if due && !(gap_ms.0..gap_ms.1).contains(&t_ms) {
                    let valid_s = (t_ms - 40) as f32 * 1e-3;
                    dvl = protocol::DvlReport {
                        t_us: (t_ms - 40) * 1000,
                        velocity_m_s: [valid_s, -valid_s],
                    };
                }
                t.dvl = dvl;
                t
            })
            .collect()
    }

    #[test]
    fn surge_and_sway_are_the_dvl_s_reports_interpolated_not_the_estimate() {
        let frames = with_dvl((0, 0));
        let r = from_telemetry(frames.iter(), 0, Path::new("log")).unwrap();
        assert!(matches!(r.velocity, VelocitySource::Dvl { reports: 49 }));
        // The first report is valid at 0 s (t_us 0 means none): the span starts at 0.2 s.
        let first = r.record.samples.first().unwrap();
        assert!((first.t_s - 0.2).abs() < 1e-9, "{}", first.t_s);
        let last = r.record.samples.last().unwrap();
        assert!((last.t_s - 9.8).abs() < 1e-9, "{}", last.t_s);
        for s in &r.record.samples {
            assert!((s.vel_m_s[0] - s.t_s).abs() < 1e-5, "{s:?}");
            assert!((s.vel_m_s[1] + s.t_s).abs() < 1e-5, "{s:?}");
        }
    }

    #[test]
    fn a_silent_dvl_is_refused_with_its_time() {
        let frames = with_dvl((2_000, 3_500));
        let e = from_telemetry(frames.iter(), 0, Path::new("log")).unwrap_err();
        assert!(
            e.to_string()
                .contains("no DVL report for 1.800 s after t = 1.800 s"),
            "{e}"
        );
    }

    #[test]
    fn a_step_answered_twice_counts_once() {
        let mut frames: Vec<Telemetry> = (0..200).map(|k| telemetry(20 * k, true, 0.1)).collect();
        frames.insert(50, telemetry(20 * 49, true, 0.1));
        let r = from_telemetry(frames.iter(), 0, Path::new("log")).unwrap();
        assert_eq!(r.record.samples.len(), 200);
        assert_eq!(r.filled, 0);
    }
}
