//! The waypoint mission: its upload item by item and what AUTO has reached of it.

use super::{
    seconds_since, Autopilot, Mission, MAX_MISSION_DEPTH_M, MAX_MISSION_RANGE_M,
    MAX_MISSION_SPEED_M_S,
};
use crate::protocol::{Mode, NackReason};
use controller_core::reference::mission::MAX_WAYPOINTS;

impl Autopilot {
    /// Take waypoint `index` of a mission of `count`; the mission in use changes only when
    /// the last one arrives, and a refused item leaves it as it was.
    pub(super) fn mission_item(
        &mut self,
        index: u16,
        count: u16,
        pos_m: [f32; 3],
        speed_m_s: f32,
    ) -> Result<(), NackReason> {
        // AUTO flies the mission it entered with; a new one while it flies would be
        // acknowledged and not flown: refused, as `MissionClear` is.
        if self.mode == Mode::Auto {
            return Err(NackReason::Unsupported);
        }
        let [x, y, z] = pos_m;
        if !(x.is_finite() && y.is_finite() && z.is_finite() && speed_m_s.is_finite()) {
            return Err(NackReason::NonFinite);
        }
        let far = x.abs() > MAX_MISSION_RANGE_M || y.abs() > MAX_MISSION_RANGE_M;
        let too_many = usize::from(count) > MAX_WAYPOINTS || count == 0 || index >= count;
        let speed_ok = speed_m_s > 0.0 && speed_m_s <= MAX_MISSION_SPEED_M_S;
        if far || too_many || !(0.0..=MAX_MISSION_DEPTH_M).contains(&z) || !speed_ok {
            return Err(NackReason::OutOfRange);
        }
        self.check_target_depth(z)?;
        if index == 0 {
            self.upload = Mission::default();
        }
        if usize::from(index) != self.upload.waypoints.len() {
            return Err(NackReason::OutOfRange);
        }
        self.upload
            .waypoints
            .push(pos_m)
            .map_err(|_| NackReason::OutOfRange)?;
        self.upload.speed_m_s = speed_m_s;
        if index + 1 == count {
            self.mission = core::mem::take(&mut self.upload);
        }
        Ok(())
    }

    /// Waypoints of the mission AUTO flies that the reference has passed (0 outside AUTO).
    pub fn mission_reached(&self, now_us: u64) -> u16 {
        match (&self.auto, self.mode) {
            (Some((path, start)), Mode::Auto) => {
                u16::try_from(path.reached(seconds_since(now_us, *start))).unwrap_or(u16::MAX)
            }
            _ => 0,
        }
    }

    /// Waypoints in the mission in use.
    pub fn mission_len(&self) -> usize {
        self.mission.waypoints.len()
    }
}
