//! Run outputs: `summary.json` and `timeseries.csv`.

pub mod plots;

use crate::closed_loop::{RunOutput, Sample};
use anyhow::{Context, Result};
use std::io::{BufWriter, Write};
use std::path::Path;

/// Column names of `timeseries.csv`, in order.
pub const CSV_COLUMNS: &[&str] = &[
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

fn row(s: &Sample) -> Vec<f64> {
    let e = &s.law_errors;
    let mut v = Vec::with_capacity(CSV_COLUMNS.len());
    v.push(s.t_s);
    v.extend_from_slice(&s.state.eta);
    v.extend_from_slice(&s.state.nu);
    v.extend_from_slice(&s.ref_pos_m);
    v.extend_from_slice(&s.ref_vel_m_s);
    v.extend_from_slice(&s.pos_err_m);
    v.push(s.pos_err_norm_m);
    v.extend_from_slice(&s.vel_err_m_s);
    v.push(s.angle_err_rad);
    for x in [e.x_m, e.y_m, e.z_m, e.pitch_rad, e.yaw_rad] {
        v.push(f64::from(x));
    }
    v.extend_from_slice(&s.requested);
    v.extend_from_slice(&s.achieved);
    v.extend_from_slice(&s.thrust_cmd_n);
    v.extend_from_slice(&s.thrust_n);
    v.extend_from_slice(&s.pulse_us);
    v.push(if s.saturated { 1.0 } else { 0.0 });
    v.extend_from_slice(&s.nav_pos_m);
    v.extend_from_slice(&s.nav_pos_std_m.unwrap_or([f64::NAN; 3]));
    v
}

/// Write `timeseries.csv`.
pub fn write_csv(path: &Path, log: &[Sample]) -> Result<()> {
    let f =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = BufWriter::new(f);
    writeln!(w, "{}", CSV_COLUMNS.join(","))?;
    for s in log {
        let r = row(s);
        let line: Vec<String> = r.iter().map(|x| format!("{x:.7e}")).collect();
        writeln!(w, "{}", line.join(","))?;
    }
    w.flush()?;
    Ok(())
}

/// Write `summary.json`, `timeseries.csv` and the plots of one run into `dir`.
pub fn write_run(dir: &Path, out: &RunOutput) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let json = serde_json::to_string_pretty(&out.summary)?;
    std::fs::write(dir.join("summary.json"), json + "\n")
        .with_context(|| format!("cannot write {}", dir.join("summary.json").display()))?;
    if !out.log.is_empty() {
        write_csv(&dir.join("timeseries.csv"), &out.log)?;
        crate::output::plots::run_plots(dir, out)?;
    }
    Ok(())
}
