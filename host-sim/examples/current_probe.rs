//! Development probe for the tracking law in a current: one scenario flown in a current of a
//! given speed and direction (relative to the path's first course, as `current-sweep`), with
//! a time series of the true position error, the yaw, the law's yaw error, its current
//! estimate, the reference speed through the water and the feasible heading (course and
//! sideslip); or, with `sweep`, the whole current sweep as a table.
//!
//! ```text
//! cargo run -p host-sim --release --example current_probe -- circle-3d 0.3 90 [every_s]
//! cargo run -p host-sim --release --example current_probe -- sweep
//! ```
use anyhow::{bail, Context, Result};
use controller_core::reference::RefSample;
use controller_core::state::NavState;
use host_sim::closed_loop::estimator_nav::navigation_for;
use host_sim::closed_loop::{
    run_closed_loop, ControllerEndpoint, CoreEndpoint, RunOptions, StepReply,
};
use host_sim::commands::current_sweep::{first_course, sweep, RMS_BOUND_M};
use sim_scenario::Scenario;

/// The core in process, recording the law's current estimate after every step.
struct Probe {
    inner: CoreEndpoint,
    estimates: Vec<[f32; 2]>,
    /// The reference velocity (horizontal) and the law's feasible heading `[course,
    /// sideslip]`, per step.
    ref_vel: Vec<[f32; 2]>,
    heading: Vec<[f32; 2]>,
}

impl ControllerEndpoint for Probe {
    fn step(&mut self, t: f64, nav: &NavState, r: &RefSample) -> Result<StepReply> {
        let reply = self.inner.step(t, nav, r)?;
        let law = self.inner.controller().tracking_state();
        self.estimates.push(law.current_estimate_m_s());
        self.heading.push(law.feasible_heading_rad());
        self.ref_vel.push([r.vel_m_s[0], r.vel_m_s[1]]);
        Ok(reply)
    }
}

fn print_sweep() -> Result<()> {
    let cells = sweep()?;
    let mut ok = 0;
    for c in &cells {
        let met = c.rms_last80_m <= RMS_BOUND_M && c.max_after_10s_m <= 0.2 && !c.nan;
        ok += usize::from(met);
        println!(
            "{:14} {:.1} m/s {:5.0} deg  RMS {:6.1} mm  max after 10 s {:6.1} mm  thrust {:5.1} N {}",
            c.path,
            c.speed_m_s,
            c.direction_deg,
            c.rms_last80_m * 1e3,
            c.max_after_10s_m * 1e3,
            c.max_thrust_n,
            if met { "" } else { "MISS" }
        );
    }
    println!(
        "{ok} of {} cells within the current sweep's bounds",
        cells.len()
    );
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("sweep") {
        return print_sweep();
    }
    let [name, speed, dir, rest @ ..] = args.as_slice() else {
        bail!(
            "usage: current_probe SCENARIO SPEED_M_S DIRECTION_DEG [EVERY_S] | current_probe sweep"
        );
    };
    let sc = Scenario::load_setup(name)?;
    let speed: f64 = speed.parse().context("SPEED_M_S")?;
    let dir: f64 = dir.parse::<f64>().context("DIRECTION_DEG")?.to_radians();
    let every: f64 = match rest.first() {
        Some(s) => s.parse().context("EVERY_S")?,
        None => 5.0,
    };
    let course = first_course(&sc) + dir;
    let opts = RunOptions {
        record: true,
        current_m_s: Some([speed * course.cos(), speed * course.sin(), 0.0]),
        ..RunOptions::default()
    };
    let mut probe = Probe {
        inner: CoreEndpoint::for_scenario(&sc)?,
        estimates: Vec::new(),
        ref_vel: Vec::new(),
        heading: Vec::new(),
    };
    let mut nav = navigation_for(&sc, None)?;
    let out = run_closed_loop(&sc, &opts, nav.as_mut(), &mut probe)?;
    let s = &out.summary;
    println!(
        "RMS (last 80 %) {:.1} mm, max after 10 s {:.1} mm, final {:.1} mm, thrust {:.1} N, NaN {}",
        s.rms_position_error_last80_m * 1e3,
        s.max_position_error_after_10s_m * 1e3,
        s.final_position_error_m * 1e3,
        s.max_abs_thruster_force_n,
        s.nan_detected
    );
    let mut next = 0.0;
    let per_step = probe
        .estimates
        .iter()
        .zip(&probe.ref_vel)
        .zip(&probe.heading);
    for (x, ((c, v), h)) in out.log.iter().zip(per_step) {
        if x.t_s + 1e-9 >= next {
            next += every;
            println!(
                "t {:6.1} s  error {:6.1} mm ({:6.1}, {:6.1})  yaw {:6.2}  yaw error {:6.2}  yaw rate {:5.2}  current estimate ({:5.2}, {:5.2}) m/s  reference through the water {:5.3} m/s  course {:5.2}  sideslip {:5.2}",
                x.t_s,
                x.pos_err_norm_m * 1e3,
                x.pos_err_m[0] * 1e3,
                x.pos_err_m[1] * 1e3,
                x.state.eta[5],
                x.angle_err_rad,
                x.state.nu[5],
                c[0],
                c[1],
                (v[0] - c[0]).hypot(v[1] - c[1]),
                h[0],
                h[1]
            );
        }
    }
    Ok(())
}
