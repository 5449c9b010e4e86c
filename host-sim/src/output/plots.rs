//! PNG figures with `plotters`, text drawn with an embedded DejaVu Sans through `ab_glyph`
//! (no system fonts or fontconfig needed).
//!
//! Planar runs get the paper's figures: `fig_errors.png` (Fig. 2 / 6: position and angle
//! errors), `fig_velocity_errors.png` (Fig. 3 / 7), `fig_trajectory.png` (Fig. 4 / 8: actual
//! and reference path in the plane), `fig_positions.png` (Fig. 5 / 9: coordinates against
//! time), plus `fig_thrusters.png`. 3-D runs get `fig_xy.png`, `fig_xz.png`, `fig_errors.png`,
//! `fig_thrusters.png`. [`compare_plot`] draws the paper law beside the tracking law.

use crate::closed_loop::{RunOutput, Sample};
use anyhow::{anyhow, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static FONT_INIT: Once = Once::new();
/// The font family the figures use (registered by [`init_font`]).
pub const FONT_NAME: &str = "sans-serif";

/// Register the embedded font once (plotters' bitmap backend has none of its own).
pub fn init_font() {
    FONT_INIT.call_once(|| {
        // The font is embedded and known good; a failure here would only lose the text.
        let _ = plotters::style::register_font(FONT_NAME, FontStyle::Normal, FONT);
    });
}

const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(0, 0, 0),
];

/// One line of a chart.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// Points.
    pub pts: Vec<(f64, f64)>,
    /// Dashed (references) or solid.
    pub dashed: bool,
    /// Dots (measurements) instead of a line.
    pub dots: bool,
}

impl Series {
    fn new(name: &str, pts: Vec<(f64, f64)>) -> Self {
        Self {
            name: name.into(),
            pts,
            dashed: false,
            dots: false,
        }
    }
    fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
    fn dots(mut self) -> Self {
        self.dots = true;
        self
    }
}

fn range(series: &[Series], f: impl Fn(&(f64, f64)) -> f64) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for s in series {
        for p in &s.pts {
            let v = f(p);
            if v.is_finite() {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
    }
    if !lo.is_finite() || !hi.is_finite() {
        return (-1.0, 1.0);
    }
    let span = hi - lo;
    let pad = if span < 1e-12 {
        1e-3_f64.max(hi.abs() * 0.1)
    } else {
        0.05 * span
    };
    (lo - pad, hi + pad)
}

/// Keep at most `n` points (every k-th), so plots stay fast.
fn thin<T: Copy>(v: &[T], n: usize) -> Vec<T> {
    if v.len() <= n {
        return v.to_vec();
    }
    let k = v.len().div_ceil(n);
    let mut o: Vec<T> = v.iter().step_by(k).copied().collect();
    if let Some(l) = v.last() {
        o.push(*l);
    }
    o
}

/// Draw a chart of `series` on `area`. `equal` keeps the same scale on both axes.
pub fn chart(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    series: &[Series],
    equal: bool,
    invert_y: bool,
) -> Result<()> {
    let (mut x0, mut x1) = range(series, |p| p.0);
    let (mut y0, mut y1) = range(series, |p| p.1);
    if equal {
        let (w, h) = area.dim_in_pixel();
        let (w, h) = ((w as f64 - 80.0).max(10.0), (h as f64 - 80.0).max(10.0));
        let sx = (x1 - x0) / w;
        let sy = (y1 - y0) / h;
        if sx > sy {
            let c = 0.5 * (y0 + y1);
            y0 = c - 0.5 * sx * h;
            y1 = c + 0.5 * sx * h;
        } else {
            let c = 0.5 * (x0 + x1);
            x0 = c - 0.5 * sy * w;
            x1 = c + 0.5 * sy * w;
        }
    }
    let e = |err: String| anyhow!("plot {title}: {err}");
    let y_range = if invert_y { y1..y0 } else { y0..y1 };
    let mut ch = ChartBuilder::on(area)
        .caption(title, (FONT_NAME, 18))
        .margin(8)
        .x_label_area_size(38)
        .y_label_area_size(62)
        .build_cartesian_2d(x0..x1, y_range)
        .map_err(|x| e(x.to_string()))?;
    ch.configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style((FONT_NAME, 13))
        .axis_desc_style((FONT_NAME, 14))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(|x| e(x.to_string()))?;
    for (i, s) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        // Non-finite points (a recorded dive has no reference) are left out; a series with
        // none left is not drawn.
        let finite: Vec<(f64, f64)> = s
            .pts
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if finite.is_empty() {
            continue;
        }
        let pts = thin(&finite, 3000);
        let style = c.stroke_width(2);
        let anno = if s.dots {
            ch.draw_series(pts.iter().map(|p| Circle::new(*p, 3, c.filled())))
                .map_err(|x| e(x.to_string()))?
        } else if s.dashed {
            ch.draw_series(DashedLineSeries::new(pts, 8, 5, style))
                .map_err(|x| e(x.to_string()))?
        } else {
            ch.draw_series(LineSeries::new(pts, style))
                .map_err(|x| e(x.to_string()))?
        };
        anno.label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
    }
    ch.configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(160, 160, 160))
        .label_font((FONT_NAME, 13))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|x| e(x.to_string()))?;
    Ok(())
}

/// A length with a unit that keeps its significant digits (mm under 1 cm, cm under 1 m).
pub fn fmt_len(m: f64) -> String {
    if !m.is_finite() {
        "inf".into()
    } else if m.abs() < 0.01 {
        format!("{:.3} mm", 1e3 * m)
    } else if m.abs() < 1.0 {
        format!("{:.1} cm", 1e2 * m)
    } else {
        format!("{m:.2} m")
    }
}

fn ts(log: &[Sample], f: impl Fn(&Sample) -> f64) -> Vec<(f64, f64)> {
    log.iter().map(|s| (s.t_s, f(s))).collect()
}

fn xy(log: &[Sample], f: impl Fn(&Sample) -> (f64, f64)) -> Vec<(f64, f64)> {
    log.iter().map(f).collect()
}

type Panel = (String, String, String, Vec<Series>, bool, bool);

fn figure(
    path: &Path,
    size: (u32, u32),
    title: &str,
    rows: usize,
    cols: usize,
    panels: Vec<Panel>,
) -> Result<()> {
    init_font();
    crate::output::png_file::write(path, size, |root| {
        root.fill(&WHITE)
            .map_err(|x| anyhow!("{}: {x}", path.display()))?;
        let root = root
            .titled(title, (FONT_NAME, 20))
            .map_err(|x| anyhow!("{}: {x}", path.display()))?;
        let areas = root.split_evenly((rows, cols));
        for (area, (t, xd, yd, series, equal, inv)) in areas.iter().zip(panels.iter()) {
            chart(area, t, xd, yd, series, *equal, *inv)?;
        }
        Ok(())
    })
}

fn panel(t: &str, xd: &str, yd: &str, s: Vec<Series>) -> Panel {
    (t.into(), xd.into(), yd.into(), s, false, false)
}

/// Thruster figure panels: commands and delivered thrust, then requested/achieved forces.
fn thruster_panels(log: &[Sample]) -> Vec<Panel> {
    vec![
        panel(
            "Thruster forces (delivered; dashed: commanded)",
            "t (s)",
            "N",
            vec![
                Series::new("F1x", ts(log, |s| s.thrust_n[0])),
                Series::new("F2x", ts(log, |s| s.thrust_n[1])),
                Series::new("F3z", ts(log, |s| s.thrust_n[2])),
                Series::new("F1x cmd", ts(log, |s| s.thrust_cmd_n[0])).dashed(),
                Series::new("F2x cmd", ts(log, |s| s.thrust_cmd_n[1])).dashed(),
                Series::new("F3z cmd", ts(log, |s| s.thrust_cmd_n[2])).dashed(),
            ],
        ),
        panel(
            "Generalized forces (requested; dashed: achieved)",
            "t (s)",
            "N, N m",
            vec![
                Series::new("tau1 surge", ts(log, |s| s.requested[0])),
                Series::new("tau2 yaw", ts(log, |s| s.requested[1])),
                Series::new("tau3 heave", ts(log, |s| s.requested[2])),
                Series::new("tau1 ach.", ts(log, |s| s.achieved[0])).dashed(),
                Series::new("tau2 ach.", ts(log, |s| s.achieved[1])).dashed(),
                Series::new("tau3 ach.", ts(log, |s| s.achieved[2])).dashed(),
            ],
        ),
    ]
}

/// Write every figure of one run into `dir`.
pub fn run_plots(dir: &Path, out: &RunOutput) -> Result<()> {
    let log = &out.log;
    let s = &out.summary;
    let head = format!("{} ({} law, {})", s.scenario, s.controller, s.plane);
    let verdict = if s.nan_detected || s.diverged {
        format!(" - {}", s.stop_reason)
    } else if !s.final_position_error_m.is_finite() {
        // No reference (a recorded dive): the summary's own words.
        format!(" - {}", s.verdict)
    } else {
        format!(" - final error {}", fmt_len(s.final_position_error_m))
    };
    let big = (1200, 800);
    match s.plane.as_str() {
        "xz" | "xy" => {
            let xz = s.plane == "xz";
            let (b, bi, ang, rate, ri) = if xz {
                ("z", 2usize, "pitch", "q", 4usize)
            } else {
                ("y", 1usize, "yaw", "r", 5usize)
            };
            figure(
                &dir.join("fig_errors.png"),
                big,
                &format!("Position and angle errors: {head}{verdict}"),
                2,
                1,
                vec![
                    panel(
                        "Inertial position errors of the body origin",
                        "t (s)",
                        "m",
                        vec![
                            Series::new("x - x_r", ts(log, |s| s.pos_err_m[0])),
                            Series::new(&format!("{b} - {b}_r"), ts(log, move |s| s.pos_err_m[bi])),
                        ],
                    ),
                    panel(
                        &format!("{ang} angle error (law's reference)"),
                        "t (s)",
                        "rad",
                        vec![Series::new(
                            &format!("{ang} error"),
                            ts(log, |s| s.angle_err_rad),
                        )],
                    ),
                ],
            )?;
            figure(
                &dir.join("fig_velocity_errors.png"),
                big,
                &format!("Velocity errors: {head}"),
                2,
                1,
                vec![
                    panel(
                        "Inertial velocity errors of the body origin",
                        "t (s)",
                        "m/s",
                        vec![
                            Series::new("x_dot - x_r_dot", ts(log, |s| s.vel_err_m_s[0])),
                            Series::new(
                                &format!("{b}_dot - {b}_r_dot"),
                                ts(log, move |s| s.vel_err_m_s[bi]),
                            ),
                        ],
                    ),
                    panel(
                        &format!("{rate} (reference rate is 0 on the paper's straight path)"),
                        "t (s)",
                        "rad/s",
                        vec![Series::new(rate, ts(log, move |s| s.state.nu[ri]))],
                    ),
                ],
            )?;
            let path_panel = (
                format!("Trajectory in the {} plane", s.plane.to_uppercase()),
                "x (m)".to_string(),
                if xz {
                    "z (m, down)".to_string()
                } else {
                    "y (m)".to_string()
                },
                vec![
                    Series::new(
                        "actual",
                        xy(log, move |s| (s.state.eta[0], s.state.eta[bi])),
                    ),
                    Series::new(
                        "reference",
                        xy(log, move |s| (s.ref_pos_m[0], s.ref_pos_m[bi])),
                    )
                    .dashed(),
                ],
                true,
                xz,
            );
            figure(
                &dir.join("fig_trajectory.png"),
                (900, 800),
                &format!("Actual and reference trajectory: {head}"),
                1,
                1,
                vec![path_panel],
            )?;
            figure(
                &dir.join("fig_positions.png"),
                big,
                &format!("Coordinates against time: {head}"),
                2,
                1,
                vec![
                    panel(
                        "x",
                        "t (s)",
                        "m",
                        vec![
                            Series::new("x", ts(log, |s| s.state.eta[0])),
                            Series::new("x_r", ts(log, |s| s.ref_pos_m[0])).dashed(),
                        ],
                    ),
                    panel(
                        b,
                        "t (s)",
                        "m",
                        vec![
                            Series::new(b, ts(log, move |s| s.state.eta[bi])),
                            Series::new(&format!("{b}_r"), ts(log, move |s| s.ref_pos_m[bi]))
                                .dashed(),
                        ],
                    ),
                ],
            )?;
        }
        _ => {
            let proj = |name: &str, bi: usize, inv: bool| -> Panel {
                (
                    format!("{name} projection"),
                    "x (m)".into(),
                    if bi == 1 {
                        "y (m)".into()
                    } else {
                        "z (m, down)".into()
                    },
                    vec![
                        Series::new(
                            "actual",
                            xy(log, move |s| (s.state.eta[0], s.state.eta[bi])),
                        ),
                        Series::new(
                            "reference",
                            xy(log, move |s| (s.ref_pos_m[0], s.ref_pos_m[bi])),
                        )
                        .dashed(),
                    ],
                    bi == 1,
                    inv,
                )
            };
            figure(
                &dir.join("fig_xy.png"),
                (900, 800),
                &format!("{head}{verdict}"),
                1,
                1,
                vec![proj("XY", 1, false)],
            )?;
            figure(
                &dir.join("fig_xz.png"),
                (1200, 900),
                &format!("{head}{verdict}"),
                2,
                1,
                vec![
                    proj("XZ", 2, true),
                    (
                        "Depth against time".to_string(),
                        "t (s)".to_string(),
                        "z (m, down)".to_string(),
                        vec![
                            Series::new("z", ts(log, |s| s.state.eta[2])),
                            Series::new("z_r", ts(log, |s| s.ref_pos_m[2])).dashed(),
                        ],
                        false,
                        true,
                    ),
                ],
            )?;
            figure(
                &dir.join("fig_errors.png"),
                big,
                &format!("Errors: {head}{verdict}"),
                2,
                1,
                vec![
                    panel(
                        "Inertial position errors of the body origin",
                        "t (s)",
                        "m",
                        vec![
                            Series::new("x - x_r", ts(log, |s| s.pos_err_m[0])),
                            Series::new("y - y_r", ts(log, |s| s.pos_err_m[1])),
                            Series::new("z - z_r", ts(log, |s| s.pos_err_m[2])),
                            Series::new("|e|", ts(log, |s| s.pos_err_norm_m)),
                        ],
                    ),
                    panel(
                        "Angles",
                        "t (s)",
                        "rad",
                        vec![
                            Series::new("yaw error (law)", ts(log, |s| s.angle_err_rad)),
                            Series::new("roll", ts(log, |s| s.state.eta[3])),
                            Series::new("pitch", ts(log, |s| s.state.eta[4])),
                        ],
                    ),
                ],
            )?;
        }
    }
    figure(
        &dir.join("fig_thrusters.png"),
        big,
        &format!("Thrusters: {head}"),
        2,
        1,
        thruster_panels(log),
    )?;
    if out.summary.navigation.source == "estimator" {
        navigation_plot(&dir.join("fig_navigation.png"), out, &head)?;
    }
    Ok(())
}

/// `fig_navigation.png`: the estimate beside the truth with the USBL fixes (accepted and
/// refused) in the horizontal plane, and the estimation error of x and y against time with
/// the estimator's own 2-sigma bounds.
fn navigation_plot(path: &Path, out: &RunOutput, head: &str) -> Result<()> {
    let log = &out.log;
    let fixes = |refused: bool| -> Vec<(f64, f64)> {
        out.usbl_fixes
            .iter()
            .filter(|f| f.refused.is_some() == refused)
            .map(|f| (f.pos_m[0], f.pos_m[1]))
            .collect()
    };
    let n = &out.summary.navigation;
    let title = format!(
        "Navigation: {head} - estimation RMS {}, NEES in 95 % bound {:.2}, USBL outliers {} injected / {} rejected",
        fmt_len(out.summary.rms_estimation_error_m),
        n.nees_in_bounds_fraction.unwrap_or(f64::NAN),
        n.usbl_outliers_injected,
        n.usbl_fixes_rejected
    );
    let std = |s: &Sample, i: usize| s.nav_pos_std_m.map_or(f64::NAN, |v| v[i]);
    figure(
        path,
        (1200, 1300),
        &title,
        2,
        1,
        vec![
            (
                "XY: truth, estimate and USBL fixes".to_string(),
                "x (m)".to_string(),
                "y (m)".to_string(),
                vec![
                    Series::new("true", xy(log, |s| (s.state.eta[0], s.state.eta[1]))),
                    Series::new("estimate", xy(log, |s| (s.nav_pos_m[0], s.nav_pos_m[1]))).dashed(),
                    Series::new("USBL fix (fused)", fixes(false)).dots(),
                    Series::new("USBL fix (refused)", fixes(true)).dots(),
                ],
                true,
                false,
            ),
            (
                "Estimation error and the estimator's 2-sigma".to_string(),
                "t (s)".to_string(),
                "m".to_string(),
                vec![
                    Series::new("x error", ts(log, |s| s.nav_pos_m[0] - s.state.eta[0])),
                    Series::new("y error", ts(log, |s| s.nav_pos_m[1] - s.state.eta[1])),
                    Series::new("+2 sigma x", ts(log, move |s| 2.0 * std(s, 0))).dashed(),
                    Series::new("-2 sigma x", ts(log, move |s| -2.0 * std(s, 0))).dashed(),
                ],
                false,
                false,
            ),
        ],
    )
}

/// Side-by-side figure: the paper law (left) and the tracking law (right) on the same
/// reference: trajectory in the plane (top) and position error norm (bottom, log-free).
pub fn compare_plot(path: &Path, paper: &RunOutput, tracking: &RunOutput) -> Result<()> {
    let plane = paper.summary.plane.clone();
    let bi = if plane == "xz" { 2 } else { 1 };
    let xz = plane == "xz";
    let traj = |o: &RunOutput| -> Panel {
        let log = &o.log;
        (
            format!(
                "{} law ({}): final {}, tail RMS {}",
                o.summary.controller,
                o.summary.scenario,
                fmt_len(o.summary.final_position_error_m),
                fmt_len(o.summary.rms_position_error_tail_m)
            ),
            "x (m)".into(),
            if xz {
                "z (m, down)".into()
            } else {
                "y (m)".into()
            },
            vec![
                Series::new(
                    "actual",
                    xy(log, move |s| (s.state.eta[0], s.state.eta[bi])),
                ),
                Series::new(
                    "reference",
                    xy(log, move |s| (s.ref_pos_m[0], s.ref_pos_m[bi])),
                )
                .dashed(),
            ],
            false,
            xz,
        )
    };
    let err = |o: &RunOutput| -> Panel {
        let log = &o.log;
        panel(
            &format!(
                "{} law: position error and max |thrust| {:.1} N",
                o.summary.controller, o.summary.max_abs_thruster_force_n
            ),
            "t (s)",
            "m",
            vec![
                Series::new("x - x_r", ts(log, |s| s.pos_err_m[0])),
                Series::new(
                    if xz { "z - z_r" } else { "y - y_r" },
                    ts(log, move |s| s.pos_err_m[bi]),
                ),
                Series::new("|e|", ts(log, |s| s.pos_err_norm_m)),
            ],
        )
    };
    figure(
        path,
        (1600, 1000),
        &format!(
            "Paper law vs tracking law, {} plane, paper reference",
            plane.to_uppercase()
        ),
        2,
        2,
        vec![traj(paper), traj(tracking), err(paper), err(tracking)],
    )
}

/// Histogram of `values` (e.g. RMS errors of Monte Carlo runs).
pub fn histogram(
    path: &Path,
    title: &str,
    x_desc: &str,
    values: &[f64],
    bins: usize,
) -> Result<()> {
    init_font();
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    let (lo, hi) = if finite.is_empty() {
        (0.0, 1.0)
    } else {
        let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if hi - lo < 1e-12 {
            (lo - 0.5 * lo.abs().max(1e-3), hi + 0.5 * hi.abs().max(1e-3))
        } else {
            (lo, hi)
        }
    };
    let bins = bins.max(1);
    let w = (hi - lo) / bins as f64;
    let mut counts = vec![0u32; bins];
    for v in &finite {
        let i = (((v - lo) / w) as usize).min(bins - 1);
        counts[i] += 1;
    }
    let cmax = counts.iter().copied().max().unwrap_or(1).max(1);
    crate::output::png_file::write(path, (1000, 650), |root| {
        let e = |x: String| anyhow!("{}: {x}", path.display());
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let mut ch = ChartBuilder::on(root)
            .caption(title, (FONT_NAME, 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(55)
            .build_cartesian_2d(lo..hi, 0u32..(cmax + cmax / 10 + 1))
            .map_err(|x| e(x.to_string()))?;
        ch.configure_mesh()
            .x_desc(x_desc)
            .y_desc("runs")
            .label_style((FONT_NAME, 13))
            .axis_desc_style((FONT_NAME, 14))
            .draw()
            .map_err(|x| e(x.to_string()))?;
        ch.draw_series(counts.iter().enumerate().map(|(i, c)| {
            let x0 = lo + i as f64 * w;
            Rectangle::new([(x0, 0u32), (x0 + w, *c)], COLORS[0].mix(0.7).filled())
        }))
        .map_err(|x| e(x.to_string()))?;
        Ok(())
    })
}
