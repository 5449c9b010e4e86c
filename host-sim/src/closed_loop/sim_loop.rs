//! The one closed loop: the `f64` plant at `plant_dt_s`, a navigation stage, and a controller
//! endpoint at `control_period_s` with a zero-order hold. Every run uses it: the software run
//! (`host-sim run`, Monte Carlo), the firmware library's `App` in process, and the firmware
//! over the tether (hardware in the loop, `host-sim hil`, and the vehicle served by `host-sim
//! vehicle`). Only the endpoint differs, so the plant, the measurement path,
//! the logging, the metrics and the stop rules are the same code. [`ClosedLoop`] is stepped
//! one control period at a time (`new`, `step`, `finish`); [`run_closed_loop`] steps it to
//! the end; `host-sim vehicle` steps it in (scaled) real time between the surface's bytes.
//!
//! Each control tick at `t = k * control_period_s`:
//! 1. the [`Navigation`] stage gives the state the controller sees (today's truth path: the
//!    plant state `delay_s` ago with Gaussian noise, [`TruthNav`]);
//! 2. the reference is sampled at `t` (for the metrics, and for an in-process core);
//! 3. the [`ControllerEndpoint`] runs one control step and says what the thrusters were
//!    commanded and what the plant gets (the thrust of the pulse widths, for the firmware);
//! 4. the metrics are computed from the *true* plant state: the position error is always the
//!    body origin against the reference for the body origin, on the plane's axes;
//! 5. the plant runs `control_period_s / plant_dt_s` steps with that thrust held, and the
//!    navigation stage sees every plant step.
//!
//! The run stops early when the state or the requested forces stop being finite
//! (`nan_detected`) or when it leaves the physical (`diverged`: |position| > 10 km,
//! |velocity| > 100 m/s, |rate| > 100 rad/s, or a thrust command above 10 kN). A run that
//! completes and misses its tracking figures is judged at its end on the true state for
//! control lost (`lost_control`, then `diverged`): the depth or position error still growing
//! past 1 m, the vehicle turning over 2 turns more than its path, or over 1 m off after the
//! settle time ([`crate::closed_loop::rules`]). Then the run is judged against its
//! scenario's `[expect]` ([`judge`]); the rule that decided is the summary's `rule`. An
//! endpoint that fails (the firmware refused a command,
//! the link was lost) ends the run with an error.

use super::endpoint::ControllerEndpoint;
use super::navigation::FixRecord;
use super::navigation::Navigation;
use super::report::{judge, meets_tracking_figures, missed_rule, ratio, verdict, Rule, Summary};
use super::rules::{divergence, lost_control, DiagonalNees, EndFigures, IdentRoom, Turns};
use anyhow::{anyhow, Result};
use controller_core::params::VehicleParams;
use controller_core::reference::{RefSample, Reference};
use controller_core::state::{BodyForces, TrackingErrors};
use serde::Serialize;
use sim_scenario::setup::RunSetup;
use sim_scenario::{ExpectSpec, Plane, Scenario, MAX_CONTROL_TICKS};
use sim_world::frames::body_to_inertial;
use sim_world::plant::six_dof::SixDof;
use sim_world::plant::water::WaterSpec;
use sim_world::plant::xy::XyPlant;
use sim_world::plant::xz::XzPlant;
use sim_world::plant::{Environment, Plant, PlantState};
use std::time::Instant;

/// The result of one run.
#[derive(Debug, Clone, Default)]
pub struct RunOutput {
    /// Summary figures.
    pub summary: Summary,
    /// Per-tick log (empty unless `record`).
    pub log: Vec<Sample>,
    /// The USBL fixes of an estimator run (empty unless `record`).
    pub usbl_fixes: Vec<FixRecord>,
}

/// What a run may change from the scenario (Monte Carlo and HIL use these).
#[derive(Debug, Clone, Copy, Default)]
pub struct RunOptions {
    /// Keep the per-tick log (for CSV and plots).
    pub record: bool,
    /// Plant parameters instead of the nominal Observer (the controller keeps the nominal).
    pub plant_params: Option<VehicleParams>,
    /// Current instead of the scenario's.
    pub current_m_s: Option<[f64; 3]>,
    /// Noise seed instead of the scenario's.
    pub noise_seed: Option<u64>,
    /// Simulated duration instead of the scenario's (s).
    pub duration_s: Option<f64>,
    /// No end: the loop runs until its driver stops stepping it (the topside). The windows
    /// of the end (the last 20 %, the last 80 %) are those of the scenario's duration.
    pub open_ended: bool,
}

/// One logged control tick.
#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Sample {
    /// Time (s).
    pub t_s: f64,
    /// True plant state.
    #[serde(skip)]
    pub state: PlantState,
    /// Position the controller was given (the navigation stage's output).
    pub nav_pos_m: [f64; 3],
    /// Standard deviation of that position per axis, when the stage reports one.
    pub nav_pos_std_m: Option<[f64; 3]>,
    /// Reference position.
    pub ref_pos_m: [f64; 3],
    /// Reference velocity (inertial).
    pub ref_vel_m_s: [f64; 3],
    /// Position error on the plane's axes (zero on the others).
    pub pos_err_m: [f64; 3],
    /// Norm of `pos_err_m`.
    pub pos_err_norm_m: f64,
    /// Inertial velocity error of the body origin on the plane's axes.
    pub vel_err_m_s: [f64; 3],
    /// Angle error reported by the law (pitch in XZ, yaw otherwise).
    pub angle_err_rad: f64,
    /// Everything the law reported.
    #[serde(skip)]
    pub law_errors: TrackingErrors,
    /// Requested generalized forces `[tau_1, tau_2, tau_3]`.
    pub requested: [f64; 3],
    /// Achieved generalized forces after allocation.
    pub achieved: [f64; 3],
    /// Thruster commands `[F1x, F2x, F3z]`.
    pub thrust_cmd_n: [f64; 3],
    /// Thrust delivered by the plant's thrusters (after lag).
    pub thrust_n: [f64; 3],
    /// PWM pulses (real map, clamped).
    pub pulse_us: [f64; 3],
    /// The allocation clamped the request (or, unlimited, a thrust exceeded the real limits).
    pub saturated: bool,
}

/// Build the plant for a scenario.
pub fn make_plant(
    plane: Plane,
    params: &VehicleParams,
    env: Environment,
    saturate: bool,
    initial: PlantState,
) -> Result<Box<dyn Plant>> {
    Ok(match plane {
        Plane::Xz => Box::new(XzPlant::new(params, env, saturate, initial)),
        Plane::Xy => Box::new(XyPlant::new(params, env, saturate, initial)),
        Plane::ThreeD => Box::new(SixDof::new(params, env, saturate, initial)),
    })
}

/// The nominal plant parameters of a scenario: its vehicle (the Observer unless the key
/// `vehicle` names another) with the scenario's buoyancy offset added to the vehicle's.
pub fn nominal_plant_params(sc: &Scenario) -> VehicleParams {
    let mut p = sc.vehicle_params;
    p.buoyancy_offset_n += sc.disturbance.buoyancy_offset_n as f32;
    p
}

/// Sums of squares over the windows the summary reports.
#[derive(Debug, Default)]
struct Rms {
    sq: f64,
    n: u64,
}

impl Rms {
    fn add(&mut self, e: f64) {
        self.sq += e * e;
        self.n += 1;
    }

    fn value(&self) -> f64 {
        if self.n > 0 {
            (self.sq / self.n as f64).sqrt()
        } else {
            f64::NAN
        }
    }
}

/// What the loop accumulates for the summary: the RMS windows, the largest figures, the
/// control-lost judgement's first-half and tail extremes, the turns against the path.
#[derive(Debug)]
struct Metrics {
    all: Rms,
    tail: Rms,
    last80: Rms,
    est: Rms,
    n_sat: u64,
    /// Start of the last 20 % and of the last 80 % (s).
    t_tail: f64,
    t_80: f64,
    settle_s: f64,
    first_half_max: f64,
    first_half_depth_max: f64,
    tail_min: f64,
    tail_depth_min: f64,
    heading_judged: bool,
    depth_judged: bool,
    turns: Turns,
    /// The NEES of an endpoint's own estimate (the firmware's), from the standard deviations
    /// it reports.
    endpoint_nees: DiagonalNees,
    /// With `[identification]`: the room the manoeuvre was given and how far it went.
    ident_room: Option<IdentRoom>,
}

/// The closed loop of one run, stepped one control period at a time: the plant, the
/// navigation stage `N`, the controller endpoint `E`, the metrics, the log and the stop rules.
/// [`run_closed_loop`] steps it to the end; the topside steps it in (scaled) real time
/// between the ground stations' commands.
pub struct ClosedLoop<N: Navigation, E: ControllerEndpoint> {
    nav: N,
    endpoint: E,
    plant: Box<dyn Plant>,
    reference: Reference,
    /// The water: a current varying in time or with depth is set each period.
    water: WaterSpec,
    /// The constant current the varying one starts from (m/s).
    current_m_s: [f64; 3],
    plane: Plane,
    axes: [bool; 3],
    expect: Option<ExpectSpec>,
    lim_fwd: f64,
    lim_rev: f64,
    /// Plant steps per control period, their length, the control period (s).
    n_sub: usize,
    dt: f64,
    tc: f64,
    /// The last control tick (`None`: open-ended, run until the driver stops).
    n_ctrl: Option<u64>,
    record: bool,
    /// The next control tick.
    k: u64,
    /// The thrust command held over the period that just ended (N).
    held_cmd: [f64; 3],
    /// The run has stopped (completed, diverged or not finite).
    done: bool,
    wall: Instant,
    s: Summary,
    m: Metrics,
    last: Sample,
    log: Vec<Sample>,
}

impl<N: Navigation, E: ControllerEndpoint> ClosedLoop<N, E> {
    /// The loop of a resolved scenario with `nav` as the navigation stage and `endpoint` as
    /// the controller: the plant built, nothing stepped yet (the endpoint is started by the
    /// first [`step`](Self::step)). The scenario was checked once, when it was resolved.
    pub fn new(sc: &RunSetup, opts: &RunOptions, nav: N, endpoint: E) -> Result<Self> {
        let wall = Instant::now();
        let saturate = sc.thrusters.saturate;
        let nominal = sc.vehicle();
        let (lim_fwd, lim_rev) = (
            f64::from(nominal.params().thrust_max_forward_n),
            f64::from(nominal.params().thrust_max_reverse_n),
        );

        let plant_params = opts
            .plant_params
            .unwrap_or_else(|| nominal_plant_params(sc));
        plant_params
            .validate()
            .map_err(|e| anyhow!("plant parameters: {e}"))?;
        let env = Environment {
            current_m_s: opts.current_m_s.unwrap_or(sc.disturbance.current_m_s),
        };
        let mut plant = make_plant(sc.plane, &plant_params, env, saturate, sc.initial())?;
        plant.set_bounds(sc.water.surface, sc.water.seabed_depth_m);

        let (n_sub, dt) = sc.plant_steps();
        let tc = dt * n_sub as f64;
        let duration = opts.duration_s.unwrap_or(sc.duration_s);
        let n_ctrl = if opts.open_ended {
            None
        } else {
            let n_ctrl = (duration / tc).round() as u64;
            if n_ctrl as f64 > MAX_CONTROL_TICKS {
                return Err(anyhow!(
                    "{duration} s is {n_ctrl} control ticks: at most {MAX_CONTROL_TICKS:.0e} in one run"
                ));
            }
            Some(n_ctrl)
        };
        let log = match n_ctrl {
            Some(n) if opts.record => Vec::with_capacity(n as usize + 1),
            _ => Vec::new(),
        };
        let s = Summary {
            scenario: sc.name.clone(),
            plane: sc.plane.as_str().into(),
            controller: sc.controller.as_str().into(),
            reference: sc.reference.kind().into(),
            saturate,
            duration_s: duration,
            stop_reason: "completed".into(),
            ..Summary::default()
        };
        let m = Metrics {
            all: Rms::default(),
            tail: Rms::default(),
            last80: Rms::default(),
            est: Rms::default(),
            n_sat: 0,
            t_tail: 0.8 * duration,
            t_80: 0.2 * duration,
            settle_s: sc.expect.map_or(10.0, |e| e.settle_s),
            first_half_max: 0.0,
            first_half_depth_max: 0.0,
            tail_min: f64::INFINITY,
            tail_depth_min: f64::INFINITY,
            heading_judged: sc.plane != Plane::Xz,
            depth_judged: sc.plane != Plane::Xy,
            turns: Turns::default(),
            endpoint_nees: DiagonalNees::default(),
            ident_room: sc.identification.as_ref().map(|spec| {
                let eta = sc.initial().eta;
                IdentRoom {
                    start_m: [eta[0], eta[1], eta[2]],
                    radius_m: spec.radius_m,
                    depth_band_m: spec.depth_band_m,
                    max_horizontal_m: 0.0,
                    max_depth_off_m: 0.0,
                }
            }),
        };
        Ok(Self {
            nav,
            endpoint,
            plant,
            reference: *sc.reference(),
            water: sc.water.clone(),
            current_m_s: env.current_m_s,
            plane: sc.plane,
            axes: sc.plane.axes(),
            expect: sc.expect,
            lim_fwd,
            lim_rev,
            n_sub,
            dt,
            tc,
            n_ctrl,
            record: opts.record,
            k: 0,
            held_cmd: [0.0; 3],
            done: false,
            wall,
            s,
            m,
            last: Sample::default(),
            log,
        })
    }

    /// The control period (s).
    pub fn period_s(&self) -> f64 {
        self.tc
    }

    /// Simulated time of the next control tick (s).
    pub fn t_s(&self) -> f64 {
        self.k as f64 * self.tc
    }

    /// The latest control tick: the true state, what the controller was given, the errors.
    pub fn sample(&self) -> &Sample {
        &self.last
    }

    /// The controller endpoint (the topside sends its ground stations' commands through it).
    pub fn endpoint(&self) -> &E {
        &self.endpoint
    }

    /// The controller endpoint, mutable.
    pub fn endpoint_mut(&mut self) -> &mut E {
        &mut self.endpoint
    }

    /// The run stopped (completed, diverged or not finite): [`step`](Self::step) does nothing.
    pub fn stopped(&self) -> bool {
        self.done
    }

    /// Why the run stopped (`completed` while it runs).
    pub fn stop_reason(&self) -> &str {
        &self.s.stop_reason
    }

    /// One control tick at `t = k * control_period_s` (see the module doc), then, unless the
    /// run stops here, the plant through the period with the endpoint's thrust held. Returns
    /// whether the run goes on.
    pub fn step(&mut self) -> Result<bool> {
        Ok(match self.control()? {
            Some(applied_n) => {
                self.advance(applied_n);
                true
            }
            None => false,
        })
    }

    /// The plant through the period with `applied_n` held, the navigation stage seeing each
    /// of its steps.
    pub(super) fn advance(&mut self, applied_n: [f64; 3]) {
        for i in 0..self.n_sub {
            self.plant.step(applied_n, self.dt);
            self.after_plant_step(i);
        }
        self.end_period();
    }

    /// Plant steps per control period and their length (s).
    pub(super) fn plant_steps(&self) -> (usize, f64) {
        (self.n_sub, self.dt)
    }

    /// The plant, when it is the 6-DOF one.
    pub(super) fn six_dof_mut(&mut self) -> Option<&mut SixDof> {
        self.plant
            .as_any_mut()
            .and_then(|p| p.downcast_mut::<SixDof>())
    }

    /// The control tick of [`step`](Self::step): the thrust the plant gets over the period,
    /// or `None` when the run stops here.
    pub(super) fn control(&mut self) -> Result<Option<[f64; 3]>> {
        if self.done {
            return Ok(None);
        }
        let k = self.k;
        let t = k as f64 * self.tc;
        let truth = self.plant.state();
        self.nav.observed_as(&truth);
        let nav_state = self.nav.estimate(t, self.held_cmd);
        if k == 0 {
            self.endpoint.start(&nav_state)?;
        }
        let t_ref = (t - self.endpoint.reference_start_s()).max(0.0);
        let r: RefSample = self.reference.sample(t_ref as f32);
        self.endpoint.forward(&self.nav.for_vehicle(t))?;
        let out = self.endpoint.step(t, &nav_state, &r)?;
        let endpoint_std = out.estimate.map(|(_, std)| std);
        let (nav_state, nav_std) = match out.estimate {
            Some((e, std)) => (e, Some(std)),
            None => (nav_state, self.nav.position_std_m()),
        };

        // Metrics on the true state.
        let axes = self.axes;
        let ref_pos = r.pos_m.map(f64::from);
        let ref_vel = r.vel_m_s.map(f64::from);
        let nav_pos = [nav_state.x_m, nav_state.y_m, nav_state.z_m].map(f64::from);
        let vel = body_to_inertial(&truth.eta, [truth.nu[0], truth.nu[1], truth.nu[2]]);
        let (mut pe, mut ve, mut ee) = ([0.0; 3], [0.0; 3], [0.0; 3]);
        for i in 0..3 {
            if axes[i] {
                pe[i] = truth.eta[i] - ref_pos[i];
                ve[i] = vel[i] - ref_vel[i];
                ee[i] = nav_pos[i] - truth.eta[i];
            }
        }
        let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let pen = norm(pe);
        if let Some(std) = endpoint_std {
            self.m.endpoint_nees.add(ee, std, axes);
        }
        let angle_err = f64::from(match self.plane {
            Plane::Xz => out.errors.pitch_rad,
            _ => out.errors.yaw_rad,
        });
        let forces = |f: BodyForces| [f.surge_n, f.yaw_n_m, f.heave_n].map(f64::from);
        let requested = forces(out.requested);
        let cmd = out.thrust_cmd_n.map(f64::from);
        let exceeds = cmd
            .iter()
            .any(|&f| f > self.lim_fwd + 1e-6 || f < -self.lim_rev - 1e-6);
        let saturated = out.saturated || exceeds;
        let sample = Sample {
            t_s: t,
            state: truth,
            nav_pos_m: nav_pos,
            nav_pos_std_m: nav_std,
            ref_pos_m: ref_pos,
            ref_vel_m_s: ref_vel,
            pos_err_m: pe,
            pos_err_norm_m: pen,
            vel_err_m_s: ve,
            angle_err_rad: angle_err,
            law_errors: out.errors,
            requested,
            achieved: forces(out.achieved),
            thrust_cmd_n: cmd,
            thrust_n: self.plant.thrust_n(),
            pulse_us: out.pulse_us,
            saturated,
        };
        self.last = sample;
        if self.record {
            self.log.push(sample);
        }

        let (s, m) = (&mut self.s, &mut self.m);
        if !truth.is_finite() || !out.requested.is_finite() || !pen.is_finite() {
            s.nan_detected = true;
            s.stop_reason = format!("non-finite state or force at t = {t:.3} s");
            s.rule = Some(Rule {
                name: "non_finite".into(),
                figure: t,
                threshold: 0.0,
                unit: "s",
                text: s.stop_reason.clone(),
            });
            self.done = true;
            return Ok(None);
        }
        m.all.add(pen);
        if t >= m.t_tail {
            m.tail.add(pen);
        }
        if t >= m.t_80 {
            m.last80.add(pen);
        }
        s.max_position_error_m = s.max_position_error_m.max(pen);
        if t >= 10.0 {
            s.max_position_error_after_10s_m = s.max_position_error_after_10s_m.max(pen);
            s.max_angle_error_after_10s_rad = s.max_angle_error_after_10s_rad.max(angle_err.abs());
            m.est.add(norm(ee));
        }
        for i in 0..3 {
            s.max_abs_requested_force[i] = s.max_abs_requested_force[i].max(requested[i].abs());
            s.max_abs_thruster_force_n = s.max_abs_thruster_force_n.max(cmd[i].abs());
        }
        if saturated {
            m.n_sat += 1;
        }
        s.control_steps += 1;
        s.simulated_s = t;

        // Control lost: the error and the depth error of the first half and of the end;
        // the turns of the vehicle against the path's.
        let depth_err = (truth.eta[2] - ref_pos[2]).abs();
        if t < 0.5 * s.duration_s {
            m.first_half_max = m.first_half_max.max(pen);
            m.first_half_depth_max = m.first_half_depth_max.max(depth_err);
        }
        if t >= m.t_tail {
            m.tail_min = m.tail_min.min(pen);
            m.tail_depth_min = m.tail_depth_min.min(depth_err);
        }
        if t >= m.settle_s {
            s.max_position_error_after_settle_m = s.max_position_error_after_settle_m.max(pen);
        }
        if let Some(room) = m.ident_room.as_mut() {
            room.update(&truth.eta);
        }
        if m.heading_judged {
            let path = (ref_vel[0].hypot(ref_vel[1]) > 1e-3).then(|| ref_vel[1].atan2(ref_vel[0]));
            m.turns.update(truth.eta[5], path);
            s.max_turns_off_path = s.max_turns_off_path.max(m.turns.off_path_turns());
        }

        if let Some(rule) = divergence(&truth, &cmd, t) {
            s.diverged = true;
            s.stop_reason = rule.text.clone();
            s.rule = Some(rule);
            self.done = true;
            return Ok(None);
        }
        if Some(k) == self.n_ctrl {
            self.done = true;
            return Ok(None);
        }

        if self.water.current_varies() {
            self.plant
                .set_current(self.water.current_at(self.current_m_s, t, truth.eta[2]));
        }
        // Zero-order hold over the plant steps of this period.
        self.held_cmd = out.applied_n;
        Ok(Some(out.applied_n))
    }

    /// After the plant's step `i` (0-based) of this period: the navigation stage sees it.
    pub(super) fn after_plant_step(&mut self, i: usize) {
        let t = self.k as f64 * self.tc;
        self.s.sim_steps += 1;
        self.nav
            .observe_raw(t + (i + 1) as f64 * self.dt, &self.plant.raw_state());
    }

    /// The end of the period: the first boundary met, the next tick.
    pub(super) fn end_period(&mut self) {
        let t = self.k as f64 * self.tc;
        if self.s.boundary_contact.is_none() {
            let t_end = t + self.tc;
            self.s.boundary_contact = self.plant.contact().map(|b| match b {
                sim_world::plant::Boundary::Surface => {
                    format!("hit the surface at t = {t_end:.3} s")
                }
                sim_world::plant::Boundary::Seabed => {
                    format!("hit the seabed at t = {t_end:.3} s")
                }
            });
        }
        self.k += 1;
    }

    /// The summary of the run so far (the end-of-run judgements included), with the log and
    /// the USBL fixes when recorded, and the endpoint back (for its own report).
    pub fn finish(self) -> (RunOutput, E) {
        let Self {
            nav,
            endpoint,
            expect,
            record,
            wall,
            mut s,
            m,
            last,
            log,
            ..
        } = self;
        s.rms_position_error_m = m.all.value();
        s.rms_position_error_tail_m = m.tail.value();
        s.rms_position_error_last80_m = m.last80.value();
        s.rms_estimation_error_m = m.est.value();
        s.navigation = nav.report();
        // An estimator in the endpoint (the firmware's, on the vehicle or the topside): its
        // figures, as the host's estimator stage gives its own.
        if s.navigation.nees_in_bounds_fraction.is_none() {
            s.navigation.nees_in_bounds_fraction = m.endpoint_nees.fraction();
        }
        if let Some(n) = endpoint.usbl_fixes_rejected() {
            s.navigation.usbl_fixes_rejected = n;
        }
        // An outlier counts when the estimator received it: the stage draws each fix at its
        // ping and delivers it `latency_s` later, so one drawn in the last latency window of
        // the run never arrives. The fix records are kept on delivery.
        let fixes = nav.usbl_fixes();
        if !fixes.is_empty() {
            s.navigation.usbl_outliers_injected = fixes.iter().filter(|f| f.outlier).count() as u64;
        }
        s.final_position_error_m = last.pos_err_norm_m;
        s.final_position_error_xyz_m = last.pos_err_m;
        s.final_angle_error_rad = last.angle_err_rad;
        s.saturated_fraction = ratio(m.n_sat, s.control_steps);
        if s.diverged || s.nan_detected {
            // A run that stopped early has no meaningful tail: report it as infinite error.
            if !s.rms_position_error_tail_m.is_finite() || m.tail.n == 0 {
                s.rms_position_error_tail_m = f64::INFINITY;
            }
            if m.last80.n == 0 {
                s.rms_position_error_last80_m = f64::INFINITY;
            }
        }
        if let Some(room) = m.ident_room.filter(|_| !s.diverged && !s.nan_detected) {
            // The manoeuvre flies around its start, not along the reference: judged by its room.
            s.rule = room.left();
            s.lost_control = s.rule.as_ref().map(|r| r.text.clone());
            s.diverged = s.rule.is_some();
        } else if !s.diverged && !s.nan_detected && !meets_tracking_figures(expect.as_ref(), &s) {
            let end = EndFigures {
                depth_judged: m.depth_judged,
                first_half_max_m: m.first_half_max,
                first_half_depth_max_m: m.first_half_depth_max,
                tail_min_m: m.tail_min,
                tail_depth_min_m: m.tail_depth_min,
                settle_s: m.settle_s,
                depth_off_end_m: last.state.eta[2] - last.ref_pos_m[2],
            };
            s.rule = lost_control(&s, &end);
            s.lost_control = s.rule.as_ref().map(|r| r.text.clone());
            s.diverged = s.rule.is_some();
        }
        s.targets = expect.map(|e| judge(&e, &s));
        if s.rule.is_none() {
            s.rule = expect.and_then(|e| missed_rule(&e, &s));
        }
        s.verdict = verdict(&s);
        let fs = last.state;
        s.final_state = fs.eta.iter().chain(fs.nu.iter()).copied().collect();
        s.wall_time_s = wall.elapsed().as_secs_f64();
        let usbl_fixes = if record { fixes } else { Vec::new() };
        (
            RunOutput {
                summary: s,
                log,
                usbl_fixes,
            },
            endpoint,
        )
    }
}

/// Run a scenario in closed loop to its end with `nav` as the navigation stage and
/// `endpoint` as the controller.
pub fn run_closed_loop(
    sc: &RunSetup,
    opts: &RunOptions,
    nav: &mut dyn Navigation,
    endpoint: &mut dyn ControllerEndpoint,
) -> Result<RunOutput> {
    let mut run = ClosedLoop::new(sc, opts, nav, endpoint)?;
    while run.step()? {}
    Ok(run.finish().0)
}
