//! Validation on the held-out blocks: each axis's velocity simulated from the block's first
//! recorded value with the recorded thrust and couplings (an output-error prediction, the
//! fitted model alone carrying the axis through the block), against the recorded one. The
//! prior is simulated the same way, so the figures say how much the fit improved.

use super::fit::{axis_series, in_fit_part, Axis};
use super::record::Record;

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
        Axis::Sway => s.vel_m_s[1] = x,
    }
    let one = Record { samples: vec![s] };
    let series = axis_series(axis, &one, &thrust[k..=k], lever_arm_m);
    let mut a: f64 = series.phi[0].iter().zip(theta).map(|(p, t)| p * t).sum();
    // The rate whose derivative the axis's mass couples in: pitch for surge, roll for sway.
    let coupled = match axis {
        Axis::Surge => Some(1),
        Axis::Sway => Some(0),
        Axis::Yaw | Axis::Heave => None,
    };
    if let Some(j) = coupled {
        let lo = k.saturating_sub(1);
        let hi = (k + 1).min(rec.samples.len() - 1);
        let dt = rec.samples[hi].t_s - rec.samples[lo].t_s;
        if dt > 0.0 {
            let rate_dot = (rec.samples[hi].rate_rad_s[j] - rec.samples[lo].rate_rad_s[j]) / dt;
            a += theta.last().copied().unwrap_or(0.0) * rate_dot;
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
        Axis::Sway => s.vel_m_s[1],
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
        self.traces.each_ref().map(|t| trace_rms(t))
    }
}

/// Simulate `axis` through the held-out blocks under its parameters `theta` (Heun's method
/// at the record's period) with the nominal thrust `thrust`: `(t, recorded, simulated)`.
pub fn predict_axis(
    axis: Axis,
    theta: &[f64],
    lever_arm_m: f64,
    rec: &Record,
    thrust: &[[f64; 3]],
) -> Vec<(f64, f64, f64)> {
    let dt = rec.period_s();
    let mut trace = Vec::new();
    for block in held_out_blocks(rec) {
        let mut x = recorded(axis, rec, block.start);
        for k in block.clone() {
            trace.push((rec.samples[k].t_s, recorded(axis, rec, k), x));
            if k + 1 < rec.samples.len() {
                let a0 = accel(axis, theta, rec, thrust, lever_arm_m, k, x);
                let xp = x + dt * a0;
                let a1 = accel(axis, theta, rec, thrust, lever_arm_m, k + 1, xp);
                x += 0.5 * dt * (a0 + a1);
            }
        }
    }
    trace
}

/// RMS of simulated minus recorded over a trace of [`predict_axis`].
pub fn trace_rms(trace: &[(f64, f64, f64)]) -> f64 {
    let n = trace.len().max(1) as f64;
    (trace.iter().map(|(_, a, b)| (b - a).powi(2)).sum::<f64>() / n).sqrt()
}

/// Simulate the held-out blocks under the three axes' parameters `thetas` (Heun's method
/// at the record's period) with the nominal thrust `thrust`.
pub fn predict(
    thetas: &[Vec<f64>; 3],
    lever_arm_m: f64,
    rec: &Record,
    thrust: &[[f64; 3]],
) -> Prediction {
    let [s, y, h] = thetas;
    Prediction {
        traces: [
            predict_axis(Axis::Surge, s, lever_arm_m, rec, thrust),
            predict_axis(Axis::Yaw, y, lever_arm_m, rec, thrust),
            predict_axis(Axis::Heave, h, lever_arm_m, rec, thrust),
        ],
    }
}
