//! A scenario resolved once into what a run needs ([`RunSetup`]): the scenario checked
//! ([`Scenario::resolve`]), the vehicle models, the core's reference and control mode, the
//! initial state. The loop, the navigation stages and the controller endpoints take a
//! `RunSetup`, so nothing downstream checks the scenario again; the core's
//! `Reference::validate` stays the one check of the reference (`reference.rs`).

use super::Scenario;
use anyhow::{anyhow, Context, Result};
use controller_core::controller::ControlMode;
use controller_core::params::Vehicle;
use controller_core::reference::Reference;
use sim_world::plant::PlantState;
use sim_world::sensors::NavSource;

/// A checked scenario and what it resolves to. Only [`Scenario::resolve`] makes one, so
/// holding a `RunSetup` means the scenario passed every check; it reads as the scenario
/// (`Deref`) and cannot be changed (change the [`Scenario`] and resolve it again).
#[derive(Debug, Clone)]
pub struct RunSetup {
    scenario: Scenario,
    vehicle: Vehicle,
    controller_vehicle: Vehicle,
    reference: Reference,
    mode: ControlMode,
    initial: PlantState,
    plant_steps: (usize, f64),
}

/// The longest RK4 step the plant takes when nothing reads it between control ticks: an
/// RK4 step of the vehicle's fastest modes (roll and pitch near 5 rad/s, the quadratic drag
/// below 2 / s up to the 100 m/s divergence bound) at 10 ms is well inside RK4's stability
/// region, and the trajectory is that of 1 ms steps within 1e-8 m (docs/host-sim.md).
pub const MAX_TICK_STEP_S: f64 = 0.01;

/// The plant's steps per control period and its RK4 step: on the truth path (unless the
/// scenario writes `plant_dt_s`), when the
/// delay is a whole number of the control period's even slices of at most
/// [`MAX_TICK_STEP_S`] (and no finer than `plant_dt_s`), those slices, since no sensor and no
/// delay line reads the plant between them; otherwise `plant_dt_s`, so every sensor sample
/// and delayed state falls on a step.
fn plant_steps(s: &Scenario) -> (usize, f64) {
    let fine = (s.plant_steps_per_control().max(1), s.plant_dt_s);
    if s.plant_dt_written || s.navigation.source != NavSource::Truth {
        return fine;
    }
    let n = (s.control_period_s / MAX_TICK_STEP_S - 1e-9)
        .ceil()
        .max(1.0);
    let dt = s.control_period_s / n;
    let delay_steps = s.disturbance.delay_s / dt;
    let whole = (delay_steps - delay_steps.round()).abs() <= 1e-9 * delay_steps.max(1.0);
    if whole && dt > s.plant_dt_s {
        (n as usize, dt)
    } else {
        fine
    }
}

impl Scenario {
    /// A built-in by name, or a `.toml` file by path, resolved for a run: the one check of
    /// the run ([`Self::resolve`]), its refusals as [`Scenario::load`]'s.
    pub fn load_setup(name_or_path: &str) -> Result<RunSetup> {
        let (s, origin) = Self::read(name_or_path)?;
        s.resolve().with_context(|| format!("scenario {origin}"))
    }

    /// Check every value ([`Self::validate`]) and resolve the scenario into what a run needs
    /// (vehicle models, the core's reference and mode, the initial state): the one check of a
    /// run; the loop, the navigation stages and the endpoints take the [`RunSetup`].
    pub fn resolve(&self) -> Result<RunSetup> {
        let (mode, reference) = self.check()?;
        RunSetup::new(self.clone(), mode, reference)
    }
}

impl RunSetup {
    /// Resolve a scenario whose own keys were checked (`mode` and `reference` are what that
    /// check resolved): the vehicle models are resolved here.
    fn new(scenario: Scenario, mode: ControlMode, reference: Reference) -> Result<Self> {
        // The controller's model: with `saturate = false` (the paper's setting) unlimited
        // thrusters (1 MN), so the allocation passes the request through.
        let mut p = scenario.vehicle_params;
        if !scenario.thrusters.saturate {
            p.thrust_max_forward_n = 1.0e6;
            p.thrust_max_reverse_n = 1.0e6;
        }
        let controller_vehicle = p
            .validate()
            .map_err(|e| anyhow!("controller parameters: {e}"))?;
        let vehicle = scenario.vehicle_model()?;
        let initial = scenario.initial.to_plant();
        let plant_steps = plant_steps(&scenario);
        Ok(Self {
            scenario,
            vehicle,
            controller_vehicle,
            reference,
            mode,
            initial,
            plant_steps,
        })
    }

    /// The scenario (checked).
    pub fn scenario(&self) -> &Scenario {
        &self.scenario
    }

    /// The scenario back, to change it (then [`Scenario::resolve`] again).
    pub fn into_scenario(self) -> Scenario {
        self.scenario
    }

    /// The vehicle's model (the real thruster limits: the plant's, the PWM map's).
    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    /// The controller's model: the vehicle's, with unlimited thrusters when the scenario
    /// says `saturate = false`.
    pub fn controller_vehicle(&self) -> &Vehicle {
        &self.controller_vehicle
    }

    /// The core's reference (checked by the core's `Reference::validate`).
    pub fn reference(&self) -> &Reference {
        &self.reference
    }

    /// The core's control mode for the scenario's plane and controller.
    pub fn mode(&self) -> ControlMode {
        self.mode
    }

    /// The plant's initial state.
    pub fn initial(&self) -> PlantState {
        self.initial
    }

    /// The plant's RK4 steps per control period and the step (s): `plant_dt_s`, or on the
    /// truth path, where nothing reads the plant between control ticks, one step a control
    /// period (at most [`MAX_TICK_STEP_S`]).
    pub fn plant_steps(&self) -> (usize, f64) {
        self.plant_steps
    }
}

impl std::ops::Deref for RunSetup {
    type Target = Scenario;

    fn deref(&self) -> &Scenario {
        &self.scenario
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn steps(extra: &str) -> (usize, f64) {
        let text = format!(
            "name = \"s\"\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 2.0\n{extra}\n\
             [reference]\nkind = \"hold\"\n"
        );
        Scenario::from_toml(&text, "s")
            .unwrap()
            .resolve()
            .unwrap()
            .plant_steps()
    }

    /// The truth path steps the plant once a control period (in slices of at most 10 ms)
    /// when the delay is whole steps of it; a delay between steps, a `plant_dt_s` written,
    /// or sensors (which sample at `plant_dt_s`) keep `plant_dt_s`.
    #[test]
    fn the_truth_path_steps_the_plant_once_a_tick_when_nothing_reads_it_between() {
        assert_eq!(steps(""), (1, 0.01));
        assert_eq!(steps("control_period_s = 0.05"), (5, 0.01));
        assert_eq!(
            steps("control_period_s = 0.02\nplant_dt_s = 0.02"),
            (1, 0.02)
        );
        assert_eq!(steps("[disturbance]\ndelay_s = 0.3"), (1, 0.01));
        assert_eq!(steps("[disturbance]\ndelay_s = 0.015"), (10, 0.001));
        assert_eq!(steps("plant_dt_s = 0.001"), (10, 0.001));
        assert_eq!(steps("plant_dt_s = 0.0001"), (100, 0.0001));
        let nav = Scenario::load_setup("nav-circle-3d").unwrap();
        assert_eq!(nav.plant_steps(), (10, 0.001));
        let mc = Scenario::load_setup("mc-circle-3d").unwrap();
        assert_eq!(mc.plant_steps(), (1, 0.01));
    }
}
