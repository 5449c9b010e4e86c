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
