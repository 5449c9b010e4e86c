//! Scenarios: TOML files describing one closed-loop run (see `docs/scenarios.md`).
//!
//! Parsing is strict: unknown keys are rejected (`deny_unknown_fields`) and every number is
//! checked by [`Scenario::validate`] before a run starts, with an error that names the key.

mod built_in;
pub mod deployment;
mod expect;
pub mod health;
pub mod identification;
mod reference;
pub mod setup;
pub use topside::vehicle_file as vehicle;

pub use built_in::{BuiltIn, BUILT_IN};
pub use expect::ExpectSpec;
pub use identification::IdentificationSpec;
pub use reference::ReferenceSpec;

use anyhow::{anyhow, bail, Context, Result};
use controller_core::controller::ControlMode;
use controller_core::params::{Vehicle, VehicleParams};
use controller_core::reference::{Bounds, Reference};
use serde::{Deserialize, Serialize};
use sim_world::checks::{fin, nonneg, pos, vec3};
pub use sim_world::sensors::{NavSource, NavigationSpec, SensorsSpec};
use std::path::Path;

/// Which plant and which set of laws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Plane {
    /// Vertical plane: `x, z, pitch`.
    Xz,
    /// Horizontal plane: `x, y, yaw`.
    Xy,
    /// 3-D, on the 6-DOF plant.
    #[serde(rename = "3d")]
    ThreeD,
}

impl Plane {
    /// The name used in the TOML and the summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            Plane::Xz => "xz",
            Plane::Xy => "xy",
            Plane::ThreeD => "3d",
        }
    }

    /// Which inertial axes the position error is measured on.
    pub fn axes(&self) -> [bool; 3] {
        match self {
            Plane::Xz => [true, false, true],
            Plane::Xy => [true, true, false],
            Plane::ThreeD => [true, true, true],
        }
    }
}

/// Which family of control laws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ControllerKind {
    /// The paper's backstepping laws (XZ and XY only).
    Paper,
    /// The tracking laws (XZ, XY, 3-D).
    Tracking,
}

impl ControllerKind {
    /// The name used in the TOML and the summaries.
    pub fn as_str(&self) -> &'static str {
        match self {
            ControllerKind::Paper => "paper",
            ControllerKind::Tracking => "tracking",
        }
    }

    /// Parse a `--controller` value.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "paper" => Ok(Self::Paper),
            "tracking" => Ok(Self::Tracking),
            other => bail!("unknown controller {other:?}: expected \"paper\" or \"tracking\""),
        }
    }
}

fn d_ctrl() -> f64 {
    0.01
}
fn d_plant() -> f64 {
    0.001
}
fn d_hr() -> f64 {
    10.0
}
fn d_tf() -> f64 {
    100.0
}
fn d_speed() -> f64 {
    0.25
}
fn d_radius() -> f64 {
    5.0
}
fn d_leg() -> f64 {
    20.0
}
fn d_spacing() -> f64 {
    5.0
}
fn d_legs() -> u16 {
    4
}
fn d_depth_rate() -> f64 {
    0.05
}
fn d_true() -> bool {
    true
}
fn d_seed() -> u64 {
    1
}
fn d_pos_std() -> f64 {
    0.01
}
fn d_angle_std() -> f64 {
    0.002
}
fn d_vel_std() -> f64 {
    0.005
}
fn d_rate_std() -> f64 {
    0.002
}

/// The `[initial]` table: the plant's initial state (absent = 0).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InitialSpec {
    /// Inertial x (m).
    pub x_m: f64,
    /// Inertial y (m).
    pub y_m: f64,
    /// Depth (m, down).
    pub z_m: f64,
    /// Pitch (rad).
    pub pitch_rad: f64,
    /// Yaw (rad).
    pub yaw_rad: f64,
    /// Surge (m/s).
    pub u_m_s: f64,
    /// Sway (m/s).
    pub v_m_s: f64,
    /// Heave (m/s).
    pub w_m_s: f64,
    /// Pitch rate (rad/s).
    pub q_rad_s: f64,
    /// Yaw rate (rad/s).
    pub r_rad_s: f64,
}

impl InitialSpec {
    /// As a plant state.
    pub fn to_plant(&self) -> sim_world::plant::PlantState {
        sim_world::plant::PlantState {
            eta: [
                self.x_m,
                self.y_m,
                self.z_m,
                0.0,
                self.pitch_rad,
                self.yaw_rad,
            ],
            nu: [
                self.u_m_s,
                self.v_m_s,
                self.w_m_s,
                0.0,
                self.q_rad_s,
                self.r_rad_s,
            ],
        }
    }

    fn values(&self) -> [(&'static str, f64); 10] {
        [
            ("x_m", self.x_m),
            ("y_m", self.y_m),
            ("z_m", self.z_m),
            ("pitch_rad", self.pitch_rad),
            ("yaw_rad", self.yaw_rad),
            ("u_m_s", self.u_m_s),
            ("v_m_s", self.v_m_s),
            ("w_m_s", self.w_m_s),
            ("q_rad_s", self.q_rad_s),
            ("r_rad_s", self.r_rad_s),
        ]
    }
}

/// The `[thrusters]` table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThrustersSpec {
    /// Apply the per-thruster limits (default true). With `false` the controller's allocation
    /// and the plant are unlimited, as in the paper's simulations.
    #[serde(default = "d_true")]
    pub saturate: bool,
}

impl Default for ThrustersSpec {
    fn default() -> Self {
        Self { saturate: true }
    }
}

/// Standard deviations of the Gaussian measurement noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoiseStd {
    /// Position (m), each axis.
    #[serde(default = "d_pos_std")]
    pub position_m: f64,
    /// Angles (rad).
    #[serde(default = "d_angle_std")]
    pub angle_rad: f64,
    /// Linear velocities (m/s).
    #[serde(default = "d_vel_std")]
    pub velocity_m_s: f64,
    /// Angular rates (rad/s).
    #[serde(default = "d_rate_std")]
    pub rate_rad_s: f64,
}

impl Default for NoiseStd {
    fn default() -> Self {
        Self {
            position_m: d_pos_std(),
            angle_rad: d_angle_std(),
            velocity_m_s: d_vel_std(),
            rate_rad_s: d_rate_std(),
        }
    }
}

/// The `[disturbance]` table.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DisturbanceSpec {
    /// Constant ocean current `[cx, cy, cz]`, inertial (m/s).
    #[serde(default)]
    pub current_m_s: [f64; 3],
    /// Net buoyancy `B - W` of the plant (N, positive floats up); the controller is not told.
    #[serde(default)]
    pub buoyancy_offset_n: f64,
    /// Gaussian measurement noise on/off.
    #[serde(default)]
    pub noise: bool,
    /// Noise standard deviations (used when `noise = true`).
    #[serde(default)]
    pub noise_std: NoiseStd,
    /// Seed of the noise generator.
    #[serde(default = "d_seed")]
    pub noise_seed: u64,
    /// Measurement delay (s).
    #[serde(default)]
    pub delay_s: f64,
    /// The controller is told `delay_s` and predicts the state over it through the model
    /// (`controller_core::nav::predict`; at most 0.5 s). Default: not told.
    #[serde(default)]
    pub delay_known: bool,
}

impl Default for DisturbanceSpec {
    fn default() -> Self {
        Self {
            current_m_s: [0.0; 3],
            buoyancy_offset_n: 0.0,
            noise: false,
            noise_std: NoiseStd::default(),
            noise_seed: d_seed(),
            delay_s: 0.0,
            delay_known: false,
        }
    }
}

/// The longest delay the tracking law flies with `delay_known = true` (s): from 0.31 s the
/// prediction over the delay limit-cycles (measured 2026-11-26 on `delay-line-3d`, 0.3 m/s:
/// 0.30 s: 0.5 mm final; 0.31 s: 5.8 cm and growing; 0.35 s: 19 cm, thrusters saturated 17 %
/// of the time; 0.40 s: 29 cm, 39 %; on `circle-3d`: 0.30 s 2.4 mm RMS, 0.35 s 10 cm).
pub const MAX_KNOWN_DELAY_S: f64 = 0.30;

/// The most control ticks of one run (one recorded closed-loop `Sample` of about
/// 400 B each, and one CSV row): 1,000,000 ticks, 10,000 s at 10 ms, about 0.4 GB in memory.
pub const MAX_CONTROL_TICKS: f64 = 1.0e6;

/// The longest measurement delay line, in plant steps (one plant state of about 100 B each:
/// 0.1 GB at the limit; 1,000 s at 1 ms).
pub const MAX_DELAY_STEPS: f64 = 1.0e6;

/// One scenario, as written in its TOML file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name (used for the output folder).
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// `"xz"`, `"xy"` or `"3d"`.
    pub plane: Plane,
    /// `"paper"` or `"tracking"`.
    pub controller: ControllerKind,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Controller period (s), default 0.01.
    #[serde(default = "d_ctrl")]
    pub control_period_s: f64,
    /// The plant's RK4 step (s), default 0.001; sensors sample and the delay line keeps the
    /// plant at it. Unless the file writes it ([`Self::plant_dt_written`]), the truth path,
    /// where nothing reads the plant between control ticks, steps the plant once a control
    /// period instead (`RunSetup::plant_steps`).
    #[serde(default = "d_plant")]
    pub plant_dt_s: f64,
    /// The scenario's file writes `plant_dt_s`: the plant steps at it on the truth path too.
    /// Code that sets `plant_dt_s` sets this to keep its step.
    #[serde(skip)]
    pub plant_dt_written: bool,
    /// The reference.
    pub reference: ReferenceSpec,
    /// Initial state.
    #[serde(default)]
    pub initial: InitialSpec,
    /// Thruster limits.
    #[serde(default)]
    pub thrusters: ThrustersSpec,
    /// Disturbances.
    #[serde(default)]
    pub disturbance: DisturbanceSpec,
    /// Where the laws' state comes from.
    #[serde(default)]
    pub navigation: NavigationSpec,
    /// The sensors fitted (used by `navigation.source = "estimator"`).
    #[serde(default)]
    pub sensors: SensorsSpec,
    /// The seabed and a current that changes in time and with depth.
    #[serde(default)]
    pub water: sim_world::plant::water::WaterSpec,
    /// The vehicle file (`vehicles/observer.toml`'s format); the Observer when absent. A
    /// relative path is taken from the scenario file's folder, else the working directory.
    #[serde(default)]
    pub vehicle: Option<String>,
    /// What the runs must reach (`[expect]`); absent: figures without judgement.
    #[serde(default)]
    pub expect: Option<ExpectSpec>,
    /// Where the control loop runs and the node link's tether (`[deployment]`).
    #[serde(default)]
    pub deployment: crate::deployment::DeploymentSpec,
    /// `[calibration]`: first fly the compass calibration turn in `Hold`, then the scenario
    ///. Flown by the firmware (`hil`); a software `run` refuses it.
    #[serde(default)]
    pub calibration: Option<CalibrationSpec>,
    /// `[battery]`: the simulated battery (in-process firmware runs).
    #[serde(default)]
    pub battery: sim_world::battery::BatterySpec,
    /// `[health]`: health events and the vehicle's health parameters.
    #[serde(default)]
    pub health: health::HealthSpec,
    /// `[identification]`: fly the identification manoeuvre in `Hold`
    /// ([`IdentificationSpec`]). Flown by the firmware (`hil`).
    #[serde(default)]
    pub identification: Option<IdentificationSpec>,
    /// The vehicle's parameters: the file's, read by [`Scenario::load`], or the Observer.
    #[serde(skip, default = "observer_params")]
    pub vehicle_params: VehicleParams,
}

/// `[calibration]`: the compass calibration turn (`firmware::compass_swing`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationSpec {
    /// Yaw rate of the turn (rad/s, 0.05-0.6 either sign), default 0.25.
    #[serde(default = "d_cal_rate")]
    pub yaw_rate_rad_s: f64,
    /// Time limit of the turn (s, at most 600), default 60.
    #[serde(default = "d_cal_limit")]
    pub time_limit_s: f64,
}

fn d_cal_rate() -> f64 {
    0.25
}
fn d_cal_limit() -> f64 {
    60.0
}

/// Longest scenario name: it names a folder, and file systems allow 255 bytes per name
/// (Monte Carlo adds a prefix and a shard suffix).
pub const MAX_NAME_LEN: usize = 100;

fn observer_params() -> VehicleParams {
    VehicleParams::OBSERVER
}

impl Scenario {
    /// Parse and validate TOML text. `origin` names the source in error messages.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self> {
        Self::from_toml_in(text, origin, None)
    }

    /// As [`Self::from_toml`], with the folder a relative `vehicle` path is taken from.
    fn from_toml_in(text: &str, origin: &str, dir: Option<&Path>) -> Result<Self> {
        let s = Self::parse_in(text, origin, dir)?;
        s.validate().with_context(|| format!("scenario {origin}"))?;
        Ok(s)
    }

    /// The TOML text parsed and the vehicle file read, not yet checked.
    fn parse_in(text: &str, origin: &str, dir: Option<&Path>) -> Result<Self> {
        let mut s: Scenario = toml::from_str(text)
            .map_err(|e| anyhow!("scenario {origin}: {}", e.to_string().trim_end()))?;
        s.plant_dt_written =
            toml::from_str::<toml::Table>(text).is_ok_and(|table| table.contains_key("plant_dt_s"));
        if let Some(file) = &s.vehicle {
            let beside = dir.map(|d| d.join(file)).filter(|p| p.exists());
            let path = beside.unwrap_or_else(|| Path::new(file).to_path_buf());
            s.vehicle_params = crate::vehicle::load(&path)
                .with_context(|| format!("scenario {origin}: key `vehicle`"))?;
        }
        if let Some(i) = s.identification.as_mut() {
            i.load_prior(dir)
                .with_context(|| format!("scenario {origin}"))?;
        }
        Ok(s)
    }

    /// The vehicle model of the scenario (validated when the scenario was loaded).
    pub fn vehicle_model(&self) -> Result<Vehicle> {
        crate::vehicle::check(&self.vehicle_params)
    }

    /// A built-in by name, or a `.toml` file by path, checked.
    pub fn load(name_or_path: &str) -> Result<Self> {
        let (s, origin) = Self::read(name_or_path)?;
        s.validate().with_context(|| format!("scenario {origin}"))?;
        Ok(s)
    }

    /// A built-in by name, or a `.toml` file by path, parsed (not checked), with the name of
    /// its source for the messages.
    fn read(name_or_path: &str) -> Result<(Self, String)> {
        if let Some(b) = BUILT_IN.iter().find(|b| b.name == name_or_path) {
            let origin = format!("built-in {:?}", b.name);
            return Ok((Self::parse_in(b.toml, &origin, None)?, origin));
        }
        let path = Path::new(name_or_path);
        if path.exists() || name_or_path.ends_with(".toml") {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read scenario file {}", path.display()))?;
            let origin = path.display().to_string();
            return Ok((Self::parse_in(&text, &origin, path.parent())?, origin));
        }
        let names: Vec<&str> = BUILT_IN.iter().map(|b| b.name).collect();
        bail!(
            "no built-in scenario or file named {name_or_path:?}; built-ins: {}",
            names.join(", ")
        )
    }

    /// The core control mode for this plane and controller.
    pub fn control_mode(&self) -> Result<ControlMode> {
        Ok(match (self.plane, self.controller) {
            (Plane::Xz, ControllerKind::Paper) => ControlMode::PaperXz,
            (Plane::Xy, ControllerKind::Paper) => ControlMode::PaperXy,
            (Plane::Xz, ControllerKind::Tracking) => ControlMode::TrackingXz,
            (Plane::Xy, ControllerKind::Tracking) => ControlMode::TrackingXy,
            (Plane::ThreeD, ControllerKind::Tracking) => ControlMode::Tracking3d,
            (Plane::ThreeD, ControllerKind::Paper) => {
                bail!("controller \"paper\" has no 3-D mode: use plane = \"xz\" or \"xy\", or controller = \"tracking\"")
            }
        })
    }

    /// Number of plant steps per control period.
    pub fn plant_steps_per_control(&self) -> usize {
        (self.control_period_s / self.plant_dt_s).round() as usize
    }

    /// Check every value; the error names the key.
    pub fn validate(&self) -> Result<()> {
        self.check().map(|_| ())
    }

    /// Every check of [`Self::validate`]; what they resolved: the control mode and the
    /// core's reference.
    fn check(&self) -> Result<(ControlMode, Reference)> {
        if let Some(c) = &self.calibration {
            if !(0.05..=0.6).contains(&c.yaw_rate_rad_s.abs()) {
                bail!(
                    "calibration.yaw_rate_rad_s = {} must be 0.05-0.6 rad/s either way",
                    c.yaw_rate_rad_s
                );
            }
            if !(c.time_limit_s > 0.0 && c.time_limit_s <= 600.0) {
                bail!(
                    "calibration.time_limit_s = {} must be in (0, 600] s",
                    c.time_limit_s
                );
            }
            if self.navigation.source != sim_world::sensors::NavSource::Estimator {
                bail!("calibration needs navigation.source = \"estimator\" (the turn fits the estimator's yaw rate against the compass)");
            }
        }
        if let Some(i) = &self.identification {
            i.check(self.initial.z_m, self.duration_s)?;
            if self.navigation.source != sim_world::sensors::NavSource::Estimator {
                bail!("identification needs navigation.source = \"estimator\" (the vehicle flies it on its own estimate)");
            }
        }
        if self.name.trim().is_empty() {
            bail!("name must not be empty");
        }
        self.health.check(&self.battery)?;
        self.deployment.validate()?;
        self.deployment.check_with(self.navigation.source)?;
        if !self
            .name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_' || c == '.')
        {
            bail!("name {:?} may contain only letters, digits, '-', '_' and '.' (it names the output folder)", self.name);
        }
        // A plain file name: `..` or `.` would put the outputs beside or above the output
        // folder, a leading '.' hides them.
        if self.name.starts_with('.') {
            bail!(
                "name {:?} must not start with '.' (it names the output folder, which must stay inside --out)",
                self.name
            );
        }
        if self.name.len() > MAX_NAME_LEN {
            bail!(
                "name is {} characters long; at most {MAX_NAME_LEN} (it names the output folder)",
                self.name.len()
            );
        }
        pos("duration_s", self.duration_s)?;
        pos("control_period_s", self.control_period_s)?;
        pos("plant_dt_s", self.plant_dt_s)?;
        if self.plant_dt_s > self.control_period_s {
            bail!(
                "plant_dt_s ({}) must not exceed control_period_s ({})",
                self.plant_dt_s,
                self.control_period_s
            );
        }
        let ratio = self.control_period_s / self.plant_dt_s;
        if (ratio - ratio.round()).abs() > 1e-6 * ratio {
            bail!(
                "control_period_s ({}) must be a whole multiple of plant_dt_s ({})",
                self.control_period_s,
                self.plant_dt_s
            );
        }
        if self.duration_s / self.plant_dt_s > 1e9 {
            bail!("duration_s / plant_dt_s is over 1e9 steps; shorten the run or enlarge the step");
        }
        if self.duration_s / self.control_period_s > MAX_CONTROL_TICKS {
            bail!(
                "duration_s = {} s is {:.3e} control ticks at control_period_s = {} s; a run keeps \
                 and writes every tick (about 400 B each), at most {MAX_CONTROL_TICKS:.0e} ticks \
                 ({} s at this period): shorten the run",
                self.duration_s,
                self.duration_s / self.control_period_s,
                self.control_period_s,
                MAX_CONTROL_TICKS * self.control_period_s
            );
        }
        if let Some(e) = &self.expect {
            e.validate(self.duration_s)?;
        }
        let mode = self.control_mode()?;
        for (k, v) in self.initial.values() {
            fin(&format!("initial.{k}"), v)?;
        }
        let reference = self.reference.validate()?;
        self.check_reference_bounds(&reference)?;
        let d = &self.disturbance;
        vec3("disturbance.current_m_s", d.current_m_s)?;
        fin("disturbance.buoyancy_offset_n", d.buoyancy_offset_n)?;
        let nominal = self.vehicle_params;
        let weight = f64::from(nominal.mass_kg) * f64::from(nominal.gravity_m_s2);
        if d.buoyancy_offset_n.abs() > 0.5 * weight {
            bail!(
                "disturbance.buoyancy_offset_n = {} N is beyond half the vehicle's weight ({:.1} N)",
                d.buoyancy_offset_n,
                0.5 * weight
            );
        }
        self.check_buoyancy_holdable()?;
        nonneg("disturbance.delay_s", d.delay_s)?;
        if d.delay_s > self.duration_s {
            bail!("disturbance.delay_s ({}) is longer than the run", d.delay_s);
        }
        if d.delay_s / self.plant_dt_s > MAX_DELAY_STEPS {
            bail!(
                "disturbance.delay_s = {} s is {:.3e} plant steps of plant_dt_s = {} s; the delay line keeps every step of it (about 100 B each), at most {MAX_DELAY_STEPS:.0e}",
                d.delay_s,
                d.delay_s / self.plant_dt_s,
                self.plant_dt_s
            );
        }
        if d.delay_known && d.delay_s > MAX_KNOWN_DELAY_S {
            bail!(
                "disturbance.delay_s = {} s with delay_known = true: the tracking law flies a known delay up to {MAX_KNOWN_DELAY_S} s; from 0.31 s its prediction limit-cycles (0.35 s: 19 cm, thrusters saturated 17 % of the time)",
                d.delay_s
            );
        }
        nonneg("disturbance.noise_std.position_m", d.noise_std.position_m)?;
        nonneg("disturbance.noise_std.angle_rad", d.noise_std.angle_rad)?;
        nonneg(
            "disturbance.noise_std.velocity_m_s",
            d.noise_std.velocity_m_s,
        )?;
        nonneg("disturbance.noise_std.rate_rad_s", d.noise_std.rate_rad_s)?;
        self.sensors.validate()?;
        self.navigation.validate()?;
        self.water.validate()?;
        self.water
            .check_start_depth(self.initial.to_plant().eta[2])?;
        if self.navigation.source == NavSource::Estimator {
            if let Some(missing) = self.sensors.missing_for_estimator() {
                bail!("navigation.source = \"estimator\" needs {missing}");
            }
        }
        Ok((mode, reference))
    }

    /// With thruster limits, the vehicle's net buoyancy (its own plus the scenario's offset)
    /// as the vehicle itself would take it: the vehicle description with that buoyancy through
    /// the firmware's own check of a new vehicle ([`crate::vehicle::check`]: the
    /// core's validation and `Vehicle::check_flyable`, which keeps half the smaller vertical
    /// thrust to spare for control). A vehicle it refuses is refused here, with its reason.
    fn check_buoyancy_holdable(&self) -> Result<()> {
        if !self.thrusters.saturate || self.plane == Plane::Xy {
            return Ok(());
        }
        let mut p = self.vehicle_params;
        let net_n = f64::from(p.buoyancy_offset_n) + self.disturbance.buoyancy_offset_n;
        p.buoyancy_offset_n = net_n as f32;
        crate::vehicle::check(&p).map_err(|e| {
            anyhow!(
                "disturbance.buoyancy_offset_n: the net buoyancy is {net_n:.1} N ({}): the \
                 vertical thruster cannot hold the depth with room to control it; the vehicle \
                 refuses such a vehicle: {e}",
                if net_n < 0.0 { "heavy" } else { "light" }
            )
        })?;
        Ok(())
    }

    /// The reference as the vehicle takes it (`SetReference`): within the vehicle's own
    /// bounds ([`Bounds::VEHICLE`], checked by the core's `Reference::check_bounds`), or
    /// refused with the vehicle's reason and its bounds.
    fn check_reference_bounds(&self, reference: &Reference) -> Result<()> {
        let b = Bounds::VEHICLE;
        reference.check_bounds(&b).map_err(|e| {
            anyhow!(
                "reference (kind = {:?}) refused by the vehicle: {e} (its bounds: |x| and |y| \
                 within {} m of the origin, depth 0-{} m, speeds up to {} m/s)",
                self.reference.kind(),
                b.max_range_m,
                b.max_depth_m,
                b.max_speed_m_s
            )
        })
    }

    /// Magnitude of the scenario's current.
    pub fn current_magnitude_m_s(&self) -> f64 {
        let c = self.disturbance.current_m_s;
        (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt()
    }
}
