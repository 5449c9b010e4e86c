//! The estimator as the vehicle runs it: [`OnboardNav`] takes the IMU at the
//! control rate and the pressure sensor's readings from the MCU's buses (on the emulated board,
//! from the host), converts the pressure to depth with the fluid's density and the surface
//! pressure, fuses the fixes that come down the tether (USBL, DVL, compass), and says when a
//! sensor has gone quiet, so the firmware can put the thrusters to neutral.
//!
//! Times: `t_us` fields are the sensors' times of validity (the estimator's clock); `now_us`
//! is the firmware's clock when the reading arrived, for the freshness checks. On a board both
//! are the board's clock; in lock-step both are the host's simulated time.

use super::compass_cal::{CalRefusal, CompassCalibration};
use super::{
    DvlFix, Estimator, HeadingFix, ImuSample, NavConfig, PositionFix, Refusal, GRAVITY_M_S2,
};
use crate::error::{positive, Error};
use crate::math::wrap_angle;
use crate::params::Vehicle;
use crate::state::NavState;
use serde::{Deserialize, Serialize};

/// Fixed-point iterations that recover a raw compass reading from a corrected one: the
/// error shrinks by the deviation's slope (at most 0.53) per iteration, so 8 leave under
/// 1e-3 of it.
const RAW_READING_ITERATIONS: usize = 8;

/// Pressure to depth: `depth = (p - p_surface) / (rho g)`, and the depth's accuracy.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PressureDepth {
    /// Fluid density (kg/m^3): 1029 sea water, 997 fresh water.
    pub density_kg_m3: f32,
    /// Pressure at the surface (Pa), measured before the dive or 101,325.
    pub surface_pressure_pa: f32,
    /// Standard deviation of one depth (m): the sensor's noise at its oversampling.
    pub std_m: f32,
}

impl PressureDepth {
    /// Sea water at standard atmospheric pressure, the MS5837-30BA's 5 mm at OSR 8192.
    pub const SEA_WATER: Self = Self {
        density_kg_m3: 1029.0,
        surface_pressure_pa: 101_325.0,
        std_m: 0.005,
    };

    /// Depth (m, down) of an absolute pressure (Pa).
    pub fn depth_m(&self, pressure_pa: f32) -> f32 {
        (pressure_pa - self.surface_pressure_pa) / (self.density_kg_m3 * GRAVITY_M_S2)
    }

    /// Absolute pressure (Pa) at a depth (m): the inverse of [`depth_m`](Self::depth_m).
    pub fn pressure_pa(&self, depth_m: f32) -> f32 {
        self.surface_pressure_pa + depth_m * self.density_kg_m3 * GRAVITY_M_S2
    }
}

/// Everything the vehicle needs to start its estimator, as the surface sends it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OnboardConfig {
    /// The filters' process noise and start-up uncertainty.
    pub nav: NavConfig,
    /// Pressure to depth.
    pub pressure: PressureDepth,
    /// No IMU sample for this long (firmware clock, us) is a lost sensor.
    pub imu_timeout_us: u32,
    /// No pressure reading for this long (us) is a lost sensor.
    pub pressure_timeout_us: u32,
}

impl Default for OnboardConfig {
    /// Default filters, sea water, 0.1 s for the IMU (five samples at 50 Hz), 0.5 s for the
    /// pressure sensor (five readings at 10 Hz).
    fn default() -> Self {
        Self {
            nav: NavConfig::default(),
            pressure: PressureDepth::SEA_WATER,
            imu_timeout_us: 100_000,
            pressure_timeout_us: 500_000,
        }
    }
}

impl OnboardConfig {
    /// Check every figure (the filters', a density of 500-2000 kg/m^3, a surface pressure of
    /// 50-150 kPa, positive accuracy and timeouts).
    pub fn validate(&self) -> Result<Self, Error> {
        self.nav.validate()?;
        let p = &self.pressure;
        positive("pressure.std_m", p.std_m)?;
        if !(500.0..=2000.0).contains(&p.density_kg_m3) {
            return Err(Error::OutOfRange("pressure.density_kg_m3"));
        }
        if !(50_000.0..=150_000.0).contains(&p.surface_pressure_pa) {
            return Err(Error::OutOfRange("pressure.surface_pressure_pa"));
        }
        if self.imu_timeout_us == 0 || self.pressure_timeout_us == 0 {
            return Err(Error::NotPositive("sensor timeout"));
        }
        Ok(*self)
    }
}

/// The on-board estimator and the arrival times of its own sensors.
#[derive(Debug, Clone)]
pub struct OnboardNav {
    estimator: Estimator,
    cfg: OnboardConfig,
    last_imu_rx_us: u64,
    last_pressure_rx_us: u64,
    /// The compass's deviation (`COMPASS_DEV_*`), taken off every heading before it is
    /// fused.
    compass_cal: CompassCalibration,
}

impl OnboardNav {
    /// Start at `initial` (the launch point) at sensor time `t_us`, received at `now_us`.
    /// The sensors count as fresh from `now_us`.
    pub fn new(
        vehicle: Vehicle,
        cfg: OnboardConfig,
        initial: &NavState,
        t_us: u64,
        now_us: u64,
    ) -> Result<Self, Error> {
        let cfg = cfg.validate()?;
        Ok(Self {
            estimator: Estimator::new(vehicle, cfg.nav, initial, t_us)?,
            cfg,
            last_imu_rx_us: now_us,
            last_pressure_rx_us: now_us,
            compass_cal: CompassCalibration::NONE,
        })
    }

    /// Keep what `from`, the estimator this one restarts, learned of the instruments and the
    /// water, when this one starts where `from` agrees it is ([`Estimator::keep_learned`]);
    /// whether it was kept.
    pub fn keep_learned(&mut self, from: &OnboardNav) -> bool {
        self.estimator.keep_learned(&from.estimator)
    }

    /// An IMU sample with the thrust commanded since the last one. After a gap the
    /// prediction restarts at the sample (the gap is refused and reported, not integrated).
    pub fn imu(
        &mut self,
        now_us: u64,
        imu: &ImuSample,
        thrust_cmd_n: [f32; 3],
    ) -> Result<(), Refusal> {
        let r = self.estimator.predict(imu, thrust_cmd_n);
        if r == Err(Refusal::ImuGap) {
            self.estimator.resume_at(imu.t_us);
        }
        if r.is_ok() || r == Err(Refusal::ImuGap) {
            self.last_imu_rx_us = now_us;
        }
        r
    }

    /// A pressure reading (Pa, absolute) made at `t_us`: converted to depth with the
    /// configured fluid and accuracy, then fused as [`depth`](Self::depth).
    pub fn pressure(&mut self, now_us: u64, t_us: u64, pressure_pa: f32) -> Result<(), Refusal> {
        let fix = super::DepthFix {
            t_us,
            depth_m: self.cfg.pressure.depth_m(pressure_pa),
            std_m: self.cfg.pressure.std_m,
        };
        self.depth(now_us, &fix)
    }

    /// A depth already converted from pressure (a simulated depth sensor, whose reading
    /// carries its own accuracy), received at `now_us`; it counts for the pressure sensor's
    /// freshness as [`pressure`](Self::pressure) does.
    pub fn depth(&mut self, now_us: u64, fix: &super::DepthFix) -> Result<(), Refusal> {
        let r = self.estimator.fuse_depth(fix);
        // A gated reading still proves the sensor answers; a refused one does not.
        if matches!(r, Ok(()) | Err(Refusal::Outlier)) {
            self.last_pressure_rx_us = now_us;
        }
        r
    }

    /// A USBL fix from the surface.
    pub fn position(&mut self, fix: &PositionFix) -> Result<(), Refusal> {
        self.estimator.fuse_position(fix)
    }

    /// A DVL velocity from the surface.
    pub fn dvl(&mut self, fix: &DvlFix) -> Result<(), Refusal> {
        self.estimator.fuse_dvl(fix)
    }

    /// A compass heading (as the compass reads it): the deviation of the calibration in
    /// force taken off, then fused.
    pub fn heading(&mut self, fix: &HeadingFix) -> Result<(), Refusal> {
        if !fix.yaw_rad.is_finite() {
            return Err(Refusal::NonFinite);
        }
        let corrected = HeadingFix {
            yaw_rad: self.compass_cal.correct(fix.yaw_rad),
            ..*fix
        };
        self.estimator.fuse_heading(&corrected)
    }

    /// Replace the compass calibration (checked: finite, deviation within 30 degrees); on a
    /// refusal the one in force stays.
    ///
    /// The estimator's compass bias `b_c` is what the *corrected* readings carry beyond the
    /// heading, so it is carried over with the calibration: at the heading the estimate holds,
    /// the reading the compass gives (`r`, with `old.correct(r) = psi + b_c`) reads
    /// `new.correct(r)` from now on, and `b_c` moves by the difference. The heading estimate
    /// and every covariance stay. Without it the next corrected readings differ from the
    /// prediction by the old deviation at this heading (up to the whole hard iron), fail the
    /// gate, and the heading is reset onto them with the old bias: wrong by that much. With no
    /// heading fused yet the bias is still its prior, which no calibration informed, and
    /// stays.
    pub fn set_compass_calibration(&mut self, cal: &CompassCalibration) -> Result<(), CalRefusal> {
        let new = cal.validate()?;
        if self.estimator.health().heading_fused > 0 {
            let old = self.compass_cal;
            let (b_c, _) = self.estimator.compass_bias_rad();
            let corrected = wrap_angle(self.estimator.state().yaw_rad + b_c);
            // The raw reading `r` with `r - old.deviation(r) = corrected`: a fixed point of a
            // contraction (the deviation's slope is under 0.53, its 30 degree amplitude).
            let mut raw = corrected;
            for _ in 0..RAW_READING_ITERATIONS {
                raw = wrap_angle(corrected + old.deviation_rad(raw));
            }
            self.estimator
                .shift_compass_bias(wrap_angle(new.correct(raw) - corrected));
        }
        self.compass_cal = new;
        Ok(())
    }

    /// The compass calibration in force.
    pub fn compass_calibration(&self) -> CompassCalibration {
        self.compass_cal
    }

    /// Have the IMU and the pressure sensor both answered within their timeouts at `now_us`?
    pub fn sensors_fresh(&self, now_us: u64) -> bool {
        now_us.saturating_sub(self.last_imu_rx_us) <= u64::from(self.cfg.imu_timeout_us)
            && now_us.saturating_sub(self.last_pressure_rx_us)
                <= u64::from(self.cfg.pressure_timeout_us)
    }

    /// The estimator (state, covariance, counters).
    pub fn estimator(&self) -> &Estimator {
        &self.estimator
    }

    /// Is the estimate ready for the modes that need a position (`Track`, `Hold`, AUTO,
    /// GUIDED)? See [`Estimator::position_ready`]; the firmware refuses those modes with the
    /// reason until it is.
    pub fn position_ready(&self) -> Result<(), super::NotReady> {
        self.estimator.position_ready()
    }

    /// Standard deviation of the position estimate `[north, east, down]` (m).
    pub fn position_std_m(&self) -> [f32; 3] {
        let [[pxx, ..], [_, pyy, _], [.., pzz]] = self.estimator.position_covariance();
        [pxx, pyy, pzz].map(|v| crate::math::sqrt(v.max(0.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn start() -> OnboardNav {
        OnboardNav::new(
            Vehicle::observer(),
            OnboardConfig::default(),
            &NavState::default(),
            0,
            0,
        )
        .unwrap()
    }

    fn start_at(x_m: f32) -> OnboardNav {
        let at = NavState {
            x_m,
            ..NavState::default()
        };
        OnboardNav::new(Vehicle::observer(), OnboardConfig::default(), &at, 0, 0).unwrap()
    }

    #[test]
    fn a_restart_where_the_estimate_agrees_keeps_what_it_learned() {
        let mut running = start();
        running.estimator.shift_compass_bias(0.05);
        let learned = running.estimator.compass_bias_rad();
        assert!((learned.0 - 0.05).abs() < 1e-6);
        // 0.1 m from the running estimate (each known to 0.5 m): kept, bias and variance.
        let mut near = start_at(0.1);
        assert!(near.keep_learned(&running));
        assert_eq!(near.estimator.compass_bias_rad(), learned);
        // 10 m off (beyond three standard deviations): the running one went wrong.
        let mut far = start_at(10.0);
        assert!(!far.keep_learned(&running));
        assert_eq!(far.estimator.compass_bias_rad().0, 0.0);
    }

    fn level_imu(t_us: u64) -> ImuSample {
        ImuSample {
            t_us,
            gyro_rad_s: [0.0; 3],
            accel_m_s2: [0.0, 0.0, -GRAVITY_M_S2],
        }
    }

    #[test]
    fn pressure_and_depth_are_inverse() {
        let p = PressureDepth::SEA_WATER;
        for d in [0.0f32, 1.0, 10.0, 100.0] {
            assert!((p.depth_m(p.pressure_pa(d)) - d).abs() < 1e-3, "{d}");
        }
        // 10 m of sea water is about one atmosphere.
        assert!((p.pressure_pa(10.0) - 2.0 * 101_325.0).abs() < 2_000.0);
    }

    #[test]
    fn invalid_configs_are_refused_with_the_key() {
        let mut c = OnboardConfig::default();
        c.pressure.density_kg_m3 = f32::NAN;
        assert!(c.validate().is_err());
        let c = OnboardConfig {
            imu_timeout_us: 0,
            ..OnboardConfig::default()
        };
        assert!(c.validate().is_err());
        let mut c = OnboardConfig::default();
        c.nav.tilt_time_constant_s = -1.0;
        assert!(c.validate().is_err());
    }

    #[test]
    fn a_quiet_sensor_is_not_fresh() {
        let mut n = start();
        for k in 1..=10u64 {
            n.imu(k * 20_000, &level_imu(k * 20_000), [0.0; 3]).unwrap();
            if k % 5 == 0 {
                n.pressure(k * 20_000, k * 20_000, 101_325.0).unwrap();
            }
        }
        assert!(n.sensors_fresh(200_000));
        // IMU quiet for 0.12 s: lost.
        assert!(!n.sensors_fresh(320_000));
        // A refused (non-finite) sample does not refresh it.
        let mut bad = level_imu(220_000);
        bad.accel_m_s2[0] = f32::NAN;
        assert_eq!(n.imu(220_000, &bad, [0.0; 3]), Err(Refusal::NonFinite));
        assert_eq!(n.estimator().time_us(), 200_000);
        // Pressure quiet for more than 0.5 s while the IMU runs: lost too.
        for k in 11..=40u64 {
            n.imu(k * 20_000, &level_imu(k * 20_000), [0.0; 3]).unwrap();
        }
        assert!(!n.sensors_fresh(800_000));
    }

    #[test]
    fn depth_follows_the_pressure() {
        let mut n = start();
        let p = PressureDepth::SEA_WATER;
        for k in 1..=500u64 {
            let t = k * 20_000;
            n.imu(t, &level_imu(t), [0.0; 3]).unwrap();
            if k % 5 == 0 {
                // 2 m from a start known to 0.1 m: the first readings fail the gate, the
                // sixth resets the depth to them (the estimator's recovery rule).
                let r = n.pressure(t, t, p.pressure_pa(2.0));
                assert!(matches!(r, Ok(()) | Err(Refusal::Outlier)), "{r:?}");
            }
        }
        assert!((n.estimator().state().z_m - 2.0).abs() < 0.02);
        assert_eq!(n.estimator().health().resets, 1);
        assert!(n.position_std_m()[2] < 0.05);
    }
}
