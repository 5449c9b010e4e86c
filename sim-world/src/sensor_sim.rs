//! The simulated sensors ([`SensorSuite`]): IMU, depth, compass, DVL and USBL sampled from
//! the true state at their rates, with their noise, biases, latencies and dropouts.

use super::frames::{body_to_inertial, inertial_to_body};
use super::noise::gauss;
use super::sensors::{Measurement, SensorsSpec};
use crate::clock::us;
use crate::plant::PlantState;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// When a sensor samples next.
#[derive(Debug, Clone, Copy)]
struct Clock {
    period_s: f64,
    next_s: f64,
}

impl Clock {
    fn new(rate_hz: f64) -> Self {
        Self {
            period_s: 1.0 / rate_hz,
            next_s: 1.0 / rate_hz,
        }
    }

    /// True once per period, at the first plant step at or after the sample time.
    fn due(&mut self, t_s: f64) -> bool {
        if t_s + 1e-9 >= self.next_s {
            self.next_s += self.period_s;
            if self.next_s <= t_s {
                self.next_s = t_s + self.period_s;
            }
            true
        } else {
            false
        }
    }
}

fn in_dropout(d: &[[f64; 2]], t: f64) -> bool {
    d.iter().any(|[a, b]| t >= *a && t < *b)
}

/// The simulated sensors of a scenario: they see every plant step and emit measurements
/// with their arrival times.
#[derive(Debug)]
pub struct SensorSuite {
    spec: SensorsSpec,
    rng: ChaCha8Rng,
    /// Outliers draw from a stream of their own, so that a run with outliers has the same
    /// noise on every other fix as the run without.
    outlier_rng: ChaCha8Rng,
    imu_clock: Option<Clock>,
    depth_clock: Option<Clock>,
    compass_clock: Option<Clock>,
    dvl_clock: Option<Clock>,
    usbl_clock: Option<Clock>,
    gyro_bias: [f64; 3],
    accel_bias: [f64; 3],
    prev: Option<(f64, [f64; 3])>,
    /// USBL fixes drawn as outliers, delivered or not (one drawn in a run's last latency
    /// window never arrives; the run's summary counts the delivered ones, from the fixes).
    pub usbl_outliers_injected: u64,
    /// The thrust command `[F1x, F2x, F3z]` (N) the compass's thrust offset sees.
    thrust_n: [f64; 3],
    /// The USBL latency jitter draws from a stream of its own (stream 2), so a run without
    /// jitter has the draws it had before.
    jitter_rng: ChaCha8Rng,
    /// The seabed's depth (m), for the DVL's bottom lock.
    seabed_depth_m: Option<f64>,
}

impl SensorSuite {
    /// The sensors of `spec`, with their noise and biases drawn from `seed`'s stream.
    pub fn new(spec: &SensorsSpec, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut outlier_rng = ChaCha8Rng::seed_from_u64(seed);
        outlier_rng.set_stream(1);
        let mut jitter_rng = ChaCha8Rng::seed_from_u64(seed);
        jitter_rng.set_stream(2);
        let mut draw3 = |sd: f64| [0; 3].map(|_| sd * gauss(&mut rng));
        let (gyro_bias, accel_bias) = match &spec.imu {
            Some(s) => (draw3(s.gyro_bias_rad_s), draw3(s.accel_bias_m_s2)),
            None => ([0.0; 3], [0.0; 3]),
        };
        Self {
            imu_clock: spec.imu.as_ref().map(|s| Clock::new(s.rate_hz)),
            depth_clock: spec.depth.as_ref().map(|s| Clock::new(s.rate_hz)),
            compass_clock: spec.compass.as_ref().map(|s| Clock::new(s.rate_hz)),
            dvl_clock: spec.dvl.as_ref().map(|s| Clock::new(s.rate_hz)),
            usbl_clock: spec.usbl.as_ref().map(|s| Clock::new(s.rate_hz)),
            spec: spec.clone(),
            rng,
            outlier_rng,
            gyro_bias,
            accel_bias,
            prev: None,
            usbl_outliers_injected: 0,
            thrust_n: [0.0; 3],
            jitter_rng,
            seabed_depth_m: None,
        }
    }

    /// The seabed's depth (m): the DVL has bottom lock only within its `max_altitude_m`.
    pub fn set_seabed_depth_m(&mut self, seabed_depth_m: Option<f64>) {
        self.seabed_depth_m = seabed_depth_m;
    }

    /// The thrust command `[F1x, F2x, F3z]` (N) in force: the compass's thrust offset
    /// follows it from the next sample on.
    pub fn set_thrust_n(&mut self, thrust_n: [f64; 3]) {
        self.thrust_n = thrust_n;
    }

    /// Sample the sensors due at `t_s` on the true state; push `(arrival_s, measurement)`.
    pub fn sample(&mut self, t_s: f64, truth: &PlantState, out: &mut Vec<(f64, Measurement)>) {
        let vel = body_to_inertial(&truth.eta, [truth.nu[0], truth.nu[1], truth.nu[2]]);
        let accel_inertial = match self.prev {
            Some((t0, v0)) if t_s > t0 => [0, 1, 2].map(|i| (vel[i] - v0[i]) / (t_s - t0)),
            _ => [0.0; 3],
        };
        let dt_prev = self.prev.map_or(0.0, |(t0, _)| t_s - t0);
        self.prev = Some((t_s, vel));
        let t_us = us(t_s);
        let rng = &mut self.rng;

        if let (Some(s), Some(c)) = (&self.spec.imu, &mut self.imu_clock) {
            // The random walks advance every plant step.
            if dt_prev > 0.0 {
                for b in &mut self.gyro_bias {
                    *b += s.gyro_bias_walk_rad_s_sqrt_s * dt_prev.sqrt() * gauss(rng);
                }
                for b in &mut self.accel_bias {
                    *b += s.accel_bias_walk_m_s2_sqrt_s * dt_prev.sqrt() * gauss(rng);
                }
            }
            if c.due(t_s) {
                let sq = s.rate_hz.sqrt();
                // Specific force in body axes: R^T (a - g), g = [0, 0, 9.80665] (z down).
                let f_inertial = [
                    accel_inertial[0],
                    accel_inertial[1],
                    accel_inertial[2] - 9.806_65,
                ];
                let f_body = inertial_to_body(&truth.eta, f_inertial);
                let gyro = [0, 1, 2].map(|i| {
                    truth.nu[3 + i]
                        + self.gyro_bias[i]
                        + s.gyro_noise_rad_s_sqrt_hz * sq * gauss(rng)
                });
                let accel = [0, 1, 2].map(|i| {
                    f_body[i] + self.accel_bias[i] + s.accel_noise_m_s2_sqrt_hz * sq * gauss(rng)
                });
                out.push((
                    t_s,
                    Measurement::Imu(controller_core::nav::ImuSample {
                        t_us,
                        gyro_rad_s: gyro.map(|v| v as f32),
                        accel_m_s2: accel.map(|v| v as f32),
                    }),
                ));
            }
        }
        if let (Some(s), Some(c)) = (&self.spec.depth, &mut self.depth_clock) {
            if c.due(t_s) {
                let z = truth.eta[2] + s.bias_m + s.noise_m * gauss(rng);
                out.push((
                    t_s,
                    Measurement::Depth(controller_core::nav::DepthFix {
                        t_us,
                        depth_m: z as f32,
                        std_m: s.noise_m.max(1e-4) as f32,
                    }),
                ));
            }
        }
        if let (Some(s), Some(c)) = (&self.spec.compass, &mut self.compass_clock) {
            if c.due(t_s) {
                let psi = s.reading_rad(truth.eta[5], self.thrust_n) + s.noise_rad * gauss(rng);
                let psi = (psi + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI;
                out.push((
                    t_s,
                    Measurement::Heading(controller_core::nav::HeadingFix {
                        t_us,
                        yaw_rad: psi as f32,
                        std_rad: s.noise_rad.max(1e-4) as f32,
                    }),
                ));
            }
        }
        if let (Some(s), Some(c)) = (&self.spec.dvl, &mut self.dvl_clock) {
            let lock = match (s.max_altitude_m, self.seabed_depth_m) {
                (Some(a), Some(d)) => d - truth.eta[2] <= a,
                _ => true,
            };
            if c.due(t_s) && lock && !in_dropout(&s.dropouts_s, t_s) {
                let read = s.reading_m_s([truth.nu[0], truth.nu[1]]);
                let v = [0, 1].map(|i| read[i] + s.noise_m_s * gauss(rng));
                out.push((
                    t_s,
                    Measurement::Dvl(controller_core::nav::DvlFix {
                        t_us,
                        velocity_m_s: v.map(|x| x as f32),
                        std_m_s: s.noise_m_s.max(1e-4) as f32,
                    }),
                ));
            }
        }
        if let (Some(s), Some(c)) = (&self.spec.usbl, &mut self.usbl_clock) {
            if c.due(t_s) && !in_dropout(&s.dropouts_s, t_s) {
                let noisy = (
                    truth.eta[0] + s.noise_m * gauss(rng),
                    truth.eta[1] + s.noise_m * gauss(rng),
                );
                let orng = &mut self.outlier_rng;
                let outlier = orng.random::<f64>() < s.outlier_fraction;
                let (n, e) = if outlier {
                    self.usbl_outliers_injected += 1;
                    let d = s.outlier_m * (1.0 + orng.random::<f64>());
                    let a = std::f64::consts::TAU * orng.random::<f64>();
                    (truth.eta[0] + d * a.cos(), truth.eta[1] + d * a.sin())
                } else {
                    noisy
                };
                let (n, e) = (n + s.bias_m[0], e + s.bias_m[1]);
                let (n, e) = if t_s >= s.step_at_s {
                    (n + s.step_m[0], e + s.step_m[1])
                } else {
                    (n, e)
                };
                let jitter_s = if s.latency_jitter_s > 0.0 {
                    s.latency_jitter_s * self.jitter_rng.random::<f64>()
                } else {
                    0.0
                };
                out.push((
                    t_s + s.latency_s + jitter_s,
                    Measurement::Position(
                        controller_core::nav::PositionFix {
                            t_us,
                            north_m: n as f32,
                            east_m: e as f32,
                            std_m: s.noise_m.max(1e-3) as f32,
                        },
                        outlier,
                    ),
                ));
            }
        }
    }
}
