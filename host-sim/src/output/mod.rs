//! Run outputs: `summary.json` and `timeseries.csv`.

pub mod identify_plot;
pub mod plots;
pub mod png_file;

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
pub const N_COLUMNS: usize = 54;

/// One row of `timeseries.csv`, in the order of [`CSV_COLUMNS`].
pub fn row(s: &Sample) -> [f64; N_COLUMNS] {
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
