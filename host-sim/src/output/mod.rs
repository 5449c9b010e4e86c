//! Run outputs: `summary.json` and `timeseries.csv`.

pub mod identify_plot;
pub mod plots;

use crate::closed_loop::{RunOutput, Sample};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::Path;

/// Column names of `timeseries.csv`, in order.
pub const CSV_COLUMNS: &[&str; N_COLUMNS] = &[
    "t_s",
    "x_m",
    "y_m",
    "z_m",
    "roll_rad",
    "pitch_rad",
    "yaw_rad",
    "u_m_s",
    "v_m_s",
    "w_m_s",
    "p_rad_s",
    "q_rad_s",
    "r_rad_s",
    "x_ref_m",
    "y_ref_m",
    "z_ref_m",
    "vx_ref_m_s",
    "vy_ref_m_s",
    "vz_ref_m_s",
    "ex_m",
    "ey_m",
    "ez_m",
    "e_norm_m",
    "evx_m_s",
    "evy_m_s",
    "evz_m_s",
    "e_angle_rad",
    "law_ex_m",
    "law_ey_m",
    "law_ez_m",
    "law_e_pitch_rad",
    "law_e_yaw_rad",
    "tau1_req_n",
    "tau2_req_n_m",
    "tau3_req_n",
    "tau1_ach_n",
    "tau2_ach_n_m",
    "tau3_ach_n",
    "f1x_cmd_n",
    "f2x_cmd_n",
    "f3z_cmd_n",
    "f1x_n",
    "f2x_n",
    "f3z_n",
    "pwm1_us",
    "pwm2_us",
    "pwm3_us",
    "saturated",
    "nav_x_m",
    "nav_y_m",
    "nav_z_m",
    "nav_x_std_m",
    "nav_y_std_m",
    "nav_z_std_m",
];

/// Number of columns of `timeseries.csv`.
const N_COLUMNS: usize = 54;

/// One row of `timeseries.csv`, in the order of [`CSV_COLUMNS`].
fn row(s: &Sample) -> [f64; N_COLUMNS] {
    let e = &s.law_errors;
    let [x, y, z, roll, pitch, yaw] = s.state.eta;
    let [u, v, w, p, q, r] = s.state.nu;
    let [nav_x_std, nav_y_std, nav_z_std] = s.nav_pos_std_m.unwrap_or([f64::NAN; 3]);
    [
        s.t_s,
        x,
        y,
        z,
        roll,
        pitch,
        yaw,
        u,
        v,
        w,
        p,
        q,
        r,
        s.ref_pos_m[0],
        s.ref_pos_m[1],
        s.ref_pos_m[2],
        s.ref_vel_m_s[0],
        s.ref_vel_m_s[1],
        s.ref_vel_m_s[2],
        s.pos_err_m[0],
        s.pos_err_m[1],
        s.pos_err_m[2],
        s.pos_err_norm_m,
        s.vel_err_m_s[0],
        s.vel_err_m_s[1],
        s.vel_err_m_s[2],
        s.angle_err_rad,
        f64::from(e.x_m),
        f64::from(e.y_m),
        f64::from(e.z_m),
        f64::from(e.pitch_rad),
        f64::from(e.yaw_rad),
        s.requested[0],
        s.requested[1],
        s.requested[2],
        s.achieved[0],
        s.achieved[1],
        s.achieved[2],
        s.thrust_cmd_n[0],
        s.thrust_cmd_n[1],
        s.thrust_cmd_n[2],
        s.thrust_n[0],
        s.thrust_n[1],
        s.thrust_n[2],
        s.pulse_us[0],
        s.pulse_us[1],
        s.pulse_us[2],
        if s.saturated { 1.0 } else { 0.0 },
        s.nav_pos_m[0],
        s.nav_pos_m[1],
        s.nav_pos_m[2],
        nav_x_std,
        nav_y_std,
        nav_z_std,
    ]
}

/// Write `timeseries.csv` to `out`: the header, then one row per sample. Each number is the
/// shortest decimal that reads back as the same `f64` (`NaN`, `inf` and `-inf` as Rust
/// writes them), formatted into one stack buffer: nothing is allocated per value.
pub fn write_csv_to<W: Write>(out: W, log: &[Sample]) -> Result<()> {
    let mut w = csv::WriterBuilder::new()
        .has_headers(false)
        .buffer_capacity(1 << 16)
        // Numbers and the column names hold no delimiter, quote or newline: no field is
        // scanned for quoting.
        .quote_style(csv::QuoteStyle::Never)
        .from_writer(out);
    w.write_record(CSV_COLUMNS)?;
    let mut number = zmij::Buffer::new();
    for s in log {
        for x in row(s) {
            w.write_field(number.format(x))?;
        }
        w.write_record(None::<&[u8]>)?;
    }
    w.flush()?;
    Ok(())
}

/// Write `timeseries.csv`.
pub fn write_csv(path: &Path, log: &[Sample]) -> Result<()> {
    let f =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    write_csv_to(f, log).with_context(|| format!("cannot write {}", path.display()))
}

/// Which files of a run are written besides `summary.json`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outputs {
    /// `timeseries.csv`.
    pub timeseries: bool,
    /// The PNG figures.
    pub plots: bool,
}

impl Outputs {
    /// Every file: `summary.json`, `timeseries.csv` and the figures.
    pub const ALL: Self = Self {
        timeseries: true,
        plots: true,
    };

    /// Something needs the per-tick log.
    pub fn need_log(self) -> bool {
        self.timeseries || self.plots
    }
}

impl Default for Outputs {
    fn default() -> Self {
        Self::ALL
    }
}

/// Write `summary.json`, `timeseries.csv` and the plots of one run into `dir`.
pub fn write_run(dir: &Path, out: &RunOutput) -> Result<()> {
    write_run_with(dir, out, Outputs::ALL)
}

/// Write `summary.json` of one run into `dir`, and the files of `outputs` that its log
/// allows.
pub fn write_run_with(dir: &Path, out: &RunOutput, outputs: Outputs) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let json = serde_json::to_string_pretty(&out.summary)?;
    std::fs::write(dir.join("summary.json"), json + "\n")
        .with_context(|| format!("cannot write {}", dir.join("summary.json").display()))?;
    if out.log.is_empty() {
        return Ok(());
    }
    // The time series and the figures are independent: written side by side.
    let (csv, plots) = rayon::join(
        || {
            outputs
                .timeseries
                .then(|| write_csv(&dir.join("timeseries.csv"), &out.log))
                .transpose()
        },
        || {
            outputs
                .plots
                .then(|| crate::output::plots::run_plots(dir, out))
                .transpose()
        },
    );
    csv?;
    plots?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(field: &str) -> f64 {
        field.parse().unwrap()
    }

    #[test]
    fn every_value_reads_back_as_the_same_f64() {
        let awkward = [
            0.1 + 0.2,
            -1.0 / 3.0,
            f64::MIN_POSITIVE / 3.0,
            f64::MAX,
            -0.0,
            1e-300,
            123_456_789.123_456_79,
            f64::from(0.1_f32),
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        let mut log = Vec::new();
        for (i, &a) in awkward.iter().enumerate() {
            let mut s = Sample {
                t_s: i as f64 * 0.01,
                saturated: i % 2 == 0,
                nav_pos_std_m: (i % 3 != 0).then_some([a, -a, 0.5]),
                ..Sample::default()
            };
            s.state.eta = [a, -a, a * 0.5, 1.0, 2.0, a];
            s.state.nu = [a; 6];
            s.pos_err_norm_m = a;
            s.pulse_us = [1500.0, a, 1100.0];
            s.law_errors.yaw_rad = 0.1;
            log.push(s);
        }
        let mut bytes = Vec::new();
        write_csv_to(&mut bytes, &log).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), CSV_COLUMNS.join(","));
        let mut n = 0;
        for (line, s) in lines.zip(&log) {
            let got: Vec<f64> = line.split(',').map(parse).collect();
            let want = row(s);
            assert_eq!(got.len(), N_COLUMNS);
            for (g, w) in got.iter().zip(want) {
                // NaN reads back as NaN; every other value bit for bit (the sign of zero too).
                assert!(
                    g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                    "{g:e} != {w:e} in {line}"
                );
            }
            n += 1;
        }
        assert_eq!(n, log.len());
    }

    #[test]
    fn numbers_are_written_shortest() {
        let s = Sample {
            t_s: 0.25,
            ..Sample::default()
        };
        let mut bytes = Vec::new();
        write_csv_to(&mut bytes, &[s]).unwrap();
        let text = String::from_utf8(bytes).unwrap();
        let data = text.lines().nth(1).unwrap();
        assert!(data.starts_with("0.25,0.0,0.0,"), "{data}");
        assert!(data.ends_with(",NaN,NaN,NaN"), "{data}");
        // Every field is short: no padding to a fixed number of digits.
        assert!(data.len() < 6 * N_COLUMNS, "{} bytes: {data}", data.len());
    }

    #[test]
    fn without_the_time_series_and_figures_only_the_summary_is_written() {
        let dir = std::env::temp_dir().join(format!("host-sim-outputs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let out = RunOutput {
            log: vec![Sample::default(); 3],
            ..RunOutput::default()
        };
        let none = Outputs {
            timeseries: false,
            plots: false,
        };
        assert!(!none.need_log());
        write_run_with(&dir, &out, none).unwrap();
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["summary.json"]);
        let csv_only = Outputs {
            timeseries: true,
            plots: false,
        };
        write_run_with(&dir, &out, csv_only).unwrap();
        let text = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
        assert_eq!(text.lines().count(), 1 + out.log.len());
        assert!(!dir.join("fig_errors.png").exists());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
