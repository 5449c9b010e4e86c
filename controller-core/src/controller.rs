//! One entry point for every law: settings apart from state, validated once.
//!
//! `Controller::step(mode, nav, reference, dt)` runs the chosen law, allocates the thrust
//! with the saturation priority of [`crate::alloc`], tells the law what was achieved
//! (anti-windup), and returns everything a caller logs or sends. It has no error path: the
//! vehicle and gains were validated when they were set, and a non-finite force is mapped to
//! zero thrust by the allocation.

use crate::alloc::{allocate, Allocation, PwmMap, ThrusterLimits};
use crate::error::Error;
use crate::law::gain_bounds;
use crate::law::paper_xy::{self, PaperXyGains};
use crate::law::paper_xz::{self, PaperXzGains};
use crate::law::pilot::{self, PilotHold, Sticks};
use crate::law::tracking::{self, TrackingGains, TrackingState};
use crate::law::LawOutput;
use crate::nav::predict::DelayCompensator;
use crate::params::Vehicle;
use crate::reference::RefSample;
use crate::state::{BodyForces, NavState, TrackingErrors};
use serde::{Deserialize, Serialize};

/// Which law runs, in which plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ControlMode {
    /// The paper's vertical-plane law (surge force and heave force).
    PaperXz,
    /// The paper's horizontal-plane law (surge force and yaw moment).
    PaperXy,
    /// Tracking law, vertical plane.
    TrackingXz,
    /// Tracking law, horizontal plane.
    TrackingXy,
    /// Tracking law in 3-D: horizontal law plus depth.
    Tracking3d,
}

/// All gains, each set validated as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gains {
    /// Paper XZ law.
    pub paper_xz: PaperXzGains,
    /// Paper XY law.
    pub paper_xy: PaperXyGains,
    /// Tracking laws.
    pub tracking: TrackingGains,
}

/// Largest value of any gain accepted: 100x the largest default (10). The gains of the
/// linear loops are held to the narrower ranges of [`gain_bounds`], derived from the laws'
/// discrete-time stability at the control period.
pub const MAX_GAIN: f32 = 1.0e3;

impl Gains {
    /// The default gains with the tracking laws' fitted to `vehicle`
    /// ([`TrackingGains::for_vehicle`]; the Observer's are the defaults exactly).
    pub fn for_vehicle(vehicle: &Vehicle) -> Self {
        Self {
            tracking: TrackingGains::for_vehicle(vehicle),
            ..Self::default()
        }
    }

    /// Validate every set, every gain at most [`MAX_GAIN`], and the gains of the linear loops
    /// within the ranges of [`gain_bounds`] (the refusal names the range).
    pub fn validate(&self) -> Result<(), Error> {
        self.paper_xz.validate()?;
        self.paper_xy.validate()?;
        self.tracking.validate()?;
        let (a, b, t) = (&self.paper_xz, &self.paper_xy, &self.tracking);
        let all = [
            (
                "paper_xz",
                [a.k, a.c1w, a.c2w, a.c1q, a.c2q, a.cq, a.c1, a.c2],
            ),
            (
                "paper_xy",
                [b.k, b.c1u, b.c2u, b.c1r, b.c2r, b.cr, b.c3, b.c4],
            ),
            (
                "tracking",
                [
                    t.hand_m, t.xy_kp, t.xy_kd, t.xy_ki, t.xz_kp, t.xz_kd, t.xz_ki, t.pitch_kp,
                ],
            ),
            (
                "tracking",
                [
                    t.pitch_kd,
                    t.pitch_max_rad,
                    t.depth_kp,
                    t.depth_kd,
                    t.depth_ki,
                    t.yaw_kp,
                    t.yaw_kd,
                    t.error_limit_m,
                ],
            ),
            (
                "tracking",
                [
                    t.integral_limit_m_s2,
                    t.current_observer_rad_s,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ],
            ),
        ];
        for (name, set) in all {
            // NaN is not finite: refused too (`validate` above refuses it first).
            if set.iter().any(|v| !v.is_finite() || v.abs() > MAX_GAIN) {
                return Err(Error::OutOfRange(name));
            }
        }
        gain_bounds::check_tracking(t)?;
        gain_bounds::check_paper(a, b)
    }
}

/// Everything one control step produces.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ControlOutput {
    /// Forces the law asked for.
    pub requested: BodyForces,
    /// Thrusts after allocation and saturation, and the forces they make.
    pub allocation: Allocation,
    /// ESC pulse widths for `[F1x, F2x, F3z]`.
    pub pulse_us: [f32; 3],
    /// Tracking errors.
    pub errors: TrackingErrors,
}

/// The controller: a validated vehicle model and gains, plus the tracking laws' state.
#[derive(Debug, Clone, PartialEq)]
pub struct Controller {
    vehicle: Vehicle,
    gains: Gains,
    limits: ThrusterLimits,
    pwm: PwmMap,
    state: TrackingState,
    pilot: PilotHold,
    delay: DelayCompensator,
}

impl Controller {
    /// Build from a validated vehicle and gains (checked here).
    pub fn new(vehicle: Vehicle, gains: Gains) -> Result<Self, Error> {
        gains.validate()?;
        Ok(Self {
            vehicle,
            gains,
            limits: ThrusterLimits::of(&vehicle),
            pwm: PwmMap::for_vehicle(&vehicle),
            state: TrackingState::default(),
            pilot: PilotHold::default(),
            delay: DelayCompensator::new(),
        })
    }

    /// The vehicle model.
    pub fn vehicle(&self) -> &Vehicle {
        &self.vehicle
    }

    /// The gains in force.
    pub fn gains(&self) -> &Gains {
        &self.gains
    }

    /// The thrust <-> pulse map.
    pub fn pwm_map(&self) -> &PwmMap {
        &self.pwm
    }

    /// The tracking laws' state (integrators, current estimate), for logs and tests.
    pub fn tracking_state(&self) -> &TrackingState {
        &self.state
    }

    /// Thruster limits.
    pub fn limits(&self) -> &ThrusterLimits {
        &self.limits
    }

    /// Replace the vehicle model (its limits and pulse curve with it) and clear the laws'
    /// state. Tracking gains that are the ones derived from the model in force
    /// ([`TrackingGains::for_vehicle`]) follow the new model; gains an operator set stay.
    pub fn set_vehicle(&mut self, vehicle: Vehicle) {
        if self.gains.tracking == TrackingGains::for_vehicle(&self.vehicle) {
            self.gains.tracking = TrackingGains::for_vehicle(&vehicle);
        }
        self.limits = ThrusterLimits::of(&vehicle);
        self.pwm = PwmMap::for_vehicle(&vehicle);
        self.vehicle = vehicle;
        self.reset();
    }

    /// Replace the gains; on error nothing changes.
    pub fn set_gains(&mut self, gains: Gains) -> Result<(), Error> {
        gains.validate()?;
        self.gains = gains;
        Ok(())
    }

    /// Clear integrators and filters (on arming or a mode change).
    pub fn reset(&mut self) {
        self.state = TrackingState::default();
        self.pilot = PilotHold::default();
        self.delay.clear();
    }

    /// Tell the controller how late its navigation states are (s, 0 to
    /// [`crate::nav::predict::MAX_DELAY_S`]): [`step`](Self::step) then predicts the state
    /// through the model over the delay with the forces it commanded
    /// ([`crate::nav::predict`]). A non-finite or out-of-range delay is refused and nothing
    /// changes.
    pub fn set_measurement_delay_s(&mut self, delay_s: f32) -> Result<(), Error> {
        self.delay.set_delay_s(delay_s)
    }

    /// Run one control step of `dt_s` seconds.
    pub fn step(
        &mut self,
        mode: ControlMode,
        nav: &NavState,
        reference: &RefSample,
        dt_s: f32,
    ) -> ControlOutput {
        let v = &self.vehicle;
        let g = &self.gains;
        let predicted = self.delay.predict(v, nav, dt_s);
        let nav = &predicted;
        let out: LawOutput = match mode {
            ControlMode::PaperXz => paper_xz::step(v, &g.paper_xz, &nav.xz(), reference),
            ControlMode::PaperXy => paper_xy::step(v, &g.paper_xy, &nav.xy(), reference),
            ControlMode::TrackingXz => {
                tracking::step_xz(v, &g.tracking, &mut self.state, nav, reference, dt_s)
            }
            ControlMode::TrackingXy => {
                tracking::step_xy(v, &g.tracking, &mut self.state, nav, reference, dt_s)
            }
            ControlMode::Tracking3d => {
                tracking::step_3d(v, &g.tracking, &mut self.state, nav, reference, dt_s)
            }
        };
        self.finish(out)
    }

    /// One step of pilot-assisted flying ([`pilot`]): the sticks' forces, the heading held
    /// while the yaw stick is centred and, with `hold_depth` (ALT_HOLD), the depth held while
    /// the heave stick is centred. The targets are those at release; [`reset`](Self::reset)
    /// forgets them.
    pub fn pilot_step(
        &mut self,
        nav: &NavState,
        sticks: &Sticks,
        hold_depth: bool,
        dt_s: f32,
    ) -> ControlOutput {
        let (forces, errors) = pilot::step(
            &self.vehicle,
            &self.gains.tracking,
            &mut self.state,
            &mut self.pilot,
            &self.limits,
            nav,
            sticks,
            hold_depth,
            dt_s,
        );
        self.finish(LawOutput { forces, errors })
    }

    /// Allocate a law's forces, tell the law what was achieved, map to pulses.
    fn finish(&mut self, out: LawOutput) -> ControlOutput {
        let allocation = allocate(&out.forces, &self.limits);
        self.state.on_allocation(&out.forces, &allocation.achieved);
        self.delay.record(&allocation.achieved);
        let pulse_us = self.pwm.pulses_us(allocation.thrust_n);
        ControlOutput {
            requested: out.forces,
            allocation,
            pulse_us,
            errors: out.errors,
        }
    }
}
