//! What the served loop needs of a served vehicle beyond the closed loop's controller end:
//! the surface's bytes in, the vehicle's bytes out, what the vehicle believes for the truth
//! log.

use crate::closed_loop::ControllerEndpoint;
use controller_core::state::NavState;

/// What the vehicle believes after a tick, beside the true state in the truth log.
#[derive(Debug, Clone, Default)]
pub struct Believed {
    /// Its navigation state.
    pub nav: NavState,
    /// Armed.
    pub armed: bool,
    /// Its mode's name (`Idle`, `Hold`, `Track`, ...).
    pub mode: String,
    /// The latest `Telemetry` it sent the surface: its time stamp (us) and the navigation
    /// state it carried, which a ground station shows (a fix fused later in the same tick
    /// moves `nav` but not this).
    pub shown: Option<(u64, NavState)>,
}

impl Believed {
    /// The name of a mode as `{:?}` shows it, without its fields (`Track { .. }` -> `Track`).
    pub fn mode_name(mode: &impl std::fmt::Debug) -> String {
        let m = format!("{mode:?}");
        m.split(|c: char| !c.is_alphanumeric())
            .next()
            .unwrap_or_default()
            .to_string()
    }
}

/// A served vehicle: the closed loop's controller end with its tether on the served port.
pub trait ServedEndpoint: ControllerEndpoint {
    /// What the vehicle is ("firmware library in process", ...), for the first line.
    fn describe(&self) -> String;
    /// Bytes from the surface, taken at the next tick.
    fn surface_sent(&mut self, bytes: &[u8]);
    /// The bytes for the surface the vehicle wrote since the last call.
    fn take_surface_out(&mut self) -> Vec<u8>;
    /// What the vehicle believes now.
    fn believed(&self) -> Believed;
    /// The vehicle's own inputs (navigation, instruments) it refused.
    fn own_refused(&self) -> u64;
    /// A truth row every this many ticks (a loop finer than the vehicle's control writes
    /// one per control period of the vehicle).
    fn truth_stride(&self) -> u64 {
        1
    }
    /// Where the vehicle was put in the water (known once the loop has started).
    fn launch(&self) -> Option<NavState> {
        None
    }
    /// The estimator's settings its instruments call for, when it has an estimator.
    fn onboard_config(&self) -> Option<controller_core::nav::onboard::OnboardConfig> {
        None
    }
}
