//! Prediction of a late navigation state through the model: a measurement that is
//! `delay_s` old describes where the vehicle was; the laws need where it is.
//!
//! The horizontal state is integrated forward over the delay with the planar XY model
//! ([`crate::model::xy`], the equations the tracking law inverts), driven by the surge force
//! and yaw moment the controller really commanded over that time (the last
//! [`HISTORY_STEPS`] steps); depth moves with the heave velocity, pitch and roll are kept.
//! Euler steps of the control period.

use crate::math::wrap_angle;
use crate::model::{axpy, xy};
use crate::params::Vehicle;
use crate::state::{BodyForces, NavState};
use heapless::Deque;

/// Control steps of commanded forces kept (0.64 s at 100 Hz).
pub const HISTORY_STEPS: usize = 64;

/// Longest delay accepted (s).
pub const MAX_DELAY_S: f32 = 0.5;

/// The commanded forces of the last steps, and the delay to bridge.
#[derive(Debug, Clone)]
pub struct DelayCompensator {
    delay_s: f32,
    /// `[tau_1, tau_2]` of each past step, oldest first.
    forces: Deque<[f32; 2], HISTORY_STEPS>,
}

impl PartialEq for DelayCompensator {
    fn eq(&self, other: &Self) -> bool {
        self.delay_s == other.delay_s && self.forces.iter().eq(other.forces.iter())
    }
}

impl Default for DelayCompensator {
    fn default() -> Self {
        Self::new()
    }
}

impl DelayCompensator {
    /// No delay.
    pub const fn new() -> Self {
        Self {
            delay_s: 0.0,
            forces: Deque::new(),
        }
    }

    /// The delay bridged (s).
    pub fn delay_s(&self) -> f32 {
        self.delay_s
    }

    /// Set the measurement delay; a non-finite, negative or too long one is refused and
    /// nothing changes.
    pub fn set_delay_s(&mut self, delay_s: f32) -> Result<(), crate::error::Error> {
        if !delay_s.is_finite() {
            return Err(crate::error::Error::NonFinite("measurement_delay_s"));
        }
        if !(0.0..=MAX_DELAY_S).contains(&delay_s) {
            return Err(crate::error::Error::OutOfRange("measurement_delay_s"));
        }
        self.delay_s = delay_s;
        Ok(())
    }

    /// Forget the forces (on a reset: the vehicle was not driven by the laws).
    pub fn clear(&mut self) {
        self.forces.clear();
    }

    /// Remember the forces commanded for the step that starts now.
    pub fn record(&mut self, forces: &BodyForces) {
        let f = [forces.surge_n, forces.yaw_n_m];
        let f = if f[0].is_finite() && f[1].is_finite() {
            f
        } else {
            [0.0, 0.0]
        };
        if self.forces.is_full() {
            self.forces.pop_front();
        }
        // Cannot fail: there is room now.
        let _ = self.forces.push_back(f);
    }

    /// The state now, from `nav` measured `delay_s` ago, stepping the model at `dt_s` (the
    /// control period) with the forces of the last `round(delay_s / dt_s)` steps (fewer if
    /// the history is shorter). With no delay, or a non-finite state, `nav` unchanged.
    pub fn predict(&self, v: &Vehicle, nav: &NavState, dt_s: f32) -> NavState {
        if self.delay_s <= 0.0 || dt_s.is_nan() || dt_s <= 0.0 {
            return *nav;
        }
        let steps = (self.delay_s / dt_s + 0.5) as usize;
        let steps = steps.min(self.forces.len());
        if steps == 0 {
            return *nav;
        }
        let skip = self.forces.len().saturating_sub(steps);
        let mut st = nav.xy();
        for &[surge_n, yaw_n_m] in self.forces.iter().skip(skip) {
            let f = BodyForces {
                surge_n,
                yaw_n_m,
                heave_n: 0.0,
            };
            st = axpy(&st, dt_s, &xy::derivative(v, &st, &f));
        }
        let out = NavState {
            x_m: st.x_m,
            y_m: st.y_m,
            z_m: nav.z_m + nav.w_m_s * self.delay_s,
            yaw_rad: wrap_angle(st.yaw_rad),
            u_m_s: st.u_m_s,
            v_m_s: st.v_m_s,
            r_rad_s: st.r_rad_s,
            ..*nav
        };
        if out.is_finite() {
            out
        } else {
            *nav
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::VehicleParams;

    fn observer() -> Vehicle {
        VehicleParams::OBSERVER.validate().unwrap()
    }

    #[test]
    fn bad_delays_are_refused_and_change_nothing() {
        let mut d = DelayCompensator::new();
        d.set_delay_s(0.2).unwrap();
        for bad in [f32::NAN, f32::INFINITY, -0.01, MAX_DELAY_S + 0.01] {
            assert!(d.set_delay_s(bad).is_err(), "{bad}");
            assert_eq!(d.delay_s(), 0.2);
        }
    }

    #[test]
    fn a_steady_straight_run_is_carried_forward_by_its_speed() {
        // Surge force balancing the drag at 0.3 m/s: the speed stays, the position moves
        // 0.3 m/s x 0.3 s along the heading.
        let v = observer();
        let p = v.params();
        let u = 0.3f32;
        let drag = (p.x_u + p.x_uu * u) * u;
        let mut d = DelayCompensator::new();
        d.set_delay_s(0.3).unwrap();
        for _ in 0..40 {
            d.record(&BodyForces {
                surge_n: drag,
                yaw_n_m: 0.0,
                heave_n: 0.0,
            });
        }
        let yaw = 0.5f32;
        let nav = NavState {
            x_m: 1.0,
            y_m: 2.0,
            yaw_rad: yaw,
            u_m_s: u,
            ..NavState::default()
        };
        let out = d.predict(&v, &nav, 0.01);
        let (s, c) = (yaw.sin(), yaw.cos());
        assert!((out.x_m - (1.0 + 0.09 * c)).abs() < 1e-4, "{out:?}");
        assert!((out.y_m - (2.0 + 0.09 * s)).abs() < 1e-4, "{out:?}");
        assert!((out.u_m_s - u).abs() < 1e-5);
        assert_eq!(out.yaw_rad, yaw);
    }

    #[test]
    fn no_delay_or_no_history_or_a_bad_period_leave_the_state_alone() {
        let v = observer();
        let nav = NavState {
            u_m_s: 0.3,
            ..NavState::default()
        };
        let mut d = DelayCompensator::new();
        assert_eq!(d.predict(&v, &nav, 0.01), nav);
        d.set_delay_s(0.3).unwrap();
        assert_eq!(d.predict(&v, &nav, 0.01), nav);
        d.record(&BodyForces::default());
        assert_eq!(d.predict(&v, &nav, f32::NAN), nav);
        assert_eq!(d.predict(&v, &nav, 0.0), nav);
        assert_ne!(d.predict(&v, &nav, 0.01), nav);
    }
}
