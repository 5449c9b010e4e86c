//! A software run: the scenario's plant and navigation around the core's [`Controller`]
//! in process, through the one closed loop of [`crate::closed_loop`].
//!
//! With `[thrusters] saturate = false` (the paper's setting) the controller is built with
//! unlimited thrusters (1 MN), so its allocation passes the request through, and the plant
//! applies no limits; the PWM column still uses the real map (clamped) for reference.
//!
//! [`Controller`]: controller_core::controller::Controller

use crate::closed_loop::estimator_nav::navigation_for;
use crate::closed_loop::lockstep::run_closed_loop_pair;
use crate::closed_loop::{run_closed_loop, CoreEndpoint};
use anyhow::{bail, Result};
use sim_scenario::deployment::Control;
use sim_scenario::setup::RunSetup;

pub use crate::closed_loop::{
    make_plant, nominal_plant_params, to_nav, verdict, RunOptions, RunOutput, Sample, Summary,
};
pub use sim_world::frames::body_to_inertial;

/// Run one resolved scenario ([`sim_scenario::Scenario::resolve`]) with the core
/// controller in process.
/// A scenario whose `[deployment] control = "topside"` is refused here: the topside layout
/// is an endpoint of the tether layer (`tether::topside_layout::run_layout`), which
/// `host-sim run` and `hil --in-process` fly.
pub fn run(sc: &RunSetup, opts: &RunOptions) -> Result<RunOutput> {
    refuse_topside(sc)?;
    let mut endpoint = CoreEndpoint::for_scenario(sc)?;
    let mut nav = navigation_for(sc, opts.noise_seed)?;
    run_closed_loop(sc, opts, nav.as_mut(), &mut endpoint)
}

/// Two runs of one resolved scenario, as [`run`] of each, stepped together
/// ([`crate::closed_loop::lockstep`]): the same outputs, in less CPU time.
pub fn run_two(sc: &RunSetup, opts: [&RunOptions; 2]) -> Result<[RunOutput; 2]> {
    refuse_topside(sc)?;
    let [oa, ob] = opts;
    let (mut ea, mut eb) = (
        CoreEndpoint::for_scenario(sc)?,
        CoreEndpoint::for_scenario(sc)?,
    );
    let mut na = navigation_for(sc, oa.noise_seed)?;
    let mut nb = navigation_for(sc, ob.noise_seed)?;
    run_closed_loop_pair(sc, opts, [na.as_mut(), nb.as_mut()], [&mut ea, &mut eb])
}

fn refuse_topside(sc: &RunSetup) -> Result<()> {
    if sc.deployment.control == Control::Topside {
        bail!(
            "{}: deployment.control = \"topside\" flies the topside layout \
             (tether::topside_layout::run_layout), not the core in process",
            sc.name
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim_scenario::Scenario;

    /// The Monte Carlo case on the truth path (one RK4 step a control period, 10 ms) against
    /// the same run at a tenth of a millisecond (`plant_dt_s` set): the trajectory and the
    /// tracking figures agree to well under a micrometre (measured: nanometres).
    #[test]
    fn one_step_a_tick_tracks_a_fine_step_reference() {
        let load = |extra: &str| {
            let mut sc = Scenario::load("mc-circle-3d").unwrap();
            sc.duration_s = 30.0;
            if !extra.is_empty() {
                sc.plant_dt_written = true;
                sc.plant_dt_s = 1e-4;
            }
            sc.resolve().unwrap()
        };
        let (tick, fine) = (load(""), load("fine"));
        assert_eq!(tick.plant_steps(), (1, 0.01));
        assert_eq!(fine.plant_steps(), (100, 1e-4));
        let a = run(&tick, &RunOptions::default()).unwrap().summary;
        let b = run(&fine, &RunOptions::default()).unwrap().summary;
        assert_eq!((a.sim_steps, b.sim_steps), (3_000, 300_000));
        let off = a
            .final_state
            .iter()
            .zip(b.final_state.iter())
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(off < 1e-6, "final states {off:e} apart");
        for (x, y) in [
            (a.rms_position_error_m, b.rms_position_error_m),
            (a.rms_position_error_last80_m, b.rms_position_error_last80_m),
            (a.max_position_error_m, b.max_position_error_m),
        ] {
            assert!((x - y).abs() < 1e-6, "{x} against {y}");
        }
        assert!(a.rms_position_error_m > 1e-3, "the run tracks something");
    }
}
