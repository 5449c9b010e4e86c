//! A recorded run as the fit reads it: time, body velocities and rates, attitude, and the
//! three ESC pulses, from a run's `timeseries.csv` (columns found by name, so the file may
//! carry more). The pulses become thrust through the prior vehicle's curve and its
//! thrusters' first-order lag: the thrust each thruster would make if the vehicle were the
//! prior; the fit's thrust scales correct it.

use anyhow::{anyhow, bail, Context, Result};
use controller_core::alloc::PwmMap;
use controller_core::params::VehicleParams;
use std::path::Path;

/// The columns the fit needs.
pub const COLUMNS: [&str; 12] = [
    "t_s",
    "u_m_s",
    "v_m_s",
    "w_m_s",
    "p_rad_s",
    "q_rad_s",
    "r_rad_s",
    "roll_rad",
    "pitch_rad",
    "pwm1_us",
    "pwm2_us",
    "pwm3_us",
];

/// One sample of a record.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RecordSample {
    /// Time (s).
    pub t_s: f64,
    /// Body velocities `[u, v, w]` (m/s).
    pub vel_m_s: [f64; 3],
    /// Body rates `[p, q, r]` (rad/s).
    pub rate_rad_s: [f64; 3],
    /// Roll and pitch (rad).
    pub tilt_rad: [f64; 2],
    /// ESC pulses `[F1x, F2x, F3z]` (us).
    pub pulse_us: [f64; 3],
}

/// A record: samples in time order at a steady period.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Record {
    /// The samples.
    pub samples: Vec<RecordSample>,
}

impl Record {
    /// Read a run's `timeseries.csv`.
    pub fn from_timeseries_csv(path: &Path) -> Result<Self> {
        let mut rd = csv::Reader::from_path(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let headers = rd.headers()?.clone();
        let mut index = [0usize; 12];
        for (slot, name) in index.iter_mut().zip(COLUMNS) {
            *slot = headers
                .iter()
                .position(|h| h == name)
                .ok_or_else(|| anyhow!("{}: no column `{name}`", path.display()))?;
        }
        let mut samples = Vec::new();
        for (line, rec) in rd.records().enumerate() {
            let rec = rec.with_context(|| format!("{}: row {}", path.display(), line + 2))?;
            let mut v = [0.0f64; 12];
            for (out, &i) in v.iter_mut().zip(&index) {
                let field = rec.get(i).unwrap_or("");
                *out = field.parse().map_err(|_| {
                    anyhow!(
                        "{}: row {}: `{field}` is not a number",
                        path.display(),
                        line + 2
                    )
                })?;
            }
            let [t, u, vv, w, p, q, r, roll, pitch, p1, p2, p3] = v;
            samples.push(RecordSample {
                t_s: t,
                vel_m_s: [u, vv, w],
                rate_rad_s: [p, q, r],
                tilt_rad: [roll, pitch],
                pulse_us: [p1, p2, p3],
            });
        }
        let r = Self { samples };
        r.check()?;
        Ok(r)
    }

    /// Finite numbers, time rising at a steady period, enough samples.
    pub fn check(&self) -> Result<()> {
        if self.samples.len() < 100 {
            bail!(
                "the record has {} samples; a fit needs at least 100",
                self.samples.len()
            );
        }
        let dt = self.period_s();
        if !(dt > 0.0 && dt.is_finite()) {
            bail!("the record's time does not rise");
        }
        for (k, pair) in self.samples.windows(2).enumerate() {
            if let [a, b] = pair {
                let step = b.t_s - a.t_s;
                if !(step > 0.5 * dt && step < 1.5 * dt) {
                    bail!(
                        "the record's time step at row {} is {step} s, not its period {dt} s",
                        k + 2
                    );
                }
            }
        }
        let finite = |s: &RecordSample| {
            s.vel_m_s
                .iter()
                .chain(&s.rate_rad_s)
                .chain(&s.tilt_rad)
                .chain(&s.pulse_us)
                .all(|x| x.is_finite())
        };
        if let Some(k) = self.samples.iter().position(|s| !finite(s)) {
            bail!("row {} of the record is not finite", k + 2);
        }
        Ok(())
    }

    /// The sampling period (s): the mean step.
    pub fn period_s(&self) -> f64 {
        match (self.samples.first(), self.samples.last()) {
            (Some(a), Some(b)) if self.samples.len() > 1 => {
                (b.t_s - a.t_s) / (self.samples.len() - 1) as f64
            }
            _ => f64::NAN,
        }
    }

    /// The nominal thrust of each thruster `[F1x, F2x, F3z]` (N) at each sample: the prior's
    /// pulse curve, then its thrusters' first-order lag (solved exactly over each period,
    /// the pulse held).
    pub fn nominal_thrust_n(&self, prior: &VehicleParams) -> Result<Vec<[f64; 3]>> {
        self.nominal_thrust_lagged_n(prior, f64::from(prior.thruster_time_constant_s))
    }

    /// As [`Self::nominal_thrust_n`] with the lag's time constant `tc` (s).
    pub fn nominal_thrust_lagged_n(&self, prior: &VehicleParams, tc: f64) -> Result<Vec<[f64; 3]>> {
        let vehicle = prior
            .validate()
            .map_err(|e| anyhow!("prior vehicle: {e}"))?;
        let pwm = PwmMap::for_vehicle(&vehicle);
        let decay = if tc > 0.0 {
            (-self.period_s() / tc).exp()
        } else {
            0.0
        };
        let mut f = [0.0f64; 3];
        let mut out = Vec::with_capacity(self.samples.len());
        for s in &self.samples {
            out.push(f);
            for (fi, p) in f.iter_mut().zip(s.pulse_us) {
                let cmd = f64::from(pwm.thrust_n(p as f32));
                *fi = cmd + (*fi - cmd) * decay;
            }
        }
        Ok(out)
    }
}
