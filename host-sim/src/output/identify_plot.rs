//! The identification's validation figure (`host-sim identify`): per axis, the recorded,
//! identified and prior velocity over the held-out blocks (`identify::validate`).

use crate::output::plots::{init_font, FONT_NAME};
use anyhow::{anyhow, Result};
use identify::fit::Axis;
use identify::validate::Prediction;
use plotters::prelude::*;
use std::path::Path;

/// The validation figure: per axis, recorded, identified and prior velocity over the
/// held-out blocks.
pub fn plot(path: &Path, identified: &Prediction, prior: &Prediction) -> Result<()> {
    init_font();
    crate::output::png_file::write(path, (1200, 900), |root| {
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
                        s.label(name).legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 16, y)], color)
                        });
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
        Ok(())
    })
}
