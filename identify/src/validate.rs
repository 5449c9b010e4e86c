//! Validation on the held-out blocks: each axis's velocity simulated from the block's first
//! recorded value with the recorded thrust and couplings (an output-error prediction, the
//! fitted model alone carrying the axis through the block), against the recorded one. The
//! prior is simulated the same way, so the figure says how much the fit improved.

use super::fit::{axis_series, in_fit_part, Axis};
use super::record::Record;
use crate::output::plots::{init_font, FONT_NAME};
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

/// One axis's acceleration under the regression parameters `theta` at sample `k` with its
/// own velocity `x` (the recorded one in the coupling terms, the pitch acceleration by
/// central differences).
fn accel(
    axis: Axis,
    theta: &[f64],
    rec: &Record,
    thrust: &[[f64; 3]],
    lever_arm_m: f64,
    k: usize,
    x: f64,
) -> f64 {
    let mut s = rec.samples[k];
    match axis {
        Axis::Surge => s.vel_m_s[0] = x,
        Axis::Yaw => s.rate_rad_s[2] = x,
        Axis::Heave => s.vel_m_s[2] = x,
    }
    let one = Record { samples: vec![s] };
    let series = axis_series(axis, &one, &thrust[k..=k], lever_arm_m);
    let mut a: f64 = series.phi[0].iter().zip(theta).map(|(p, t)| p * t).sum();
    if axis == Axis::Surge {
        let lo = k.saturating_sub(1);
        let hi = (k + 1).min(rec.samples.len() - 1);
        let dt = rec.samples[hi].t_s - rec.samples[lo].t_s;
        if dt > 0.0 {
            let q_dot = (rec.samples[hi].rate_rad_s[1] - rec.samples[lo].rate_rad_s[1]) / dt;
            a += theta.last().copied().unwrap_or(0.0) * q_dot;
        }
    }
    a
}

fn recorded(axis: Axis, rec: &Record, k: usize) -> f64 {
    let s = &rec.samples[k];
    match axis {
        Axis::Surge => s.vel_m_s[0],
        Axis::Yaw => s.rate_rad_s[2],
        Axis::Heave => s.vel_m_s[2],
    }
}

/// The held-out blocks: index ranges of consecutive samples outside the fit part.
pub fn held_out_blocks(rec: &Record) -> Vec<std::ops::Range<usize>> {
    let t0 = rec.samples.first().map_or(0.0, |s| s.t_s);
    let mut out = Vec::new();
    let mut start = None;
    for (k, s) in rec.samples.iter().enumerate() {
        let held = !in_fit_part(s.t_s, t0);
        match (held, start) {
            (true, None) => start = Some(k),
            (false, Some(a)) => {
                out.push(a..k);
                start = None;
            }
            _ => {}
        }
    }
    if let Some(a) = start {
        out.push(a..rec.samples.len());
    }
    out.retain(|r| r.len() > 10);
    out
}

/// Per axis, the recorded and the simulated velocity over the held-out blocks.
pub struct Prediction {
    /// `(t, recorded, simulated)` per held-out sample, per axis.
    pub traces: [Vec<(f64, f64, f64)>; 3],
}

impl Prediction {
    /// RMS of simulated minus recorded, per axis.
    pub fn rms(&self) -> [f64; 3] {
        self.traces.clone().map(|t| {
            let n = t.len().max(1) as f64;
            (t.iter().map(|(_, a, b)| (b - a).powi(2)).sum::<f64>() / n).sqrt()
        })
    }
}

/// Simulate the held-out blocks under the three axes' parameters `thetas` (Heun's method
/// at the record's period) with the nominal thrust `thrust`.
pub fn predict(
    thetas: &[Vec<f64>; 3],
    lever_arm_m: f64,
    rec: &Record,
    thrust: &[[f64; 3]],
) -> Prediction {
    let dt = rec.period_s();
    let mut traces: [Vec<(f64, f64, f64)>; 3] = Default::default();
    for block in held_out_blocks(rec) {
        for ((axis, trace), theta) in Axis::ALL.iter().zip(traces.iter_mut()).zip(thetas) {
            let mut x = recorded(*axis, rec, block.start);
            for k in block.clone() {
                trace.push((rec.samples[k].t_s, recorded(*axis, rec, k), x));
                if k + 1 < rec.samples.len() {
                    let a0 = accel(*axis, theta, rec, thrust, lever_arm_m, k, x);
                    let xp = x + dt * a0;
                    let a1 = accel(*axis, theta, rec, thrust, lever_arm_m, k + 1, xp);
                    x += 0.5 * dt * (a0 + a1);
                }
            }
        }
    }
    Prediction { traces }
}

/// The validation figure: per axis, recorded, identified and prior velocity over the
/// held-out blocks.
pub fn plot(path: &Path, identified: &Prediction, prior: &Prediction) -> Result<()> {
    init_font();
    let root = BitMapBackend::new(path, (1200, 900)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| anyhow!("{e}"))?;
    let panels = root.split_evenly((3, 1));
    let units = ["u (m/s)", "r (rad/s)", "w (m/s)"];
    let ir = identified.rms();
    let pr = prior.rms();
    for (i, panel) in panels.iter().enumerate() {
        let id = &identified.traces[i];
        let pri = &prior.traces[i];
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for &(_, a, b) in id.iter().chain(pri.iter()) {
            for v in [a, b] {
                if v.is_finite() {
                    lo = lo.min(v);
                    hi = hi.max(v);
                }
            }
        }
        let (t0, t1) = (
            id.first().map_or(0.0, |p| p.0),
            id.last().map_or(1.0, |p| p.0),
        );
        if lo.is_nan() || hi.is_nan() || lo >= hi {
            (lo, hi) = (-1.0, 1.0);
        }
        let pad = 0.05 * (hi - lo);
        let title = format!(
            "{}: held-out RMS identified {:.4}, prior {:.4}",
            Axis::ALL[i].name(),
            ir[i],
            pr[i]
        );
        let mut chart = ChartBuilder::on(panel)
            .caption(title, (FONT_NAME, 18))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(t0..t1.max(t0 + 1.0), (lo - pad)..(hi + pad))
            .map_err(|e| anyhow!("{e}"))?;
        chart
            .configure_mesh()
            .x_desc("t (s)")
            .y_desc(units[i])
            .label_style((FONT_NAME, 12))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
        let lines = [
            (
                "recorded",
                BLACK,
                id.iter().map(|p| (p.0, p.1)).collect::<Vec<_>>(),
            ),
            (
                "identified",
                RGBColor(214, 39, 40),
                id.iter().map(|p| (p.0, p.2)).collect(),
            ),
            (
                "prior",
                RGBColor(31, 119, 180),
                pri.iter().map(|p| (p.0, p.2)).collect(),
            ),
        ];
        for (name, color, pts) in lines {
            // One line per held-out block (no line across the fitted blocks between them).
            let mut pieces: Vec<Vec<(f64, f64)>> = Vec::new();
            for p in pts {
                match pieces.last_mut() {
                    Some(last) if last.last().is_some_and(|q| p.0 - q.0 < 1.0) => last.push(p),
                    _ => pieces.push(vec![p]),
                }
            }
            for (j, piece) in pieces.into_iter().enumerate() {
                let s = chart
                    .draw_series(LineSeries::new(piece, color.stroke_width(1)))
                    .map_err(|e| anyhow!("{e}"))?;
                if j == 0 {
                    s.label(name)
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color));
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font((FONT_NAME, 12))
            .draw()
            .map_err(|e| anyhow!("{e}"))?;
    }
    root.present().map_err(|e| anyhow!("{e}"))?;
    Ok(())
}
