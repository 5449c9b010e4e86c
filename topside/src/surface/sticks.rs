//! The pilot's sticks: ArduSub's `MANUAL_CONTROL` conventions, what counts as centred, and how
//! long a stick stays live.

use protocol::ManualThrust;
use std::time::Duration;

/// A `MANUAL_CONTROL` older than this (wall clock) is no longer forwarded.
pub const MANUAL_CONTROL_TIMEOUT: Duration = Duration::from_millis(500);

/// Largest stick deflection that counts as centred (fraction of full scale): the vehicle's.
pub const STICK_CENTRED: f32 = firmware::autopilot::STICK_CENTRED;

/// Are all three sticks centred?
pub fn sticks_centred(m: &ManualThrust) -> bool {
    [m.surge, m.yaw, m.heave]
        .iter()
        .all(|v| v.abs() <= STICK_CENTRED)
}

/// `MANUAL_CONTROL` to normalized thrust, ArduSub's conventions: x forward and r clockwise in
/// -1000..1000, z 0..1000 with 500 neutral and above 500 up (our heave is positive down); y
/// (sway) has no thruster.
pub fn manual_thrust(x: i16, z: i16, r: i16) -> ManualThrust {
    let norm = |v: f32| (v / 1000.0).clamp(-1.0, 1.0);
    ManualThrust {
        surge: norm(f32::from(x)),
        yaw: norm(f32::from(r)),
        heave: -((f32::from(z) - 500.0) / 500.0).clamp(-1.0, 1.0),
    }
}
