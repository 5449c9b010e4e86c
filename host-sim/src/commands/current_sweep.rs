//! Currents from every direction: the built-in paths flown in a constant current
//! of each speed and each direction relative to the path's first course, the tracking error
//! (the plant's **true** position against the reference) summarized per run and drawn as a
//! heat map per path. A measurement, not a fix: it shows where the tracking law holds in a
//! current and where it does not.

use crate::closed_loop::runner::run;
use crate::closed_loop::RunOptions;
use crate::output::plots::{init_font, FONT_NAME};
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use rayon::prelude::*;
use serde::Serialize;
use sim_scenario::Scenario;
use std::io::Write;
use std::path::Path;

/// The paths swept (built-in scenarios).
pub const PATHS: [&str; 3] = ["line-3d", "circle-3d", "lawnmower-3d"];
/// Current speeds (m/s).
pub const SPEEDS_M_S: [f64; 3] = [0.1, 0.2, 0.3];
/// Directions relative to the path's first course (degrees): 0 behind the vehicle (the
/// current runs along the path), 180 against it, 90 from port to starboard.
pub const DIRECTIONS_DEG: [f64; 12] = [
    0.0, 30.0, 60.0, 90.0, 120.0, 150.0, 180.0, 210.0, 240.0, 270.0, 300.0, 330.0,
];
/// The bound on the RMS over the last 80 % (m).
pub const RMS_BOUND_M: f64 = 0.05;

/// One run of the sweep.
#[derive(Debug, Clone, Serialize)]
pub struct Cell {
    /// Scenario.
    pub path: String,
    /// Current speed (m/s).
    pub speed_m_s: f64,
    /// Current direction relative to the path's first course (degrees).
    pub direction_deg: f64,
    /// RMS position error over the last 80 % of the run (m).
    pub rms_last80_m: f64,
    /// Largest position error after the first 10 s (m).
    pub max_after_10s_m: f64,
    /// Largest thruster force (N).
    pub max_thrust_n: f64,
    /// A NaN appeared.
    pub nan: bool,
}

/// The path's first course (rad): from the reference at 0 s to where it is at 2 s.
pub fn first_course(sc: &Scenario) -> f64 {
    let r = sc.reference.to_core();
    let (a, b) = (r.sample(0.0).pos_m, r.sample(2.0).pos_m);
    f64::from(b[1] - a[1]).atan2(f64::from(b[0] - a[0]))
}

/// Run the whole sweep (in parallel).
pub fn sweep() -> Result<Vec<Cell>> {
    let mut jobs = Vec::new();
    for path in PATHS {
        for speed in SPEEDS_M_S {
            for dir in DIRECTIONS_DEG {
                jobs.push((path, speed, dir));
            }
        }
    }
    jobs.par_iter()
        .map(|&(path, speed, dir)| cell(path, speed, dir))
        .collect()
}

/// One run: the built-in `path` in a current of `speed_m_s` from `direction_deg` relative to
/// the path's first course.
pub fn cell(path: &str, speed_m_s: f64, direction_deg: f64) -> Result<Cell> {
    let sc = Scenario::load_setup(path)?;
    let course = first_course(&sc) + direction_deg.to_radians();
    let opts = RunOptions {
        current_m_s: Some([speed_m_s * course.cos(), speed_m_s * course.sin(), 0.0]),
        ..RunOptions::default()
    };
    let s = run(&sc, &opts)?.summary;
    Ok(Cell {
        path: path.to_string(),
        speed_m_s,
        direction_deg,
        rms_last80_m: s.rms_position_error_last80_m,
        max_after_10s_m: s.max_position_error_after_10s_m,
        max_thrust_n: s.max_abs_thruster_force_n,
        nan: s.nan_detected,
    })
}

/// Write `sweep.csv`, `sweep.json` and one heat map per path into `dir`; print a summary.
pub fn write(dir: &Path, cells: &[Cell]) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    let mut csv = std::fs::File::create(dir.join("sweep.csv"))?;
    writeln!(
        csv,
        "path,speed_m_s,direction_deg,rms_last80_m,max_after_10s_m,max_thrust_n,nan"
    )?;
    for c in cells {
        writeln!(
            csv,
            "{},{},{},{:.6},{:.6},{:.3},{}",
            c.path,
            c.speed_m_s,
            c.direction_deg,
            c.rms_last80_m,
            c.max_after_10s_m,
            c.max_thrust_n,
            c.nan
        )?;
    }
    std::fs::write(
        dir.join("sweep.json"),
        serde_json::to_string_pretty(cells)? + "\n",
    )?;
    for path in PATHS {
        let mine: Vec<&Cell> = cells.iter().filter(|c| c.path == path).collect();
        heat_map(&dir.join(format!("heatmap_{path}.png")), path, &mine)?;
        let within = mine
            .iter()
            .filter(|c| !c.nan && c.rms_last80_m <= RMS_BOUND_M)
            .count();
        let worst = mine
            .iter()
            .max_by(|a, b| a.rms_last80_m.total_cmp(&b.rms_last80_m));
        if let Some(w) = worst {
            println!(
                "{path}: {within} of {} runs within {:.0} cm RMS (last 80 %); worst {:.1} cm at {} m/s from {} deg",
                mine.len(),
                RMS_BOUND_M * 100.0,
                w.rms_last80_m * 100.0,
                w.speed_m_s,
                w.direction_deg
            );
        }
    }
    Ok(())
}

/// Colour of an RMS error: green within the bound, through yellow to red at 4x the bound.
fn colour(rms_m: f64) -> RGBColor {
    let x = (rms_m / (4.0 * RMS_BOUND_M)).clamp(0.0, 1.0);
    if rms_m <= RMS_BOUND_M {
        RGBColor(120, 200, 120)
    } else {
        RGBColor(240, (220.0 * (1.0 - x)) as u8, 60)
    }
}

fn heat_map(file: &Path, path: &str, cells: &[&Cell]) -> Result<()> {
    init_font();
    let e = |x: String| anyhow!("{}: {x}", file.display());
    crate::output::png_file::write(file, (1100, 420), |root| {
        root.fill(&WHITE).map_err(|x| e(x.to_string()))?;
        let n = DIRECTIONS_DEG.len() as f64;
        let m = SPEEDS_M_S.len() as f64;
        // Plain coordinates with a band for the labels: columns are directions, rows speeds.
        let mut ch = ChartBuilder::on(root)
            .caption(
                format!(
                "{path}: RMS tracking error over the last 80 % in a current (cm; green <= 5 cm)"
            ),
                (FONT_NAME, 20),
            )
            .margin(12)
            .build_cartesian_2d(-1.4..n, -0.7..m)
            .map_err(|x| e(x.to_string()))?;
        let label = |text: String, at: (f64, f64), size: u32| {
            Text::new(text, at, (FONT_NAME, size).into_font())
        };
        let mut labels = Vec::new();
        for (i, d) in DIRECTIONS_DEG.iter().enumerate() {
            labels.push(label(format!("{d:.0}"), (i as f64 + 0.38, -0.12), 18));
        }
        for (j, v) in SPEEDS_M_S.iter().enumerate() {
            labels.push(label(format!("{v} m/s"), (-1.3, j as f64 + 0.58), 18));
        }
        labels.push(label(
        "current direction relative to the path's first course, degrees (0: from behind, along the path; 180: against it)".to_string(),
        (0.0, -0.42),
        16,
    ));
        ch.draw_series(labels).map_err(|x| e(x.to_string()))?;
        for c in cells {
            let i = DIRECTIONS_DEG
                .iter()
                .position(|&d| d == c.direction_deg)
                .unwrap_or(0) as f64;
            let j = SPEEDS_M_S
                .iter()
                .position(|&s| s == c.speed_m_s)
                .unwrap_or(0) as f64;
            let fill = if c.nan {
                RGBColor(60, 60, 60)
            } else {
                colour(c.rms_last80_m)
            };
            ch.draw_series([Rectangle::new(
                [(i + 0.02, j + 0.02), (i + 0.98, j + 0.98)],
                fill.filled(),
            )])
            .map_err(|x| e(x.to_string()))?;
            let label = if c.nan {
                "NaN".to_string()
            } else {
                format!("{:.1}", c.rms_last80_m * 100.0)
            };
            ch.draw_series([Text::new(
                label,
                (i + 0.3, j + 0.6),
                (FONT_NAME, 18).into_font(),
            )])
            .map_err(|x| e(x.to_string()))?;
        }
        Ok(())
    })
}

/// Arguments of `host-sim current-sweep`.
#[derive(Debug, clap::Args)]
pub struct CurrentSweepArgs {
    /// Output folder.
    #[arg(long, default_value = "out/current-sweep")]
    pub out: std::path::PathBuf,
}

/// Run `host-sim current-sweep`.
pub fn main(a: CurrentSweepArgs) -> Result<()> {
    let cells = sweep()?;
    write(&a.out, &cells)?;
    println!("wrote {}", a.out.display());
    Ok(())
}
