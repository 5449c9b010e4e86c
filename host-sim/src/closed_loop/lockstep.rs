//! Two runs of one scenario stepped together, for campaigns (Monte Carlo): each control
//! tick runs both loops' control, then their 6-DOF plants step side by side
//! ([`SixDof::step_lanes`](sim_world::plant::six_dof::SixDof::step_lanes)), so one run's
//! chain of dependent operations fills the other's waits. Each run's figures are the bits
//! of the same run stepped alone ([`ClosedLoop::step`]): the lanes compute what the plant
//! computes, and everything else is each loop's own code in its own order.
//!
//! Runs whose plants are not both 6-DOF, or whose plant steps differ, or a run that goes on
//! after the other stopped, are stepped alone.

use super::endpoint::ControllerEndpoint;
use super::navigation::Navigation;
use super::sim_loop::{ClosedLoop, RunOptions, RunOutput};
use anyhow::Result;
use sim_scenario::setup::RunSetup;
use sim_world::plant::six_dof::SixDof;

/// One control period of both loops: their control ticks, then their plants through the
/// period, side by side when both are 6-DOF plants with the same steps. Returns whether each
/// run goes on.
pub fn step_pair<N1, E1, N2, E2>(
    a: &mut ClosedLoop<N1, E1>,
    b: &mut ClosedLoop<N2, E2>,
) -> Result<[bool; 2]>
where
    N1: Navigation,
    E1: ControllerEndpoint,
    N2: Navigation,
    E2: ControllerEndpoint,
{
    let (fa, fb) = (a.control()?, b.control()?);
    let (Some(fa), Some(fb)) = (fa, fb) else {
        // At most one run goes on: it steps alone.
        if let Some(f) = fa {
            a.advance(f);
        }
        if let Some(f) = fb {
            b.advance(f);
        }
        return Ok([fa.is_some(), fb.is_some()]);
    };
    let (n_sub, dt) = a.plant_steps();
    if b.plant_steps() != (n_sub, dt) || a.six_dof_mut().is_none() || b.six_dof_mut().is_none() {
        a.advance(fa);
        b.advance(fb);
        return Ok([true, true]);
    }
    for i in 0..n_sub {
        if let (Some(pa), Some(pb)) = (a.six_dof_mut(), b.six_dof_mut()) {
            SixDof::step_lanes(&mut [pa, pb], [fa, fb], dt);
        }
        a.after_plant_step(i);
        b.after_plant_step(i);
    }
    a.end_period();
    b.end_period();
    Ok([true, true])
}

/// Step both loops to their ends, together while both run.
pub fn run_pair<N1, E1, N2, E2>(
    a: &mut ClosedLoop<N1, E1>,
    b: &mut ClosedLoop<N2, E2>,
) -> Result<()>
where
    N1: Navigation,
    E1: ControllerEndpoint,
    N2: Navigation,
    E2: ControllerEndpoint,
{
    loop {
        match step_pair(a, b)? {
            [true, true] => {}
            [true, false] => while a.step()? {},
            [false, true] => while b.step()? {},
            [false, false] => return Ok(()),
        }
    }
}

/// Two runs of the scenario `sc` (options `opts[0]`, `opts[1]`), each with its navigation
/// stage and its controller endpoint, stepped together ([`run_pair`]): the same outputs as
/// [`super::run_closed_loop`] of each.
pub fn run_closed_loop_pair(
    sc: &RunSetup,
    opts: [&RunOptions; 2],
    navs: [&mut dyn Navigation; 2],
    endpoints: [&mut dyn ControllerEndpoint; 2],
) -> Result<[RunOutput; 2]> {
    let [oa, ob] = opts;
    let [na, nb] = navs;
    let [ea, eb] = endpoints;
    let mut a = ClosedLoop::new(sc, oa, na, ea)?;
    let mut b = ClosedLoop::new(sc, ob, nb, eb)?;
    run_pair(&mut a, &mut b)?;
    Ok([a.finish().0, b.finish().0])
}

#[cfg(test)]
mod tests {
    use crate::closed_loop::report::Summary;
    use crate::closed_loop::runner::{nominal_plant_params, run, run_two, RunOptions};
    use sim_scenario::Scenario;

    /// A summary and its log without the wall time (the one figure in which two runs of the
    /// same bits differ).
    fn figures(s: &Summary, log: &[crate::closed_loop::Sample]) -> String {
        let mut s = s.clone();
        s.wall_time_s = 0.0;
        format!("{s:?} {log:?}")
    }

    /// Two different runs of the Monte Carlo case (plant, current, noise seed, length: the
    /// shorter one stops first and the other goes on alone) stepped together give, tick for
    /// tick, the bits of each run alone.
    #[test]
    fn two_runs_stepped_together_are_the_bits_of_each_alone() {
        let sc = Scenario::load_setup("mc-circle-3d").unwrap();
        let nominal = nominal_plant_params(&sc);
        let mut heavy = nominal;
        heavy.mass_kg *= 1.15;
        heavy.z_g_m *= 0.8;
        heavy.n_rdot_kg_m2 *= 1.2;
        let run_a = RunOptions {
            record: true,
            plant_params: Some(nominal),
            current_m_s: Some([0.1, 0.0, 0.0]),
            noise_seed: Some(3),
            duration_s: Some(12.0),
            ..RunOptions::default()
        };
        let run_b = RunOptions {
            plant_params: Some(heavy),
            current_m_s: Some([0.0, -0.1, 0.0]),
            noise_seed: Some(4),
            duration_s: Some(8.0),
            ..run_a
        };
        let together = run_two(&sc, [&run_a, &run_b]).unwrap();
        for (pair, opts) in together.iter().zip([&run_a, &run_b]) {
            let alone = run(&sc, opts).unwrap();
            assert!(alone.log.len() > 700, "{} ticks", alone.log.len());
            assert_eq!(
                figures(&pair.summary, &pair.log),
                figures(&alone.summary, &alone.log)
            );
        }
        assert_ne!(
            together[0].summary.final_state,
            together[1].summary.final_state
        );
    }
}
