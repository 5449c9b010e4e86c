//! The ranges the vehicle accepts on the wire, written once for both ends: the vehicle
//! refuses a command beyond them (`Nack`), and the surface checks a ground station's request
//! against the same numbers before it sends, so that it can say why.
//!
//! Which commands are navigation inputs and how each command is answered are methods of
//! [`Command`](crate::Command) ([`is_nav_input`](crate::Command::is_nav_input),
//! [`response`](crate::Command::response)); the fault bits of `Telemetry::faults` are in
//! [`fault`](crate::fault).

use crate::NackReason;

/// Most waypoints in a mission (`Command::MissionItem::count`): the core's mission path.
pub const MAX_MISSION_ITEMS: usize = controller_core::reference::mission::MAX_WAYPOINTS;
/// Deepest waypoint accepted (m): the Observer's 150 m tether, with room for its catenary.
pub const MAX_MISSION_DEPTH_M: f32 = 100.0;
/// Farthest waypoint accepted from the origin, horizontally, each axis (m).
pub const MAX_MISSION_RANGE_M: f32 = 1_000.0;
/// Fastest mission speed accepted (m/s).
pub const MAX_MISSION_SPEED_M_S: f32 = 1.0;

/// Slowest yaw rate of a compass calibration turn (`Command::StartCompassCal`, rad/s, either
/// sign): slower, a turn takes over two minutes.
pub const SWING_RATE_MIN_RAD_S: f32 = 0.05;
/// Fastest yaw rate of a compass calibration turn (rad/s): faster, the compass (10 Hz) sees
/// too few headings per cycle.
pub const SWING_RATE_MAX_RAD_S: f32 = 0.6;
/// Longest time limit of a compass calibration turn (s).
pub const SWING_TIME_LIMIT_MAX_S: f32 = 600.0;

/// The checks of one `Command::MissionItem` that do not depend on the vehicle's state:
/// `NonFinite` for a NaN or infinite number; `OutOfRange` for an index not below `count`, a
/// `count` of 0 or over [`MAX_MISSION_ITEMS`], a waypoint farther than
/// [`MAX_MISSION_RANGE_M`] on an axis or outside 0..=[`MAX_MISSION_DEPTH_M`] deep, or a speed
/// not in (0, [`MAX_MISSION_SPEED_M_S`]].
pub fn check_mission_item(
    index: u16,
    count: u16,
    pos_m: [f32; 3],
    speed_m_s: f32,
) -> Result<(), NackReason> {
    let [x, y, z] = pos_m;
    if !(x.is_finite() && y.is_finite() && z.is_finite() && speed_m_s.is_finite()) {
        return Err(NackReason::NonFinite);
    }
    let far = x.abs() > MAX_MISSION_RANGE_M || y.abs() > MAX_MISSION_RANGE_M;
    let too_many = usize::from(count) > MAX_MISSION_ITEMS || count == 0 || index >= count;
    let speed_ok = speed_m_s > 0.0 && speed_m_s <= MAX_MISSION_SPEED_M_S;
    if far || too_many || !(0.0..=MAX_MISSION_DEPTH_M).contains(&z) || !speed_ok {
        return Err(NackReason::OutOfRange);
    }
    Ok(())
}

/// Whether a compass calibration turn at `yaw_rate_rad_s` (either sign) within
/// `time_limit_s` is in range.
pub fn compass_turn_in_range(yaw_rate_rad_s: f32, time_limit_s: f32) -> bool {
    let rate_ok = (SWING_RATE_MIN_RAD_S..=SWING_RATE_MAX_RAD_S).contains(&yaw_rate_rad_s.abs());
    let limit_ok = time_limit_s > 0.0 && time_limit_s <= SWING_TIME_LIMIT_MAX_S;
    rate_ok && limit_ok
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mission_item_is_checked_as_the_vehicle_checks_it() {
        let ok = check_mission_item(0, 3, [10.0, -20.0, 5.0], 0.5);
        assert_eq!(ok, Ok(()));
        let cases = [
            (0, 3, [10.0, 0.0, f32::NAN], 0.5, NackReason::NonFinite),
            (0, 3, [10.0, 0.0, 5.0], f32::INFINITY, NackReason::NonFinite),
            (3, 3, [10.0, 0.0, 5.0], 0.5, NackReason::OutOfRange),
            (0, 0, [10.0, 0.0, 5.0], 0.5, NackReason::OutOfRange),
            (0, 33, [10.0, 0.0, 5.0], 0.5, NackReason::OutOfRange),
            (0, 3, [1000.5, 0.0, 5.0], 0.5, NackReason::OutOfRange),
            (0, 3, [0.0, -1000.5, 5.0], 0.5, NackReason::OutOfRange),
            (0, 3, [0.0, 0.0, 100.5], 0.5, NackReason::OutOfRange),
            (0, 3, [0.0, 0.0, -0.1], 0.5, NackReason::OutOfRange),
            (0, 3, [0.0, 0.0, 5.0], 0.0, NackReason::OutOfRange),
            (0, 3, [0.0, 0.0, 5.0], 1.01, NackReason::OutOfRange),
        ];
        for (index, count, pos_m, speed, why) in cases {
            assert_eq!(
                check_mission_item(index, count, pos_m, speed),
                Err(why),
                "{index}/{count} {pos_m:?} {speed}"
            );
        }
        // The limits themselves are in range.
        let edge = [
            MAX_MISSION_RANGE_M,
            -MAX_MISSION_RANGE_M,
            MAX_MISSION_DEPTH_M,
        ];
        assert_eq!(
            check_mission_item(31, 32, edge, MAX_MISSION_SPEED_M_S),
            Ok(())
        );
    }

    #[test]
    fn a_compass_turn_is_in_range_between_the_limits() {
        assert!(compass_turn_in_range(0.25, 60.0));
        assert!(compass_turn_in_range(-0.6, 600.0));
        assert!(compass_turn_in_range(0.05, 1.0));
        assert!(!compass_turn_in_range(0.04, 60.0));
        assert!(!compass_turn_in_range(-0.61, 60.0));
        assert!(!compass_turn_in_range(0.25, 0.0));
        assert!(!compass_turn_in_range(0.25, 600.5));
        assert!(!compass_turn_in_range(f32::NAN, 60.0));
        assert!(!compass_turn_in_range(0.25, f32::NAN));
    }
}
