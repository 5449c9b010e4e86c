//! The vehicle's health in the state machine: each check's failsafe action (SURFACE or
//! disarm), the SURFACE mode's step, the depth limit's cap on every step's vertical command
//! and its refusal of deeper targets, and the health parameters' command.

use super::{Autopilot, StepOutput, SurfacePhase};
use crate::health::{
    DepthLimit, FailsafeAction, HealthParams, HealthReport, HealthSample, SurfaceEnd,
    SURFACE_DONE_DEPTH_M,
};
use crate::protocol::{fault, Mode, NackReason};
use controller_core::controller::ControlMode;
use controller_core::math::{cos, sin_cos};
use controller_core::reference::{Bounds, Reference};
use controller_core::state::{BodyForces, NavState};

/// SURFACE's ascent: this fraction of the vertical thruster's largest upward force.
pub const SURFACE_ASCENT_FRACTION: f32 = 0.6;

/// SURFACE's ascent rate limit, m/s: above it the upward force is cut back, so that the
/// vehicle does not broach at speed.
pub const SURFACE_ASCENT_MAX_M_S: f32 = 0.5;

/// Depth rate (positive down) of a navigation state: the body's surge and heave speeds
/// turned by the pitch.
fn descent_rate_m_s(nav: &NavState) -> f32 {
    let (sp, cp) = sin_cos(nav.pitch_rad);
    -sp * nav.u_m_s + cp * cos(nav.roll_rad) * nav.w_m_s
}

/// Faults that make a step neutral whatever the mode: no vertical command to cap.
const NEUTRAL_FAULTS: u16 = fault::HEARTBEAT_LOST | fault::MANUAL_STALE | fault::NAV_STALE;

impl Autopilot {
    /// The latest health check.
    pub fn health(&self) -> &HealthReport {
        self.health.latest()
    }

    /// The health parameters in force.
    pub fn health_params(&self) -> &HealthParams {
        self.health.params()
    }

    /// Run the health checks at `now_us` on `sample` (its depth, when it has none, is the
    /// navigation's) and take the action of an event that starts: SURFACE when armed and not
    /// already surfacing, or disarm. Called by the App before each control step.
    pub fn health_check(&mut self, now_us: u64, sample: &HealthSample) -> HealthReport {
        let mut s = *sample;
        if s.depth_m.is_none() && self.nav_fresh(now_us) {
            s.depth_m = Some(self.nav_state().z_m);
        }
        let report = self.health.update(now_us, &s);
        match report.action {
            FailsafeAction::Surface if self.armed && self.mode != Mode::Surface => {
                self.enter_surface(now_us);
            }
            FailsafeAction::Disarm if self.armed => self.disarm(),
            _ => {}
        }
        report
    }

    /// Switch to SURFACE now (it needs no navigation and no reference).
    pub(super) fn enter_surface(&mut self, now_us: u64) {
        self.abort_swing();
        self.controller.reset();
        self.engaged_us = now_us;
        self.surface = SurfacePhase::Ascent;
        self.mode = Mode::Surface;
    }

    /// New health parameters: disarmed, any (checked); armed, only a depth limit switched
    /// on or made shallower with everything else unchanged (tightening a failsafe mid-dive
    /// is safe, relaxing one is not).
    pub(super) fn set_health(&mut self, p: &HealthParams) -> Result<(), NackReason> {
        p.validate()?;
        if self.armed {
            let old = *self.health.params();
            let only_limit = HealthParams {
                depth_limit_m: old.depth_limit_m,
                ..*p
            } == old;
            let tighter = p.depth_limit_m > 0.0
                && (old.depth_limit_m == 0.0 || p.depth_limit_m <= old.depth_limit_m);
            if !(only_limit && tighter) {
                return Err(NackReason::Armed);
            }
        }
        self.health.set_params(*p)
    }

    /// Refuse a reference that starts or turns below the depth limit (the same points
    /// [`Reference::check_bounds`] checks against the vehicle's bounds).
    pub(super) fn check_reference_depth(&self, r: &Reference) -> Result<(), NackReason> {
        let Some(lim) = self.health.depth_limit() else {
            return Ok(());
        };
        let b = Bounds {
            max_depth_m: lim.limit_m().min(Bounds::VEHICLE.max_depth_m),
            ..Bounds::VEHICLE
        };
        r.check_bounds(&b).map_err(|_| NackReason::DepthLimit)
    }

    /// Refuse a waypoint below the depth limit.
    pub(super) fn check_target_depth(&self, depth_m: f32) -> Result<(), NackReason> {
        match self.health.depth_limit() {
            Some(lim) if lim.refuses(depth_m) => Err(NackReason::DepthLimit),
            _ => Ok(()),
        }
    }

    /// Arming is refused while a leak or a critical battery holds (ArduSub's pre-arm
    /// checks).
    pub(super) fn check_health_for_arming(&self) -> Result<(), NackReason> {
        if self.health.latest().faults & (fault::LEAK | fault::BATTERY_CRITICAL) != 0 {
            Err(NackReason::Health)
        } else {
            Ok(())
        }
    }

    /// The SURFACE mode's step: horizontal thrusters neutral; the vertical one up at
    /// [`SURFACE_ASCENT_FRACTION`] (less above [`SURFACE_ASCENT_MAX_M_S`]) until the depth
    /// is [`SURFACE_DONE_DEPTH_M`], then the depth law holds that depth or the vehicle
    /// disarms (`SURFACE_END`). Without fresh navigation it keeps going up (the top is not
    /// known).
    pub(super) fn surface_step(&mut self, nav_fresh: bool, dt_s: f32, faults: u16) -> StepOutput {
        let nav = self.nav_state();
        if nav_fresh && nav.z_m <= SURFACE_DONE_DEPTH_M && self.surface == SurfacePhase::Ascent {
            match self.health.params().surface_end {
                SurfaceEnd::Disarm => {
                    self.disarm();
                    return self.neutral(faults);
                }
                SurfaceEnd::Hold => {
                    self.controller.reset();
                    self.surface = SurfacePhase::Holding;
                }
            }
        }
        let heave_n = match self.surface {
            SurfacePhase::Holding if nav_fresh => {
                let hold = Reference::Hold {
                    pos_m: [nav.x_m, nav.y_m, SURFACE_DONE_DEPTH_M],
                };
                let law =
                    self.controller
                        .step(ControlMode::Tracking3d, &nav, &hold.sample(0.0), dt_s);
                law.requested.heave_n
            }
            _ => {
                let up_n = self.controller.limits().max_reverse_n * SURFACE_ASCENT_FRACTION;
                let rising_m_s = if nav_fresh {
                    -descent_rate_m_s(&nav)
                } else {
                    0.0
                };
                // Linearly less from the rate limit to none at twice it.
                let over = ((rising_m_s - SURFACE_ASCENT_MAX_M_S) / SURFACE_ASCENT_MAX_M_S)
                    .clamp(0.0, 1.0);
                -up_n * (1.0 - over)
            }
        };
        let requested = BodyForces {
            surge_n: 0.0,
            yaw_n_m: 0.0,
            heave_n,
        };
        self.forces_output(requested, Default::default(), faults)
    }

    /// Cap the vertical command of a step that makes thrust by the depth limit's envelope
    /// (every mode, the pilot's included); the other axes stay. Navigation must be fresh to
    /// know the depth; without it the step is as computed.
    pub(super) fn limit_depth(&self, out: StepOutput, now_us: u64) -> StepOutput {
        let Some(lim) = self.health.depth_limit() else {
            return out;
        };
        if !self.armed || self.mode == Mode::Idle || out.faults & NEUTRAL_FAULTS != 0 {
            return out;
        }
        if !self.nav_fresh(now_us) {
            return out;
        }
        let nav = self.nav_state();
        let max_down_n = self.controller.limits().max_forward_n;
        let heave_n = out.allocation.achieved.heave_n;
        let capped = cap_heave(&lim, heave_n, &nav, max_down_n);
        if capped >= heave_n {
            return out;
        }
        let requested = BodyForces {
            heave_n: capped,
            ..out.allocation.achieved
        };
        let mut limited = self.forces_output(requested, out.errors, out.faults);
        limited.requested = BodyForces {
            heave_n: capped.min(out.requested.heave_n),
            ..out.requested
        };
        limited.law_ran = out.law_ran;
        limited
    }
}

/// `heave_n` capped by `lim`'s envelope at the navigation's depth and depth rate.
fn cap_heave(lim: &DepthLimit, heave_n: f32, nav: &NavState, max_down_n: f32) -> f32 {
    lim.cap(heave_n, nav.z_m, descent_rate_m_s(nav), max_down_n)
}
