//! The mission protocol at the surface (`MISSION_COUNT` / `MISSION_REQUEST_INT` /
//! `MISSION_ITEM_INT` / `MISSION_ACK`, downloads, `MISSION_CLEAR_ALL`).
//!
//! An upload is a transaction of one station: while it runs, another station's
//! `MISSION_COUNT` or items are refused with `MISSION_ACK` `DENIED` and a `STATUSTEXT`
//! naming the station uploading, and the upload goes on; an upload that waits 5 s for an item
//! is abandoned (`OPERATION_CANCELLED`). A new mission is refused while the vehicle flies one
//! in AUTO (`DENIED`, "leave AUTO first"): the mission flown is the one the operator saw
//! accepted before AUTO. Requests and acknowledgements go to the station of the exchange
//! only.
//!
//! `mission_type`: only the mission (0) is kept. A FENCE (1) or RALLY (2) upload is refused
//! with `MAV_MISSION_UNSUPPORTED`, its list is empty and clearing it is accepted (there is
//! nothing to clear); none of them touches the mission. ALL (255) clears the mission; an
//! upload or list of ALL is refused (`MAV_MISSION_UNSUPPORTED`, MAVLink allows ALL only in
//! `MISSION_CLEAR_ALL`). Every answer carries the type it answers. Every item is answered:
//! one past the count with `MAV_MISSION_INVALID_SEQUENCE`, one whose frame or command this
//! dialect does not know with `MAV_MISSION_UNSUPPORTED_FRAME` / `MAV_MISSION_UNSUPPORTED`,
//! one outside an upload with `MAV_MISSION_ERROR`.

use super::geodesy::item_position;
use super::transport::{Gcs, StationId, UnknownItem};
use super::vehicle::Vehicle;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavFrame, MavMessage, MavMissionResult, MavSeverity, MISSION_ACK_DATA,
    MISSION_COUNT_DATA, MISSION_CURRENT_DATA, MISSION_ITEM_INT_DATA, MISSION_ITEM_REACHED_DATA,
    MISSION_REQUEST_INT_DATA,
};
use mavlink::MavHeader;
use protocol::{Command, Mode, Telemetry};
use std::time::{Duration, Instant};

/// Most waypoints a mission may have (the vehicle's store).
pub const MISSION_MAX_ITEMS: usize = protocol::limits::MAX_MISSION_ITEMS;
/// An upload that waits this long for the next item asks again (5 times, then gives up).
const MISSION_RETRY: Duration = Duration::from_secs(1);

/// A mission item as the ground station sent it (as `MISSION_ITEM_INT`: a float
/// `MISSION_ITEM` is converted to the spec's scaling), its waypoint in the local frame, and
/// whether it came as the float form.
type ReceivedItem = (MISSION_ITEM_INT_DATA, [f32; 3], bool);

/// The mission protocol at the surface: uploads item by item to the vehicle, the mission in
/// use for downloads, and the progress reported in AUTO.
#[derive(Debug, Default)]
pub(super) struct Missions {
    /// Upload in progress: items so far, the count announced, when the last request went,
    /// how many times it went, and the station uploading.
    upload: Option<(Vec<ReceivedItem>, u16, Instant, u32, Peer)>,
    /// The mission the vehicle holds, as the ground station sent it.
    items: Vec<MISSION_ITEM_INT_DATA>,
    /// Its local-frame items carry metres x 1e7 (MAVProxy's and ArduPilot's scaling of
    /// `MISSION_ITEM_INT` in every frame), not the MAVLink spec's x 1e4.
    local_e7: bool,
    /// The station that uploaded it: its downloads come back exactly as it sent them.
    uploader: Option<StationId>,
    /// Waypoints reported reached in the current AUTO run.
    reached: u16,
    /// The ground station of the latest mission exchange (station, system, component):
    /// requests and acknowledgements go to it, addressed as ground stations check.
    peer: Peer,
}

/// A station and its MAVLink system and component ids.
type Peer = (StationId, u8, u8);

/// `MAV_MISSION_TYPE` values.
const MISSION: u8 = 0;
const FENCE: u8 = 1;
const RALLY: u8 = 2;
const ALL: u8 = 255;

/// The largest local coordinate at the spec's x 1e4 within the vehicle's range.
const LOCAL_E4_MAX: f64 = protocol::limits::MAX_MISSION_RANGE_M as f64 * 1e4;

/// An item in the float form (`MISSION_ITEM`): x, y in metres (local frames) or degrees
/// (global), from an integer item carrying local metres x 1e7 (`local_e7`) or x 1e4.
#[allow(deprecated)]
pub(super) fn float_item(
    i: &MISSION_ITEM_INT_DATA,
    local_e7: bool,
) -> mavlink::dialects::ardupilotmega::MISSION_ITEM_DATA {
    let scale = if i.frame == MavFrame::MAV_FRAME_LOCAL_NED && !local_e7 {
        1e-4
    } else {
        1e-7
    };
    mavlink::dialects::ardupilotmega::MISSION_ITEM_DATA {
        param1: i.param1,
        param2: i.param2,
        param3: i.param3,
        param4: i.param4,
        x: (f64::from(i.x) * scale) as f32,
        y: (f64::from(i.y) * scale) as f32,
        z: i.z,
        seq: i.seq,
        command: i.command,
        target_system: i.target_system,
        target_component: i.target_component,
        frame: i.frame,
        current: i.current,
        autocontinue: i.autocontinue,
    }
}

/// A float `MISSION_ITEM` as `MISSION_ITEM_INT` in the spec's scaling: local x, y in metres
/// x 1e4, global degrees x 1e7 (a value beyond `i32` saturates and is refused by range).
#[allow(deprecated)]
pub(super) fn int_item(
    i: &mavlink::dialects::ardupilotmega::MISSION_ITEM_DATA,
) -> MISSION_ITEM_INT_DATA {
    let scale = if i.frame == MavFrame::MAV_FRAME_LOCAL_NED {
        1e4
    } else {
        1e7
    };
    let as_int = |m: f32| {
        let v = (f64::from(m) * scale).round();
        if v.is_finite() {
            v.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
        } else {
            i32::MAX
        }
    };
    MISSION_ITEM_INT_DATA {
        param1: i.param1,
        param2: i.param2,
        param3: i.param3,
        param4: i.param4,
        x: as_int(i.x),
        y: as_int(i.y),
        z: i.z,
        seq: i.seq,
        command: i.command,
        target_system: i.target_system,
        target_component: i.target_component,
        frame: i.frame,
        current: i.current,
        autocontinue: i.autocontinue,
    }
}

impl Missions {
    /// Item `seq` of the mission for a download by `station`: as its uploader sent it, to
    /// others (and with `None`) local x, y in the spec's metres x 1e4.
    fn download_item(&self, station: Option<StationId>, seq: u16) -> Option<MISSION_ITEM_INT_DATA> {
        let mut item = self.items.get(usize::from(seq))?.clone();
        if self.local_e7 && item.frame == MavFrame::MAV_FRAME_LOCAL_NED {
            if station.is_some() && self.uploader == station {
                return Some(item);
            }
            item.x /= 1000;
            item.y /= 1000;
        }
        Some(item)
    }

    fn request(peer: Peer, gcs: &mut Gcs, seq: u16) -> Result<()> {
        gcs.send_to(
            peer.0,
            MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                seq,
                target_system: peer.1,
                target_component: peer.2,
            }),
        )
    }

    fn ack(peer: Peer, gcs: &mut Gcs, result: MavMissionResult) -> Result<()> {
        Self::ack_typed(peer, gcs, result, MISSION)
    }

    /// A `MISSION_ACK` for `mission_type`.
    fn ack_typed(
        peer: Peer,
        gcs: &mut Gcs,
        result: MavMissionResult,
        mission_type: u8,
    ) -> Result<()> {
        let ack = MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: peer.1,
            target_component: peer.2,
            mavtype: result,
        });
        gcs.send_typed(peer.0, ack, mission_type)
    }

    /// A mission message of another `mission_type` than the mission: answered for its type,
    /// the mission untouched (ALL clears it). (`MISSION_ITEM` and `MISSION_REQUEST` are
    /// deprecated, still sent.)
    #[allow(deprecated)]
    fn other_type(
        &mut self,
        gcs: &mut Gcs,
        v: &mut Vehicle,
        sender: Peer,
        msg: &MavMessage,
        mission_type: u8,
    ) -> Result<bool> {
        use MavMissionResult as R;
        let warn = MavSeverity::MAV_SEVERITY_WARNING;
        let kind = match mission_type {
            FENCE => "FENCE",
            RALLY => "RALLY",
            ALL => "ALL",
            _ => "unknown",
        };
        match msg {
            MavMessage::MISSION_CLEAR_ALL(_) if mission_type == ALL => {
                self.peer = sender;
                return self.clear(gcs, v, ALL).map(|_| true);
            }
            MavMessage::MISSION_CLEAR_ALL(_) if matches!(mission_type, FENCE | RALLY) => {
                // Nothing of that type is kept: cleared already.
                Self::ack_typed(sender, gcs, R::MAV_MISSION_ACCEPTED, mission_type)?;
            }
            MavMessage::MISSION_REQUEST_LIST(_) if matches!(mission_type, FENCE | RALLY) => {
                gcs.send_typed(
                    sender.0,
                    MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                        count: 0,
                        target_system: sender.1,
                        target_component: sender.2,
                    }),
                    mission_type,
                )?;
            }
            MavMessage::MISSION_ACK(_) => {}
            MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_ITEM_INT(_)
            | MavMessage::MISSION_ITEM(_)
            | MavMessage::MISSION_CLEAR_ALL(_)
            | MavMessage::MISSION_REQUEST_LIST(_)
            | MavMessage::MISSION_REQUEST_INT(_)
            | MavMessage::MISSION_REQUEST(_) => {
                let text = format!(
                    "Mission refused: {kind} (type {mission_type}) is not kept here; the \
                     mission is untouched"
                );
                gcs.text_to(sender.0, warn, &text)?;
                Self::ack_typed(sender, gcs, R::MAV_MISSION_UNSUPPORTED, mission_type)?;
            }
            _ => return Ok(false),
        }
        gcs.stats.handled += 1;
        Ok(true)
    }

    /// A mission item this dialect cannot parse (an unknown frame or command): the upload
    /// it belongs to is refused with the reason, anything else answered as an item outside
    /// an upload; never silence.
    pub(super) fn unknown_item(
        &mut self,
        gcs: &mut Gcs,
        station: StationId,
        from: MavHeader,
        item: UnknownItem,
    ) -> Result<()> {
        use MavMissionResult as R;
        gcs.stats.handled += 1;
        let sender: Peer = (
            station,
            u8::try_from(from.system_id).unwrap_or(u8::MAX),
            from.component_id,
        );
        let (result, what) = if item.frame_known {
            (R::MAV_MISSION_UNSUPPORTED, "a command")
        } else {
            (R::MAV_MISSION_UNSUPPORTED_FRAME, "a frame")
        };
        let why = format!("item {}: {what} this vehicle does not know", item.seq);
        if item.mission_type != MISSION {
            return Self::ack_typed(sender, gcs, R::MAV_MISSION_UNSUPPORTED, item.mission_type);
        }
        match self.uploader() {
            Some(u) if u == station => self.refuse(gcs, result, &why),
            _ => Self::deny(gcs, sender, result, &why),
        }
    }

    /// Refuse `peer`'s mission message with `result` and say why (to it); the mission in use
    /// stays, and so does another station's upload in progress.
    pub(super) fn deny(
        gcs: &mut Gcs,
        peer: Peer,
        result: MavMissionResult,
        why: &str,
    ) -> Result<()> {
        gcs.text_to(
            peer.0,
            MavSeverity::MAV_SEVERITY_WARNING,
            &format!("Mission refused: {why}"),
        )?;
        Self::ack(peer, gcs, result)
    }

    /// Refuse the upload in progress with `result` and say why; the mission in use stays.
    fn refuse(&mut self, gcs: &mut Gcs, result: MavMissionResult, why: &str) -> Result<()> {
        let peer = self.upload.take().map_or(self.peer, |u| u.4);
        gcs.text(
            MavSeverity::MAV_SEVERITY_WARNING,
            &format!("Mission refused: {why}"),
        )?;
        Self::ack(peer, gcs, result)
    }

    /// The station uploading, if an upload is in progress.
    pub(super) fn uploader(&self) -> Option<StationId> {
        self.upload.as_ref().map(|u| u.4 .0)
    }

    /// Abandon the upload in progress (its station lost control): it is told
    /// `OPERATION_CANCELLED`.
    pub(super) fn abandon(&mut self, gcs: &mut Gcs, why: &str) -> Result<()> {
        if self.upload.is_some() {
            self.refuse(gcs, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED, why)?;
        }
        Ok(())
    }

    /// A mission message from the ground station; false if `msg` is not one. `MISSION_REQUEST`
    /// is deprecated, but older ground stations still download with it: both are answered.
    #[allow(deprecated)]
    pub(super) fn handle(
        &mut self,
        gcs: &mut Gcs,
        v: &mut Vehicle,
        station: StationId,
        from: MavHeader,
        msg: &MavMessage,
        mission_type: u8,
    ) -> Result<bool> {
        // (MAVLink system ids are 8 bits on the wire.)
        let sender: Peer = (
            station,
            u8::try_from(from.system_id).unwrap_or(u8::MAX),
            from.component_id,
        );
        if mission_type != MISSION {
            return self.other_type(gcs, v, sender, msg, mission_type);
        }
        let writes = matches!(
            msg,
            MavMessage::MISSION_COUNT(_)
                | MavMessage::MISSION_CLEAR_ALL(_)
                | MavMessage::MISSION_ITEM_INT(_)
                | MavMessage::MISSION_ITEM(_)
        );
        if let Some(uploader) = self.uploader().filter(|&u| writes && u != station) {
            gcs.stats.handled += 1;
            let why = format!("{} is uploading a mission", gcs.label(uploader));
            Self::deny(gcs, sender, MavMissionResult::MAV_MISSION_DENIED, &why)?;
            return Ok(true);
        }
        if matches!(
            msg,
            MavMessage::MISSION_COUNT(_)
                | MavMessage::MISSION_REQUEST_LIST(_)
                | MavMessage::MISSION_CLEAR_ALL(_)
        ) {
            self.peer = sender;
        }
        match msg {
            MavMessage::MISSION_COUNT(c) if c.count > 0 && v.tel.mode == Mode::Auto => {
                let why = "the vehicle is flying a mission in AUTO (leave AUTO first)";
                Self::deny(gcs, sender, MavMissionResult::MAV_MISSION_DENIED, why)?;
            }
            MavMessage::MISSION_COUNT(c) => {
                if usize::from(c.count) > MISSION_MAX_ITEMS {
                    let why = format!("{} items, the vehicle holds {MISSION_MAX_ITEMS}", c.count);
                    return self
                        .refuse(gcs, MavMissionResult::MAV_MISSION_NO_SPACE, &why)
                        .map(|_| true);
                }
                if c.count == 0 {
                    return self.clear(gcs, v, MISSION).map(|_| true);
                }
                self.upload = Some((Vec::new(), c.count, Instant::now(), 1, sender));
                Self::request(self.peer, gcs, 0)?;
            }
            MavMessage::MISSION_ITEM_INT(item) => self.item(gcs, v, sender, item, false)?,
            // The float form, which MAVProxy sends to a vehicle that does not announce
            // MISSION_INT in AUTOPILOT_VERSION: the same item, x and y in metres (local) or
            // degrees (global).
            MavMessage::MISSION_ITEM(i) => self.item(gcs, v, sender, &int_item(i), true)?,
            MavMessage::MISSION_REQUEST_LIST(_) => {
                gcs.send_to(
                    station,
                    MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                        count: self.items.len() as u16,
                        target_system: sender.1,
                        target_component: sender.2,
                    }),
                )?;
            }
            // Each item in the form asked for: `MISSION_ITEM_INT` for `MISSION_REQUEST_INT`,
            // the float `MISSION_ITEM` for `MISSION_REQUEST`.
            MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA { seq, .. }) => {
                match self.download_item(Some(station), *seq) {
                    Some(item) => gcs.send_to(
                        station,
                        // Addressed to the station downloading (MAVSDK drops an item
                        // addressed elsewhere).
                        MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                            target_system: sender.1,
                            target_component: sender.2,
                            ..item
                        }),
                    )?,
                    None => Self::ack(sender, gcs, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)?,
                }
            }
            MavMessage::MISSION_REQUEST(r) => match self.download_item(None, r.seq) {
                Some(item) => {
                    let item = MISSION_ITEM_INT_DATA {
                        target_system: sender.1,
                        target_component: sender.2,
                        ..item
                    };
                    gcs.send_to(station, MavMessage::MISSION_ITEM(float_item(&item, false)))?
                }
                None => Self::ack(sender, gcs, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)?,
            },
            MavMessage::MISSION_CLEAR_ALL(_) => self.clear(gcs, v, MISSION)?,
            // The end of a download.
            MavMessage::MISSION_ACK(_) => {}
            _ => return Ok(false),
        }
        gcs.stats.handled += 1;
        Ok(true)
    }

    fn clear(&mut self, gcs: &mut Gcs, v: &mut Vehicle, mission_type: u8) -> Result<()> {
        self.upload = None;
        match v.command(&Command::MissionClear)? {
            Ok(()) => {
                self.items.clear();
                Self::ack_typed(
                    self.peer,
                    gcs,
                    MavMissionResult::MAV_MISSION_ACCEPTED,
                    mission_type,
                )
            }
            Err(why) => {
                gcs.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Mission not cleared: {why} (leave AUTO first)"),
                )?;
                Self::ack_typed(
                    self.peer,
                    gcs,
                    MavMissionResult::MAV_MISSION_DENIED,
                    mission_type,
                )
            }
        }
    }

    /// One uploaded item: checked, kept; the last one sends the whole mission to the vehicle.
    fn item(
        &mut self,
        gcs: &mut Gcs,
        v: &mut Vehicle,
        sender: Peer,
        item: &MISSION_ITEM_INT_DATA,
        float: bool,
    ) -> Result<()> {
        let Some((items, count, at, tries, peer)) = self.upload.as_mut() else {
            let why = format!("item {} with no upload in progress", item.seq);
            return Self::deny(gcs, sender, MavMissionResult::MAV_MISSION_ERROR, &why);
        };
        let (count, peer) = (*count, *peer);
        if item.seq >= count {
            let why = format!("item {} of a mission of {count}", item.seq);
            return self.refuse(gcs, MavMissionResult::MAV_MISSION_INVALID_SEQUENCE, &why);
        }
        if usize::from(item.seq) != items.len() {
            // Out of order (a lost or repeated item): ask for the one expected.
            *at = Instant::now();
            *tries += 1;
            return Self::request(peer, gcs, items.len() as u16);
        }
        use MavMissionResult as R;
        let pos_m = match item_position(item.frame, item.x, item.y, item.z, gcs.origin.as_ref()) {
            Ok(p) => p,
            Err(why) => {
                let why = format!("item {}: {why}", item.seq);
                return self.refuse(gcs, R::MAV_MISSION_UNSUPPORTED_FRAME, &why);
            }
        };
        if item.command != MavCmd::MAV_CMD_NAV_WAYPOINT {
            let why = format!(
                "item {}: {:?}, only MAV_CMD_NAV_WAYPOINT",
                item.seq, item.command
            );
            return self.refuse(gcs, R::MAV_MISSION_UNSUPPORTED, &why);
        }
        let depth = pos_m[2];
        if !depth.is_finite() {
            let why = format!("item {}: depth is not a number", item.seq);
            return self.refuse(gcs, R::MAV_MISSION_INVALID_PARAM7, &why);
        }
        let max_depth = protocol::limits::MAX_MISSION_DEPTH_M;
        if !(0.0..=max_depth).contains(&depth) {
            let why = format!(
                "item {}: depth {depth} m is unreachable (0 to {max_depth} m)",
                item.seq
            );
            return self.refuse(gcs, R::MAV_MISSION_INVALID_PARAM7, &why);
        }
        items.push((item.clone(), pos_m, float));
        if items.len() < usize::from(count) {
            *at = Instant::now();
            *tries = 1;
            return Self::request(peer, gcs, items.len() as u16);
        }
        // Complete: to the vehicle, which replaces its mission only when the last one is in.
        let mut items = std::mem::take(items);
        // A local coordinate beyond the vehicle's range at the spec's x 1e4 is MAVProxy's
        // x 1e7 (the same numbers read at 1e4 would be over 1 km away): the whole upload is
        // read at 1e7. (MAVProxy's local points within 1 m of the origin cannot be told from
        // the spec's within 1 km; they are read as the spec says.)
        let local_e7 = items.iter().any(|(i, _, float)| {
            !float
                && i.frame == MavFrame::MAV_FRAME_LOCAL_NED
                && f64::from(i.x).hypot(f64::from(i.y)) > LOCAL_E4_MAX
        });
        if local_e7 {
            for (item, pos_m, float) in items.iter_mut() {
                if item.frame == MavFrame::MAV_FRAME_LOCAL_NED && !*float {
                    pos_m[0] *= 1e-3;
                    pos_m[1] *= 1e-3;
                }
            }
            gcs.text(
                MavSeverity::MAV_SEVERITY_INFO,
                "Mission: local x, y read as metres x 1e7 (MAVProxy's scaling), not x 1e4",
            )?;
        }
        for (i, (_, pos_m, _)) in items.iter().enumerate() {
            let cmd = Command::MissionItem {
                index: i as u16,
                count,
                pos_m: *pos_m,
                speed_m_s: v.settings.mission_speed_m_s,
            };
            if let Err(why) = v.command(&cmd)? {
                let why = format!("item {i} refused by the vehicle: {why}");
                return self.refuse(gcs, R::MAV_MISSION_INVALID, &why);
            }
        }
        self.upload = None;
        // Kept at one scale: a float item among x 1e7 ones is brought to x 1e7.
        self.items = items
            .into_iter()
            .map(|(mut item, _, float)| {
                if local_e7 && float && item.frame == MavFrame::MAV_FRAME_LOCAL_NED {
                    item.x = item.x.saturating_mul(1000);
                    item.y = item.y.saturating_mul(1000);
                }
                item
            })
            .collect();
        self.local_e7 = local_e7;
        self.uploader = Some(peer.0);
        gcs.text(
            MavSeverity::MAV_SEVERITY_INFO,
            &format!("Mission of {count} waypoints accepted"),
        )?;
        Self::ack(peer, gcs, R::MAV_MISSION_ACCEPTED)
    }

    /// Every control period: ask again for a late item; in AUTO, report the waypoints reached.
    pub(super) fn tick(
        &mut self,
        gcs: &mut Gcs,
        tel: &Telemetry,
        every_second: bool,
    ) -> Result<()> {
        if let Some((items, _, at, tries, peer)) = self.upload.as_mut() {
            if at.elapsed() > MISSION_RETRY {
                if *tries >= 5 {
                    return self.refuse(
                        gcs,
                        MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                        "no item for 5 s",
                    );
                }
                *at = Instant::now();
                *tries += 1;
                let next = items.len() as u16;
                Self::request(*peer, gcs, next)?;
            }
        }
        if tel.mode != Mode::Auto {
            self.reached = 0;
            return Ok(());
        }
        // At most the mission's waypoints, whatever the frame says (bounded work per frame).
        let reached = tel.mission_reached.min(self.items.len() as u16);
        while self.reached < reached {
            gcs.send(MavMessage::MISSION_ITEM_REACHED(
                MISSION_ITEM_REACHED_DATA { seq: self.reached },
            ))?;
            // ArduPilot's words, which ground stations show.
            let text = format!("Reached command #{}", self.reached);
            gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
            self.reached += 1;
        }
        if every_second {
            let last = (self.items.len() as u16).saturating_sub(1);
            gcs.send(MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
                seq: self.reached.min(last),
            }))?;
        }
        Ok(())
    }
}
