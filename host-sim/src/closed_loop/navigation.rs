//! The navigation stage: what the controller is told about the vehicle ([`Navigation`]);
//! the truth path ([`TruthNav`]: the plant state `delay_s` ago with Gaussian noise).

use super::report::NavReport;
use controller_core::state::NavState;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sim_scenario::setup::RunSetup;
use sim_scenario::NoiseStd;
use sim_world::noise::gauss;
use sim_world::plant::{PlantState, RawState};
use sim_world::sensors::Measurement;

/// One USBL fix as the estimator saw it, for plots and logs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixRecord {
    /// Time of validity (s).
    pub t_valid_s: f64,
    /// Arrival (s).
    pub t_arrival_s: f64,
    /// North, east (m).
    pub pos_m: [f64; 2],
    /// Injected as an outlier.
    pub outlier: bool,
    /// Why the estimator refused it, if it did.
    pub refused: Option<controller_core::nav::Refusal>,
}

/// The navigation stage: what the controller is told about the vehicle.
pub trait Navigation {
    /// After every plant step: the true state at `t_s`.
    fn observe(&mut self, t_s: f64, truth: &PlantState);
    /// [`observe`](Self::observe) with the state as the plant holds it: a stage that keeps
    /// states and reads few converts only those it reads.
    fn observe_raw(&mut self, t_s: f64, truth: &RawState) {
        self.observe(t_s, &truth.state());
    }
    /// At each control tick, before [`estimate`](Self::estimate): the state last observed
    /// (the plant's now), as the loop converted it for its metrics. A stage that keeps
    /// states may keep this form instead of converting the same state again.
    fn observed_as(&mut self, _truth: &PlantState) {}
    /// At each control tick: the state handed to the controller. `thrust_cmd_n` is the
    /// command `[F1x, F2x, F3z]` (N) held over the period that just ended.
    fn estimate(&mut self, t_s: f64, thrust_cmd_n: [f64; 3]) -> NavState;
    /// Figures for `summary.json`.
    fn report(&self) -> NavReport;
    /// Standard deviation of the position estimate `[x, y, z]` (m), if the stage has one.
    fn position_std_m(&self) -> Option<[f64; 3]> {
        None
    }
    /// The USBL fixes so far, if the stage has any.
    fn usbl_fixes(&self) -> Vec<FixRecord> {
        Vec::new()
    }
    /// At each control tick, before the step: the measurements that have arrived for an
    /// estimator on the vehicle (empty when the stage estimates itself), in arrival order.
    fn for_vehicle(&mut self, _t_s: f64) -> Vec<Measurement> {
        Vec::new()
    }
}

/// The truth path: the plant state `delay` plant steps old (the initial state until enough
/// steps have passed), converted to the core's `f32` [`NavState`], with Gaussian noise.
#[derive(Debug, Clone)]
pub struct TruthNav {
    /// The last `delay_steps + 1` plant states, a ring: `oldest` is the one the
    /// measurement reads, and the slot the next state overwrites.
    history: Vec<RawState>,
    oldest: usize,
    noise: Option<NoiseStd>,
    rng: ChaCha8Rng,
}

impl TruthNav {
    /// A truth path `delay_steps` plant steps late, with noise of `noise` standard
    /// deviations if given.
    pub fn new(
        initial: PlantState,
        delay_steps: usize,
        noise: Option<NoiseStd>,
        seed: u64,
    ) -> Self {
        Self {
            history: vec![RawState::Euler(initial); delay_steps + 1],
            oldest: 0,
            noise,
            rng: ChaCha8Rng::seed_from_u64(seed),
        }
    }

    /// The truth path of a scenario (`[disturbance] delay_s`, `noise`, `noise_seed`).
    pub fn for_scenario(sc: &RunSetup, seed: Option<u64>) -> Self {
        let d = &sc.disturbance;
        Self::new(
            sc.initial(),
            (d.delay_s / sc.plant_steps().1).round() as usize,
            d.noise.then_some(d.noise_std),
            seed.unwrap_or(d.noise_seed),
        )
    }

    /// The newest plant state in, the oldest out (overwritten in place).
    fn push(&mut self, truth: RawState) {
        if let Some(slot) = self.history.get_mut(self.oldest) {
            *slot = truth;
        }
        self.oldest += 1;
        if self.oldest == self.history.len() {
            self.oldest = 0;
        }
    }

    /// The newest state's slot in the ring (the one before `oldest`).
    fn newest(&mut self) -> Option<&mut RawState> {
        let n = self.history.len();
        self.history.get_mut((self.oldest + n - 1) % n.max(1))
    }

    /// The measurement now.
    pub fn measure(&mut self) -> NavState {
        let st = self
            .history
            .get(self.oldest)
            .map(RawState::state)
            .unwrap_or_default();
        let mut nav = to_nav(&st);
        if let Some(ns) = self.noise {
            let rng = &mut self.rng;
            let mut g = |sd: f64| (sd * gauss(rng)) as f32;
            nav.x_m += g(ns.position_m);
            nav.y_m += g(ns.position_m);
            nav.z_m += g(ns.position_m);
            nav.roll_rad += g(ns.angle_rad);
            nav.pitch_rad += g(ns.angle_rad);
            nav.yaw_rad += g(ns.angle_rad);
            nav.u_m_s += g(ns.velocity_m_s);
            nav.v_m_s += g(ns.velocity_m_s);
            nav.w_m_s += g(ns.velocity_m_s);
            nav.p_rad_s += g(ns.rate_rad_s);
            nav.q_rad_s += g(ns.rate_rad_s);
            nav.r_rad_s += g(ns.rate_rad_s);
        }
        nav
    }
}

impl Navigation for TruthNav {
    fn observe(&mut self, _t_s: f64, truth: &PlantState) {
        self.push(RawState::Euler(*truth));
    }

    fn observe_raw(&mut self, _t_s: f64, truth: &RawState) {
        self.push(*truth);
    }

    fn observed_as(&mut self, truth: &PlantState) {
        // The plant's state pushed by the last step, converted by the loop with the same
        // function: the delayed measurement reads it without a second conversion (`atan2`,
        // `asin`). A state that is already Euler angles (the initial one) stays as it is.
        if let Some(slot) = self.newest() {
            if matches!(slot, RawState::Quaternion { .. }) {
                *slot = RawState::Euler(*truth);
            }
        }
    }

    fn estimate(&mut self, _t_s: f64, _thrust_cmd_n: [f64; 3]) -> NavState {
        self.measure()
    }

    fn report(&self) -> NavReport {
        NavReport {
            source: "truth".into(),
            ..NavReport::default()
        }
    }
}

/// The plant state as the core's `f32` navigation state.
pub fn to_nav(s: &PlantState) -> NavState {
    NavState {
        x_m: s.eta[0] as f32,
        y_m: s.eta[1] as f32,
        z_m: s.eta[2] as f32,
        roll_rad: s.eta[3] as f32,
        pitch_rad: s.eta[4] as f32,
        yaw_rad: s.eta[5] as f32,
        u_m_s: s.nu[0] as f32,
        v_m_s: s.nu[1] as f32,
        w_m_s: s.nu[2] as f32,
        p_rad_s: s.nu[3] as f32,
        q_rad_s: s.nu[4] as f32,
        r_rad_s: s.nu[5] as f32,
    }
}

/// A navigation stage behind a pointer is one: a loop can borrow its stage
/// (`run_closed_loop`) or own it (the topside's loop).
macro_rules! forward_navigation {
    ($($head:tt)*) => {
        $($head)* {
            fn observe(&mut self, t_s: f64, truth: &PlantState) {
                (**self).observe(t_s, truth)
            }
            fn observe_raw(&mut self, t_s: f64, truth: &RawState) {
                (**self).observe_raw(t_s, truth)
            }
            fn observed_as(&mut self, truth: &PlantState) {
                (**self).observed_as(truth)
            }
            fn estimate(&mut self, t_s: f64, thrust_cmd_n: [f64; 3]) -> NavState {
                (**self).estimate(t_s, thrust_cmd_n)
            }
            fn report(&self) -> NavReport {
                (**self).report()
            }
            fn position_std_m(&self) -> Option<[f64; 3]> {
                (**self).position_std_m()
            }
            fn usbl_fixes(&self) -> Vec<FixRecord> {
                (**self).usbl_fixes()
            }
            fn for_vehicle(&mut self, t_s: f64) -> Vec<Measurement> {
                (**self).for_vehicle(t_s)
            }
        }
    };
}

forward_navigation!(impl<T: Navigation + ?Sized> Navigation for &mut T);

forward_navigation!(impl<T: Navigation + ?Sized> Navigation for Box<T>);

#[cfg(test)]
mod tests {
    use super::*;

    /// The delayed measurement of a state the loop converted is the bits of the state
    /// converted by the truth path itself, the initial state (Euler angles) untouched.
    #[test]
    fn a_state_converted_once_measures_as_converted_twice() {
        let initial = PlantState {
            eta: [1.0, 2.0, 3.0, 0.1, -0.2, 2.9],
            nu: [0.1, 0.0, -0.1, 0.01, 0.02, 0.3],
        };
        let raw = |i: u32| RawState::Quaternion {
            pos_m: [f64::from(i), 0.5, 2.0],
            quat: [0.9, 0.1 * f64::from(i), -0.3, 0.2].map(|e| e / 0.984_885_780_179_610_5),
            nu: [0.2, 0.0, 0.0, 0.0, 0.0, 0.1 * f64::from(i)],
        };
        for delay in [0, 1, 3] {
            let noise = Some(NoiseStd::default());
            let (mut once, mut twice) = (
                TruthNav::new(initial, delay, noise, 7),
                TruthNav::new(initial, delay, noise, 7),
            );
            once.observed_as(&initial);
            for i in 0..8 {
                let a = once.estimate(0.0, [0.0; 3]);
                let b = twice.estimate(0.0, [0.0; 3]);
                assert_eq!(
                    format!("{a:?}"),
                    format!("{b:?}"),
                    "delay {delay}, tick {i}"
                );
                once.observe_raw(0.0, &raw(i));
                twice.observe_raw(0.0, &raw(i));
                once.observed_as(&raw(i).state());
            }
        }
    }
}
