//! "Go to" as ground stations send it, flown by the vehicle in its GUIDED mode
//! (`Mode::Guided`: `GuidedTarget`, a point to go to and hold):
//!
//! | in | answered |
//! |---|---|
//! | `SET_POSITION_TARGET_LOCAL_NED` in `MAV_FRAME_LOCAL_NED` (north, east, depth from the origin), `LOCAL_OFFSET_NED` (from the vehicle's position), `BODY_NED` / `BODY_OFFSET_NED` (from the vehicle's position, x ahead and y to starboard of its heading: ArduSub reads both so) | `POSITION_TARGET_LOCAL_NED` with the target taken (ArduSub sends no `COMMAND_ACK` for these) |
//! | `SET_POSITION_TARGET_GLOBAL_INT` in `GLOBAL(_INT)`, `GLOBAL_RELATIVE_ALT(_INT)`, `GLOBAL_TERRAIN_ALT(_INT)` (read as relative: the surface is the datum) | the same, and `POSITION_TARGET_GLOBAL_INT` |
//! | a guided mission item (`MISSION_ITEM` / `MISSION_ITEM_INT` with `current` = 2: MAVProxy's `guided`) | `MISSION_ACK` `ACCEPTED`, or `ERROR` with the reason |
//! | `MAV_CMD_DO_REPOSITION` (`COMMAND_INT`, or `COMMAND_LONG` in degrees): with the change-mode flag it enters GUIDED first | `COMMAND_ACK` |
//!
//! Each is refused with a `STATUSTEXT` saying why: not in GUIDED, disarmed (a target given
//! before arming is never flown after it), a velocity or acceleration target (only positions
//! are flown), a frame not listed, NaN, deeper than 100 m or above the surface, more than 1 km
//! from the origin, a global target before `SET_GPS_GLOBAL_ORIGIN`.

use super::geodesy::{item_position, GlobalOrigin};
use super::topside::Topside;
use super::transport::StationId;
use anyhow::Result;
use controller_core::state::NavState;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavFrame, MavMessage, MavMissionResult, MavResult, MavSeverity,
    PositionTargetTypemask as M, COMMAND_INT_DATA, COMMAND_LONG_DATA, MISSION_ACK_DATA,
    MISSION_ITEM_INT_DATA, POSITION_TARGET_GLOBAL_INT_DATA, POSITION_TARGET_LOCAL_NED_DATA,
    SET_POSITION_TARGET_GLOBAL_INT_DATA, SET_POSITION_TARGET_LOCAL_NED_DATA,
};
use protocol::limits::{MAX_MISSION_DEPTH_M, MAX_MISSION_RANGE_M};
use protocol::Command;

/// `MAV_DO_REPOSITION_FLAGS_CHANGE_MODE`: enter GUIDED before going.
const REPOSITION_CHANGE_MODE: f32 = 1.0;

/// A target position's checks at the surface: finite, from the surface down to the deepest
/// waypoint a mission may have, within a mission's range of the origin. The vehicle checks
/// again.
pub fn check_target(pos_m: [f32; 3]) -> std::result::Result<[f32; 3], String> {
    let [n, e, d] = pos_m;
    if !pos_m.iter().all(|v| v.is_finite()) {
        return Err("the position is not a number (NaN or infinite)".into());
    }
    if !(0.0..=MAX_MISSION_DEPTH_M).contains(&d) {
        return Err(format!(
            "depth {d:.2} m is outside 0 (the surface) to {MAX_MISSION_DEPTH_M} m"
        ));
    }
    let range = n.hypot(e);
    if range > MAX_MISSION_RANGE_M {
        return Err(format!(
            "{range:.0} m from the origin, at most {MAX_MISSION_RANGE_M} m"
        ));
    }
    Ok(pos_m)
}

/// The type mask ignores the position (a velocity, acceleration or yaw target only).
fn position_ignored(mask: M) -> Option<String> {
    let ignored = M::POSITION_TARGET_TYPEMASK_X_IGNORE
        | M::POSITION_TARGET_TYPEMASK_Y_IGNORE
        | M::POSITION_TARGET_TYPEMASK_Z_IGNORE;
    mask.intersects(ignored).then(|| {
        format!(
            "only position targets are flown (type mask 0x{:x} ignores the position)",
            mask.bits()
        )
    })
}

/// A `SET_POSITION_TARGET_LOCAL_NED`'s point `[north, east, depth]` (m), the vehicle at
/// `here`: the frames ArduSub accepts.
// The body frames are superseded by `BODY_FRD` but are what ground stations send.
#[allow(deprecated)]
pub fn local_target(
    p: &SET_POSITION_TARGET_LOCAL_NED_DATA,
    here: &NavState,
) -> std::result::Result<[f32; 3], String> {
    if let Some(why) = position_ignored(p.type_mask) {
        return Err(why);
    }
    let (x, y, z) = (p.x, p.y, p.z);
    let at = [here.x_m, here.y_m, here.z_m];
    let pos = match p.coordinate_frame {
        MavFrame::MAV_FRAME_LOCAL_NED => [x, y, z],
        MavFrame::MAV_FRAME_LOCAL_OFFSET_NED => [at[0] + x, at[1] + y, at[2] + z],
        MavFrame::MAV_FRAME_BODY_NED | MavFrame::MAV_FRAME_BODY_OFFSET_NED => {
            let (s, c) = here.yaw_rad.sin_cos();
            [at[0] + c * x - s * y, at[1] + s * x + c * y, at[2] + z]
        }
        other => {
            return Err(format!(
                "frame {other:?} (taken: MAV_FRAME_LOCAL_NED, LOCAL_OFFSET_NED, BODY_NED, \
                 BODY_OFFSET_NED)"
            ))
        }
    };
    check_target(pos)
}

/// A global point (latitude and longitude x 1e7, altitude in `frame`) as `[north, east,
/// depth]` (m): through the origin, as a mission item's.
// The `_INT` frames are superseded by their plain names but still sent.
#[allow(deprecated)]
pub fn global_target(
    frame: MavFrame,
    lat_e7: i32,
    lon_e7: i32,
    alt_m: f32,
    origin: Option<&GlobalOrigin>,
) -> std::result::Result<[f32; 3], String> {
    let frame = match frame {
        // No terrain here: the surface is the datum, as the relative frame's.
        MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT | MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT => {
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
        }
        MavFrame::MAV_FRAME_LOCAL_NED => {
            return Err("frame MAV_FRAME_LOCAL_NED where a global frame is needed".into())
        }
        f => f,
    };
    let pos = item_position(frame, lat_e7, lon_e7, alt_m, origin)?;
    check_target(pos)
}

impl Topside {
    /// The vehicle is in GUIDED (its own mode, as its telemetry says: a restarted surface
    /// reads it back).
    pub(super) fn guided(&self) -> bool {
        self.v.tel.mode == protocol::Mode::Guided
    }

    /// Whether a target may be flown now: GUIDED and armed; else the reason.
    fn goto_state(&self) -> Option<&'static str> {
        if !self.guided() {
            Some("not in GUIDED (switch to GUIDED first)")
        } else if !self.v.tel.armed {
            Some("the vehicle is disarmed (arm in GUIDED, then send the target)")
        } else {
            None
        }
    }

    /// Fly to `pos_m`: the vehicle's GUIDED target, echoed as `POSITION_TARGET_LOCAL_NED`.
    fn fly_to(&mut self, pos_m: [f32; 3]) -> Result<std::result::Result<(), String>> {
        if let Err(why) = self.v.command(&Command::GuidedTarget { pos_m })? {
            return Ok(Err(format!("the vehicle refused the point: {why}")));
        }
        self.guided_target = Some(pos_m);
        self.send_position_target()?;
        Ok(Ok(()))
    }

    /// The GUIDED point in force, as ArduSub streams it.
    pub(super) fn send_position_target(&mut self) -> Result<()> {
        let Some([x, y, z]) = self.guided_target else {
            return Ok(());
        };
        // The vehicle's own clock, as on every other message the surface streams.
        let time_boot_ms = (self.v.tel.t_us / 1000) as u32;
        self.gcs.send(MavMessage::POSITION_TARGET_LOCAL_NED(
            POSITION_TARGET_LOCAL_NED_DATA {
                time_boot_ms,
                x,
                y,
                z,
                coordinate_frame: MavFrame::MAV_FRAME_LOCAL_NED,
                type_mask: M::POSITION_TARGET_TYPEMASK_VX_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_VY_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_VZ_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_AX_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_AY_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_AZ_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_YAW_IGNORE
                    | M::POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE,
                ..Default::default()
            },
        ))?;
        if let Some(o) = self.gcs.origin {
            let [lat, lon] = o.to_global(f64::from(x), f64::from(y));
            self.gcs.send(MavMessage::POSITION_TARGET_GLOBAL_INT(
                POSITION_TARGET_GLOBAL_INT_DATA {
                    time_boot_ms,
                    lat_int: (lat * 1e7).round() as i32,
                    lon_int: (lon * 1e7).round() as i32,
                    alt: -z,
                    coordinate_frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                    ..Default::default()
                },
            ))?;
        }
        Ok(())
    }

    /// `what` refused, said to `station`.
    fn goto_refused(&mut self, station: StationId, what: &str, why: &str) -> Result<()> {
        self.gcs.text_to(
            station,
            MavSeverity::MAV_SEVERITY_WARNING,
            &format!("{what} refused: {why}"),
        )
    }

    /// `SET_POSITION_TARGET_LOCAL_NED`.
    pub(super) fn target_local(
        &mut self,
        station: StationId,
        p: &SET_POSITION_TARGET_LOCAL_NED_DATA,
    ) -> Result<()> {
        self.gcs.stats.handled += 1;
        let what = "Target";
        if let Some(why) = self.goto_state() {
            return self.goto_refused(station, what, why);
        }
        let pos = match local_target(p, &self.v.state) {
            Ok(pos) => pos,
            Err(why) => return self.goto_refused(station, what, &why),
        };
        match self.fly_to(pos)? {
            Ok(()) => Ok(()),
            Err(why) => self.goto_refused(station, what, &why),
        }
    }

    /// `SET_POSITION_TARGET_GLOBAL_INT`.
    pub(super) fn target_global(
        &mut self,
        station: StationId,
        p: &SET_POSITION_TARGET_GLOBAL_INT_DATA,
    ) -> Result<()> {
        self.gcs.stats.handled += 1;
        let what = "Global target";
        if let Some(why) = self.goto_state() {
            return self.goto_refused(station, what, why);
        }
        if let Some(why) = position_ignored(p.type_mask) {
            return self.goto_refused(station, what, &why);
        }
        let origin = self.gcs.origin;
        let pos = match global_target(
            p.coordinate_frame,
            p.lat_int,
            p.lon_int,
            p.alt,
            origin.as_ref(),
        ) {
            Ok(pos) => pos,
            Err(why) => return self.goto_refused(station, what, &why),
        };
        match self.fly_to(pos)? {
            Ok(()) => Ok(()),
            Err(why) => self.goto_refused(station, what, &why),
        }
    }

    /// A guided mission item (`current` = 2), answered with `MISSION_ACK` as ArduPilot does.
    pub(super) fn guided_item(
        &mut self,
        station: StationId,
        sender: (u8, u8),
        item: &MISSION_ITEM_INT_DATA,
    ) -> Result<()> {
        self.gcs.stats.handled += 1;
        let what = "Guided waypoint";
        let result = if let Some(why) = self.goto_state() {
            Err(why.to_string())
        } else if item.command != MavCmd::MAV_CMD_NAV_WAYPOINT {
            Err(format!("{:?}, only MAV_CMD_NAV_WAYPOINT", item.command))
        } else {
            let origin = self.gcs.origin;
            match item_position(item.frame, item.x, item.y, item.z, origin.as_ref())
                .and_then(check_target)
            {
                Ok(pos) => self.fly_to(pos)?,
                Err(why) => Err(why),
            }
        };
        let mavtype = match &result {
            Ok(()) => MavMissionResult::MAV_MISSION_ACCEPTED,
            Err(_) => MavMissionResult::MAV_MISSION_ERROR,
        };
        if let Err(why) = &result {
            self.goto_refused(station, what, why)?;
        }
        self.gcs.send_to(
            station,
            MavMessage::MISSION_ACK(MISSION_ACK_DATA {
                target_system: sender.0,
                target_component: sender.1,
                mavtype,
            }),
        )
    }

    /// `MAV_CMD_DO_REPOSITION` as `COMMAND_INT`: latitude and longitude x 1e7 in `x`, `y`
    /// (`i32::MAX`: stay), the altitude in `z` (NaN: keep the depth), in the command's frame.
    pub(super) fn reposition_int(
        &mut self,
        station: StationId,
        c: &COMMAND_INT_DATA,
    ) -> Result<()> {
        let stay = |v: i32| v == i32::MAX;
        let horizontal = (!stay(c.x) && !stay(c.y)).then_some((c.x, c.y));
        self.reposition(station, c.param2, c.frame, horizontal, c.z)
    }

    /// `MAV_CMD_DO_REPOSITION` as `COMMAND_LONG`: latitude and longitude in degrees in
    /// param5, param6 (NaN: stay), the altitude (relative to the surface) in param7.
    pub(super) fn reposition_long(
        &mut self,
        station: StationId,
        c: &COMMAND_LONG_DATA,
    ) -> Result<()> {
        let e7 = |deg: f32| {
            let v = (f64::from(deg) * 1e7).round();
            (v.is_finite() && v.abs() <= f64::from(i32::MAX)).then_some(v as i32)
        };
        let horizontal = if c.param5.is_nan() && c.param6.is_nan() {
            None
        } else {
            match (e7(c.param5), e7(c.param6)) {
                (Some(lat), Some(lon)) => Some((lat, lon)),
                _ => {
                    return self.refuse(
                        station,
                        MavCmd::MAV_CMD_DO_REPOSITION,
                        &format!(
                            "Reposition refused: latitude {} and longitude {} are not degrees",
                            c.param5, c.param6
                        ),
                    )
                }
            }
        };
        self.reposition(
            station,
            c.param2,
            MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            horizontal,
            c.param7,
        )
    }

    fn reposition(
        &mut self,
        station: StationId,
        flags: f32,
        frame: MavFrame,
        horizontal: Option<(i32, i32)>,
        alt_m: f32,
    ) -> Result<()> {
        self.gcs.stats.handled += 1;
        let cmd = MavCmd::MAV_CMD_DO_REPOSITION;
        let change_mode =
            flags.is_finite() && (flags as u32) & (REPOSITION_CHANGE_MODE as u32) != 0;
        if !self.guided() && change_mode && self.v.tel.armed {
            if let Err(why) = self.enter_guided()? {
                return self.refuse(station, cmd, &format!("Reposition refused: {why}"));
            }
        }
        if let Some(why) = self.goto_state() {
            return self.refuse(station, cmd, &format!("Reposition refused: {why}"));
        }
        let here = self.v.state;
        let origin = self.gcs.origin;
        let pos = match horizontal {
            Some((lat, lon)) => {
                let alt = if alt_m.is_nan() { -here.z_m } else { alt_m };
                global_target(frame, lat, lon, alt, origin.as_ref())
            }
            None if alt_m.is_nan() => check_target([here.x_m, here.y_m, here.z_m]),
            None => check_target([here.x_m, here.y_m, -alt_m]),
        };
        let pos = match pos {
            Ok(p) => p,
            Err(why) => return self.refuse(station, cmd, &format!("Reposition refused: {why}")),
        };
        match self.fly_to(pos)? {
            Ok(()) => self.gcs.ack(station, cmd, MavResult::MAV_RESULT_ACCEPTED),
            Err(why) => self.refuse(station, cmd, &format!("Reposition refused: {why}")),
        }
    }

    /// GUIDED entered (holding where the vehicle is), as `MAV_CMD_DO_SET_MODE` 4 does,
    /// without its acknowledgement.
    fn enter_guided(&mut self) -> Result<std::result::Result<(), String>> {
        let hold = [self.v.state.x_m, self.v.state.y_m, self.v.state.z_m];
        let mode = protocol::Mode::Guided;
        if let Err(why) = self.v.command(&Command::SetMode(mode))? {
            return Ok(Err(format!("GUIDED refused: {why}")));
        }
        self.v.tel.mode = mode;
        self.guided_target = Some(hold);
        self.sticks_seen_centred = false;
        Ok(Ok(()))
    }
}
