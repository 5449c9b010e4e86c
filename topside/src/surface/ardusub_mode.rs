//! ArduSub's custom mode numbers (`ArduSub/mode.h`), and the one each firmware mode is shown
//! as.

use protocol::Mode;

/// Heading hold with the yaw stick centred.
pub const STABILIZE: u32 = 0;
/// Depth hold with the pilot steering.
pub const ALT_HOLD: u32 = 2;
/// The uploaded mission.
pub const AUTO: u32 = 3;
/// Go to and hold a point.
pub const GUIDED: u32 = 4;
/// Go up to the surface (the battery and leak failsafes).
pub const SURFACE: u32 = 9;
/// Hold the position.
pub const POSHOLD: u32 = 16;
/// Sticks straight to the thrusters.
pub const MANUAL: u32 = 19;

/// The ArduSub mode a firmware mode is shown as (a tracking mode, which no ground station
/// asks for, as AUTO).
pub(super) fn custom_mode_of(mode: Mode) -> u32 {
    match mode {
        Mode::Manual => MANUAL,
        Mode::Stabilize => STABILIZE,
        Mode::Auto => AUTO,
        Mode::DepthHold => ALT_HOLD,
        Mode::Hold => POSHOLD,
        Mode::Guided => GUIDED,
        Mode::Track { .. } => AUTO,
        Mode::Idle => MANUAL,
        Mode::Surface => SURFACE,
    }
}
