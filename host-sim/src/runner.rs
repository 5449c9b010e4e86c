//! A software run: the scenario's plant and navigation around the core's [`Controller`]
//! in process, through the one closed loop of [`crate::sim_loop`].
//!
//! With `[thrusters] saturate = false` (the paper's setting) the controller is built with
//! unlimited thrusters (1 MN), so its allocation passes the request through, and the plant
//! applies no limits; the PWM column still uses the real map (clamped) for reference.
//!
//! [`Controller`]: controller_core::controller::Controller

use crate::estimator_nav::navigation_for;
use crate::scenario::Scenario;
use crate::sim_loop::{run_closed_loop, CoreEndpoint};
use anyhow::Result;

pub use crate::sim_loop::{
    body_to_inertial, make_plant, nominal_plant_params, to_nav, verdict, RunOptions, RunOutput,
    Sample, Summary,
};

/// Run one scenario with the core controller in process.
/// `[deployment] control = "topside"` flies the paper's layout (issue 25,
/// [`crate::topside_layout`]) in the same loop.
pub fn run(sc: &Scenario, opts: &RunOptions) -> Result<RunOutput> {
    sc.validate()?;
    if sc.deployment.control == crate::topside_layout::Control::Topside {
        return Ok(crate::topside_layout::run_layout(sc, opts)?.run);
    }
    let mut endpoint = CoreEndpoint::for_scenario(sc)?;
    let mut nav = navigation_for(sc, opts.noise_seed)?;
    run_closed_loop(sc, opts, nav.as_mut(), &mut endpoint)
}
