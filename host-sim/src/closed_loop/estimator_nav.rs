//! The navigation stage of `[navigation] source = "estimator"`: the scenario's simulated
//! sensors ([`sim_world::sensors`]) feed the core's [`OnboardNav`] - the estimator as the vehicle
//! runs it, through its entry points, one per sensor (as PX4's EKF2 has its `set*Data`) - and
//! the laws see only its output. Measurements reach the estimator when they *arrive* (a USBL fix `latency_s` after
//! its ping), in arrival order, at the control tick; the IMU samples drive the prediction
//! with the thrust commands held over the period.
//!
//! At every control tick the estimate is compared with the truth for the summary: the
//! position NEES `e^T P^-1 e` on the plane's axes against the 95 % chi-square bound.

use crate::closed_loop::floor::{FloorNoise, FloorRecorder};
use crate::closed_loop::navigation::{to_nav, FixRecord, Navigation, TruthNav};
use crate::closed_loop::report::NavReport;
use anyhow::{anyhow, Result};
use controller_core::nav::compass_cal::CompassCalibration;
use controller_core::nav::onboard::{OnboardConfig, OnboardNav, PressureDepth};
use controller_core::nav::{Estimator, HeadingFix, NavConfig};
use controller_core::state::NavState;
use sim_scenario::setup::RunSetup;
use sim_scenario::Scenario;
use sim_world::clock::us;
use sim_world::plant::PlantState;
use sim_world::sensor_sim::SensorSuite;
use sim_world::sensors::{Measurement, NavSource, SensorsSpec};

/// 95 % quantile of the chi-square distribution with 1, 2 and 3 degrees of freedom.
pub const CHI2_95: [f64; 3] = [3.841, 5.991, 7.815];

/// The measurements of `pending` (`(arrival_s, measurement)`) that have arrived by `t_s`,
/// taken out in arrival order; the rest stay. The sort is stable: measurements with the same
/// arrival keep the order they were made in. The one order for both the host's estimator
/// ([`EstimatorNav`]) and the vehicle's ([`VehicleNav`]).
fn take_arrived(pending: &mut Vec<(f64, Measurement)>, t_s: f64) -> Vec<(f64, Measurement)> {
    pending.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n_due = pending.partition_point(|(arr, _)| *arr <= t_s + 1e-9);
    pending.drain(..n_due).collect()
}

/// The vehicle's estimator ([`OnboardNav`]) on simulated sensors, in process.
pub struct EstimatorNav {
    onboard: OnboardNav,
    sensors: SensorSuite,
    pending: Vec<(f64, Measurement)>,
    axes: [bool; 3],
    truth: PlantState,
    nees_in: u64,
    nees_n: u64,
    fixes: Vec<FixRecord>,
    /// The first control tick at which the estimate was ready for position modes (s).
    ready_at_s: Option<f64>,
    /// The compass calibration applied to each heading fix.
    compass_cal: CompassCalibration,
    /// What the estimator was given, for the floor's smoother.
    floor: FloorRecorder,
}

/// The estimator's process noise for a sensor suite: the simulated IMU's figures, floored by
/// the defaults of [`NavConfig`]; the start-up bias uncertainties are the IMU's bias spreads.
pub fn nav_config(spec: &SensorsSpec) -> NavConfig {
    let mut cfg = NavConfig::default();
    if let Some(s) = &spec.imu {
        // The filter's process noise is the IMU's or, where larger, the default's (which
        // carries what the decoupled filters neglect).
        let at_least = |spec: f64, floor: f32| (spec as f32).max(floor);
        cfg.gyro_noise_rad_s_sqrt_hz =
            at_least(s.gyro_noise_rad_s_sqrt_hz, cfg.gyro_noise_rad_s_sqrt_hz);
        cfg.gyro_bias_walk_rad_s_sqrt_s = at_least(
            s.gyro_bias_walk_rad_s_sqrt_s,
            cfg.gyro_bias_walk_rad_s_sqrt_s,
        );
        cfg.accel_noise_m_s2_sqrt_hz =
            at_least(s.accel_noise_m_s2_sqrt_hz, cfg.accel_noise_m_s2_sqrt_hz);
        cfg.accel_bias_walk_m_s2_sqrt_s = at_least(
            s.accel_bias_walk_m_s2_sqrt_s,
            cfg.accel_bias_walk_m_s2_sqrt_s,
        );
        cfg.initial_gyro_bias_std_rad_s = s.gyro_bias_rad_s.max(1e-4) as f32;
        cfg.initial_accel_bias_std_m_s2 = s.accel_bias_m_s2.max(1e-3) as f32;
    }
    cfg
}

impl EstimatorNav {
    /// The estimator of a scenario, started at the scenario's initial state (the launch
    /// point), its sensors drawing from `seed`'s stream. The set-up checked the sensors the
    /// estimator needs ([`Scenario::resolve`]).
    pub fn for_scenario(sc: &RunSetup, seed: u64) -> Result<Self> {
        let initial = sc.initial();
        let cfg = onboard_config(sc);
        let told = to_nav(&sc.navigation.told_start(&initial));
        let onboard = OnboardNav::new(*sc.vehicle(), cfg, &told, 0, 0)
            .map_err(|e| anyhow!("estimator: {e}"))?;
        let floor = FloorRecorder::new(*sc.vehicle(), floor_noise(sc), told, sc.plane.axes());
        let mut sensors = SensorSuite::new(&sc.sensors, seed);
        sensors.set_seabed_depth_m(sc.water.seabed_depth_m);
        Ok(Self {
            onboard,
            sensors,
            pending: Vec::new(),
            axes: sc.plane.axes(),
            truth: initial,
            nees_in: 0,
            nees_n: 0,
            fixes: Vec::new(),
            ready_at_s: None,
            compass_cal: compass_calibration(sc),
            floor,
        })
    }

    /// The first control tick at which the estimate was ready for position modes
    /// ([`Estimator::position_ready`]), in seconds of simulated time.
    pub fn position_ready_at_s(&self) -> Option<f64> {
        self.ready_at_s
    }

    /// The estimator (for its covariance, current and counters).
    pub fn estimator(&self) -> &Estimator {
        self.onboard.estimator()
    }

    /// Every USBL fix so far.
    pub fn fixes(&self) -> &[FixRecord] {
        &self.fixes
    }

    /// One measurement into its entry point of [`OnboardNav`], received at `arrival_s`. A
    /// refusal is the estimator's to count (its health); the stage records the USBL fixes'.
    fn deliver(&mut self, arrival_s: f64, m: Measurement, thrust_cmd_n: [f32; 3]) {
        let now_us = us(arrival_s);
        let nav = &mut self.onboard;
        match m {
            Measurement::Imu(s) => {
                if nav.imu(now_us, &s, thrust_cmd_n).is_ok() {
                    let st = nav.estimator().state();
                    let tilt = (st.roll_rad, st.pitch_rad, st.q_rad_s);
                    self.floor.imu(&s, tilt, thrust_cmd_n);
                }
            }
            Measurement::Depth(f) => {
                self.floor.depth(&f);
                let _ = nav.depth(now_us, &f);
            }
            Measurement::Heading(f) => {
                let f = HeadingFix {
                    yaw_rad: self.compass_cal.correct(f.yaw_rad),
                    ..f
                };
                self.floor.heading(&f);
                let _ = nav.heading(&f);
            }
            Measurement::Dvl(f) => {
                self.floor.dvl(&f);
                let _ = nav.dvl(&f);
            }
            Measurement::Position(f, outlier) => {
                self.floor.position(&f);
                let r = nav.position(&f);
                self.fixes.push(FixRecord {
                    t_valid_s: f.t_us as f64 * 1e-6,
                    t_arrival_s: arrival_s,
                    pos_m: [f64::from(f.north_m), f64::from(f.east_m)],
                    outlier,
                    refused: r.err(),
                });
            }
        }
    }

    /// Position NEES on the plane's axes, and its degrees of freedom.
    fn nees(&self, nav: &NavState) -> Option<(f64, usize)> {
        let p = self.estimator().position_covariance();
        let est = [nav.x_m, nav.y_m, nav.z_m];
        let idx: Vec<usize> = (0..3).filter(|&i| self.axes[i]).collect();
        let e: Vec<f64> = idx
            .iter()
            .map(|&i| f64::from(est[i]) - self.truth.eta[i])
            .collect();
        let m: Vec<Vec<f64>> = idx
            .iter()
            .map(|&i| idx.iter().map(|&j| f64::from(p[i][j])).collect())
            .collect();
        let v = quad_inverse(&m, &e)?;
        Some((v, idx.len()))
    }
}

/// `e^T M^-1 e` for a 1x1, 2x2 or 3x3 symmetric positive-definite `M` (None otherwise).
fn quad_inverse(m: &[Vec<f64>], e: &[f64]) -> Option<f64> {
    match e.len() {
        1 => (m[0][0] > 0.0).then(|| e[0] * e[0] / m[0][0]),
        2 => {
            let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
            (det > 0.0).then(|| {
                (e[0] * e[0] * m[1][1] - 2.0 * e[0] * e[1] * m[0][1] + e[1] * e[1] * m[0][0]) / det
            })
        }
        3 => {
            // Adjugate of a symmetric 3x3.
            let (a, b, c) = (m[0][0], m[0][1], m[0][2]);
            let (d, f, i) = (m[1][1], m[1][2], m[2][2]);
            let c00 = d * i - f * f;
            let c01 = c * f - b * i;
            let c02 = b * f - c * d;
            let c11 = a * i - c * c;
            let c12 = b * c - a * f;
            let c22 = a * d - b * b;
            let det = a * c00 + b * c01 + c * c02;
            (det > 0.0).then(|| {
                (e[0] * (c00 * e[0] + c01 * e[1] + c02 * e[2])
                    + e[1] * (c01 * e[0] + c11 * e[1] + c12 * e[2])
                    + e[2] * (c02 * e[0] + c12 * e[1] + c22 * e[2]))
                    / det
            })
        }
        _ => None,
    }
}

impl Navigation for EstimatorNav {
    fn observe(&mut self, t_s: f64, truth: &PlantState) {
        let before = self.pending.len();
        self.sensors.sample(t_s, truth, &mut self.pending);
        self.truth = *truth;
        // The truth at each IMU sample's time, for the floor's score.
        let imu_now = self
            .pending
            .iter()
            .skip(before)
            .any(|(_, m)| matches!(m, Measurement::Imu(_)));
        if imu_now {
            self.floor
                .truth(us(t_s), [truth.eta[0], truth.eta[1], truth.eta[2]]);
        }
    }

    fn estimate(&mut self, t_s: f64, thrust_cmd_n: [f64; 3]) -> NavState {
        let due = take_arrived(&mut self.pending, t_s);
        let cmd = thrust_cmd_n.map(|f| f as f32);
        self.sensors.set_thrust_n(thrust_cmd_n);
        for (arrival, m) in due {
            self.deliver(arrival, m, cmd);
        }
        let nav = self.estimator().state();
        let est = [nav.x_m, nav.y_m, nav.z_m];
        let err = [0, 1, 2].map(|i| f64::from(est[i]) - self.truth.eta[i]);
        self.floor.filter_error(t_s, err);
        if self.ready_at_s.is_none() && self.onboard.position_ready().is_ok() {
            self.ready_at_s = Some(t_s);
        }
        if let Some((nees, dof)) = self.nees(&nav) {
            self.nees_n += 1;
            if nees <= CHI2_95[dof - 1] {
                self.nees_in += 1;
            }
        }
        nav
    }

    fn position_std_m(&self) -> Option<[f64; 3]> {
        let p = self.estimator().position_covariance();
        Some([0, 1, 2].map(|i| f64::from(p[i][i]).sqrt()))
    }

    fn usbl_fixes(&self) -> Vec<FixRecord> {
        self.fixes.clone()
    }

    fn report(&self) -> NavReport {
        NavReport {
            source: "estimator".into(),
            nees_in_bounds_fraction: (self.nees_n > 0)
                .then(|| self.nees_in as f64 / self.nees_n as f64),
            usbl_outliers_injected: self.sensors.usbl_outliers_injected,
            usbl_fixes_rejected: u64::from(self.estimator().health().position_outliers),
            floor: self.floor.floor(),
        }
    }
}

/// The floor's process noise: the IMU's stated gyro figures, the estimator's settings for
/// what no sensor states ([`crate::closed_loop::floor`]).
fn floor_noise(sc: &Scenario) -> FloorNoise {
    let nav = onboard_config(sc).nav;
    let (ng, wb) = sc.sensors.imu.as_ref().map_or(
        (
            f64::from(nav.gyro_noise_rad_s_sqrt_hz),
            f64::from(nav.gyro_bias_walk_rad_s_sqrt_s),
        ),
        |s| (s.gyro_noise_rad_s_sqrt_hz, s.gyro_bias_walk_rad_s_sqrt_s),
    );
    FloorNoise {
        gyro_noise_rad_s_sqrt_hz: ng,
        gyro_bias_walk_rad_s_sqrt_s: wb,
        nav,
    }
}

/// The scenario's compass calibration (`[navigation] compass_calibration`), or none.
fn compass_calibration(sc: &Scenario) -> CompassCalibration {
    sc.navigation
        .compass_calibration
        .map_or(CompassCalibration::NONE, |[a, b]| CompassCalibration {
            sin_rad: a as f32,
            cos_rad: b as f32,
        })
}

/// The start uncertainties of `[navigation]`, where given, in place of the
/// defaults.
fn start_config(sc: &Scenario, mut cfg: NavConfig) -> NavConfig {
    if let Some(v) = sc.navigation.start_position_std_m {
        cfg.initial_position_std_m = v as f32;
    }
    if let Some(v) = sc.navigation.start_heading_std_rad {
        cfg.initial_heading_std_rad = v as f32;
    }
    cfg
}

/// The on-board estimator's settings for a scenario: the filters of [`nav_config`], sea water
/// with the depth sensor's noise, the default sensor timeouts.
pub fn onboard_config(sc: &Scenario) -> OnboardConfig {
    let mut pressure = PressureDepth::SEA_WATER;
    if let Some(d) = &sc.sensors.depth {
        // The same accuracy the simulated sensor gives its fixes (`sensors.rs`).
        pressure.std_m = d.noise_m.max(1e-4) as f32;
    }
    OnboardConfig {
        nav: start_config(sc, nav_config(&sc.sensors)),
        pressure,
        ..OnboardConfig::default()
    }
}

/// `source = "estimator"` with the estimator on the vehicle (hardware in the loop): the
/// scenario's simulated sensors are delivered to the firmware as they arrive, and the
/// firmware estimates; the loop scores the estimate the firmware reports.
pub struct VehicleNav {
    sensors: SensorSuite,
    pending: Vec<(f64, Measurement)>,
    initial: NavState,
    fixes: Vec<FixRecord>,
    /// The compass calibration the surface applies before it sends a heading.
    compass_cal: CompassCalibration,
}

impl VehicleNav {
    /// The sensors of a scenario, drawing from `seed`'s stream (the same draws as
    /// [`EstimatorNav::for_scenario`] with the same seed).
    pub fn for_scenario(sc: &RunSetup, seed: u64) -> Self {
        let mut sensors = SensorSuite::new(&sc.sensors, seed);
        sensors.set_seabed_depth_m(sc.water.seabed_depth_m);
        Self {
            sensors,
            pending: Vec::new(),
            initial: to_nav(&sc.navigation.told_start(&sc.initial())),
            fixes: Vec::new(),
            compass_cal: compass_calibration(sc),
        }
    }
}

impl Navigation for VehicleNav {
    fn observe(&mut self, t_s: f64, truth: &PlantState) {
        self.sensors.sample(t_s, truth, &mut self.pending);
    }

    /// The launch point (what the vehicle's estimator starts from); the loop uses the
    /// vehicle's own estimate after that.
    fn estimate(&mut self, _t_s: f64, thrust_cmd_n: [f64; 3]) -> NavState {
        self.sensors.set_thrust_n(thrust_cmd_n);
        self.initial
    }

    fn for_vehicle(&mut self, t_s: f64) -> Vec<Measurement> {
        let due = take_arrived(&mut self.pending, t_s);
        for (arrival, m) in &due {
            if let Measurement::Position(f, outlier) = m {
                self.fixes.push(FixRecord {
                    t_valid_s: f.t_us as f64 * 1e-6,
                    t_arrival_s: *arrival,
                    pos_m: [f64::from(f.north_m), f64::from(f.east_m)],
                    outlier: *outlier,
                    // The firmware's verdict comes back as a Nack, counted by the endpoint.
                    refused: None,
                });
            }
        }
        let cal = self.compass_cal;
        due.into_iter()
            .map(|(_, m)| match m {
                Measurement::Heading(f) => Measurement::Heading(HeadingFix {
                    yaw_rad: cal.correct(f.yaw_rad),
                    ..f
                }),
                other => other,
            })
            .collect()
    }

    fn usbl_fixes(&self) -> Vec<FixRecord> {
        self.fixes.clone()
    }

    fn report(&self) -> NavReport {
        NavReport {
            source: "estimator on the vehicle".into(),
            nees_in_bounds_fraction: None,
            usbl_outliers_injected: self.sensors.usbl_outliers_injected,
            usbl_fixes_rejected: 0,
            floor: None,
        }
    }
}

/// The navigation stage of hardware in the loop: the truth path, or the simulated sensors
/// delivered to the firmware's estimator ([`VehicleNav`]).
pub fn navigation_for_vehicle(sc: &RunSetup) -> Box<dyn Navigation> {
    match sc.navigation.source {
        NavSource::Truth => Box::new(TruthNav::for_scenario(sc, None)),
        NavSource::Estimator => Box::new(VehicleNav::for_scenario(sc, sc.disturbance.noise_seed)),
    }
}

/// The navigation stage a scenario asks for: the truth path (`source = "truth"`) or the
/// estimator on the simulated sensors. `seed` replaces the scenario's noise seed (Monte Carlo).
pub fn navigation_for(sc: &RunSetup, seed: Option<u64>) -> Result<Box<dyn Navigation>> {
    Ok(match sc.navigation.source {
        NavSource::Truth => Box::new(TruthNav::for_scenario(sc, seed)),
        NavSource::Estimator => Box::new(EstimatorNav::for_scenario(
            sc,
            seed.unwrap_or(sc.disturbance.noise_seed),
        )?),
    })
}
