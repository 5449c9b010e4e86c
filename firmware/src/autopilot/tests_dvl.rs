//! The DVL's measurement kept for the telemetry: every sound reading the on-board estimator
//! was given, fused or refused only by its outlier gate; a broken one changes nothing.
#![allow(clippy::unwrap_used)]

use super::*;
use crate::protocol::DvlReport;
use controller_core::controller::Gains;
use controller_core::nav::{DvlFix, Refusal};
use controller_core::params::Vehicle;

const T0: u64 = 1_000_000;

fn dvl(t_us: u64, u: f32) -> Command {
    Command::DvlFix(DvlFix {
        t_us,
        velocity_m_s: [u, -0.5 * u],
        std_m_s: 0.01,
    })
}

#[test]
fn the_latest_sound_dvl_reading_is_kept_as_measured() {
    let c = Controller::new(Vehicle::observer(), Gains::default()).unwrap();
    let mut a = Autopilot::new(c, Failsafe::DEFAULT);
    assert_eq!(a.last_dvl(), DvlReport::default());
    // Without the estimator: refused, nothing kept.
    assert_eq!(
        a.handle_nav(T0, 1, &dvl(T0, 0.1)),
        Err(NackReason::NavSource)
    );
    assert!(!a.last_dvl().is_some());
    let start = Command::StartNav {
        t_us: T0,
        initial: NavState::default(),
        config: Default::default(),
    };
    a.handle_nav(T0, 2, &start).unwrap();
    assert_eq!(a.handle_nav(T0, 3, &dvl(T0, 0.01)), Ok(()));
    let fused = DvlReport {
        t_us: T0,
        velocity_m_s: [0.01, -0.005],
    };
    assert_eq!(a.last_dvl(), fused);
    // Far from what the estimator predicts (at rest, 1 cm/s accuracy): gated as an outlier,
    // and still the instrument's measurement.
    let r = a.handle_nav(T0, 4, &dvl(T0, 2.0));
    assert_eq!(r, Err(NackReason::NavRefused(Refusal::Outlier)));
    assert_eq!(a.last_dvl().velocity_m_s, [2.0, -1.0]);
    // Broken (NaN) or beyond any vehicle's speed: not kept.
    let before = a.last_dvl();
    assert!(a.handle_nav(T0, 5, &dvl(T0, f32::NAN)).is_err());
    assert!(a.handle_nav(T0, 6, &dvl(T0, 30.0)).is_err());
    assert_eq!(a.last_dvl(), before);
}
