//! One commander at a time. Every ground station sees everything the
//! vehicle says (telemetry, parameters, missions, status texts); one of them commands:
//!
//! - **Who commands**: the station that holds control. Control is taken by the first
//!   commanding message while nobody holds it (arming, a mode, a parameter, a mission, the
//!   sticks), or explicitly with `CHANGE_OPERATOR_CONTROL` (`control_request` 0), answered
//!   by `CHANGE_OPERATOR_CONTROL_ACK` with MAVLink's codes: `ack` 0 granted; 1 the passkey
//!   is wrong (or `CTRL_PASSKEY` is 0: no takeover); 3 control changed hands less than
//!   [`GRANT_HOLD`] ago (one grant at a time: two stations asking at once get one grant,
//!   and stations swapping control get at most one grant per [`GRANT_HOLD`]). While nobody
//!   holds control a request is granted without a passkey (the first command would take it
//!   anyway). The holder is told who asked and whether it was granted. The holder gives
//!   control up with `CHANGE_OPERATOR_CONTROL` `control_request` 1, or by being silent (no
//!   message at all) for [`COMMANDER_SILENCE`]: QGroundControl, MAVProxy and Cockpit send a
//!   heartbeat every second. After any change of commander the topside sends the vehicle
//!   centred sticks until it has seen the new commander's sticks at centre (`Topside`).
//!   (`MAV_CMD_REQUEST_OPERATOR_CONTROL` is in MAVLink's development set, not in the
//!   ArduPilot dialect the ground stations speak to ArduSub, so it cannot be parsed here.)
//! - **Others**: their commands are answered `COMMAND_ACK` `TEMPORARILY_REJECTED`, their
//!   `PARAM_SET` with the value in force, their mission writes with `MISSION_ACK` `DENIED`, each
//!   with a `STATUSTEXT` naming the station in control; their `MANUAL_CONTROL` is ignored and
//!   counted (one `STATUSTEXT` every [`MANUAL_NOTE_EVERY`]).
//! - **Disarming** is the one exception: any station may disarm at any time (the safe state,
//!   a ground station's emergency stop); it is announced to all.
//! - Whenever control changes every station is told (`STATUSTEXT` "Control: ...").

use super::transport::{Gcs, StationId};
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavMessage, MavSeverity, CHANGE_OPERATOR_CONTROL_ACK_DATA, COMMAND_INT_DATA,
    COMMAND_LONG_DATA,
};
use mavlink::MavHeader;
use std::time::{Duration, Instant};

/// A commander silent this long gives up control (about three missed heartbeats).
pub const COMMANDER_SILENCE: Duration = Duration::from_secs(3);
/// A station whose sticks are ignored is told so at most this often.
pub const MANUAL_NOTE_EVERY: Duration = Duration::from_secs(5);
/// After control changes hands, no other station takes it for this long.
pub const GRANT_HOLD: Duration = Duration::from_secs(2);

/// What the arbitration decided for one message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Not a command (a request, a heartbeat): anyone.
    Open,
    /// From the station in control (or one that just took it): obeyed.
    Obey,
    /// From another station: refused, naming the holder.
    Refuse(StationId),
}

/// Who commands the vehicle.
#[derive(Debug, Default)]
pub struct Commander {
    holder: Option<StationId>,
    /// `MANUAL_CONTROL` messages ignored because their station was not in control.
    pub manual_ignored: u64,
    /// Commands refused because their station was not in control.
    pub refused: u64,
    manual_noted: Option<Instant>,
    /// When control last changed hands to a station.
    granted_at: Option<Instant>,
    /// Takeovers refused (wrong passkey, or too soon after the last grant).
    pub takeovers_refused: u64,
}

/// True for a message that changes the vehicle's state (and so needs control).
// (The deprecated SET_MODE, MISSION_ITEM and SET_GPS_GLOBAL_ORIGIN are still sent.)
#[allow(deprecated)]
pub fn is_command(msg: &MavMessage) -> bool {
    matches!(
        msg,
        MavMessage::COMMAND_LONG(COMMAND_LONG_DATA { command, .. })
            | MavMessage::COMMAND_INT(COMMAND_INT_DATA { command, .. })
            if !super::queries::is_query(*command)
    ) || matches!(
        msg,
        MavMessage::SET_MODE(_)
            | MavMessage::MANUAL_CONTROL(_)
            | MavMessage::SET_POSITION_TARGET_LOCAL_NED(_)
            | MavMessage::SET_POSITION_TARGET_GLOBAL_INT(_)
            | MavMessage::PARAM_SET(_)
            | MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_ITEM_INT(_)
            | MavMessage::MISSION_ITEM(_)
            | MavMessage::MISSION_CLEAR_ALL(_)
            | MavMessage::SET_GPS_GLOBAL_ORIGIN(_)
    )
}

/// A disarm command (`MAV_CMD_COMPONENT_ARM_DISARM` with param1 exactly 0).
pub fn is_disarm(msg: &MavMessage) -> bool {
    matches!(msg, MavMessage::COMMAND_LONG(c)
        if c.command == MavCmd::MAV_CMD_COMPONENT_ARM_DISARM && c.param1 == 0.0)
}

impl Commander {
    /// The station in control.
    pub fn holder(&self) -> Option<StationId> {
        self.holder
    }

    fn set(&mut self, gcs: &mut Gcs, holder: Option<StationId>, why: &str) -> Result<()> {
        if self.holder == holder {
            return Ok(());
        }
        self.holder = holder;
        if holder.is_some() {
            self.granted_at = Some(Instant::now());
        }
        let text = match holder {
            Some(s) => format!("Control: {} ({why})", gcs.label(s)),
            None => format!("Control: nobody ({why})"),
        };
        eprintln!("topside: {text}");
        gcs.text(MavSeverity::MAV_SEVERITY_NOTICE, &text)
    }

    /// Every control period: a silent holder gives up control.
    pub fn tick(&mut self, gcs: &mut Gcs) -> Result<()> {
        if let Some(h) = self.holder {
            if gcs.silent_for(h).is_none_or(|d| d >= COMMANDER_SILENCE) {
                let why = format!("{} silent", gcs.label(h));
                self.set(gcs, None, &why)?;
            }
        }
        Ok(())
    }

    /// A `CHANGE_OPERATOR_CONTROL` take request from `station` with `passkey` (its text up
    /// to the first NUL), against `wanted` (none: takeovers refused): the MAVLink `ack` code.
    fn take(
        &mut self,
        gcs: &mut Gcs,
        station: StationId,
        passkey: &str,
        wanted: Option<&str>,
    ) -> Result<u8> {
        let Some(holder) = self.holder.filter(|&h| h != station) else {
            let why = if self.holder.is_none() {
                "took control; nobody held it"
            } else {
                "already in control"
            };
            self.set(gcs, Some(station), why)?;
            return Ok(0);
        };
        let (from, to) = (gcs.label(station), gcs.label(holder));
        let warn = MavSeverity::MAV_SEVERITY_WARNING;
        if wanted.is_none_or(|w| w != passkey) {
            self.takeovers_refused += 1;
            let why = if wanted.is_none() {
                format!("CTRL_PASSKEY is 0 (no takeover): ask {to} to release control")
            } else {
                "wrong passkey".to_string()
            };
            gcs.text_to(station, warn, &format!("Control not granted: {why}"))?;
            gcs.text_to(
                holder,
                warn,
                &format!("{from} asked for control: refused ({why})"),
            )?;
            eprintln!("topside: {from} asked for control: refused ({why})");
            return Ok(1);
        }
        if self.granted_at.is_some_and(|t| t.elapsed() < GRANT_HOLD) {
            self.takeovers_refused += 1;
            let text = format!(
                "Control not granted: it changed hands less than {} s ago",
                GRANT_HOLD.as_secs()
            );
            gcs.text_to(station, warn, &text)?;
            return Ok(3);
        }
        gcs.text_to(
            holder,
            warn,
            &format!("Control taken by {from} with the passkey: your commands and sticks are refused now"),
        )?;
        self.set(
            gcs,
            Some(station),
            &format!("took control from {to} with the passkey"),
        )?;
        Ok(0)
    }

    /// Arbitrate `msg` from `station`; `CHANGE_OPERATOR_CONTROL` is answered here (`Open`
    /// afterwards, nothing more to do), a takeover checked against `passkey`.
    pub fn judge(
        &mut self,
        gcs: &mut Gcs,
        station: StationId,
        header: MavHeader,
        msg: &MavMessage,
        passkey: Option<&str>,
    ) -> Result<Verdict> {
        if let MavMessage::CHANGE_OPERATOR_CONTROL(c) = msg {
            gcs.stats.handled += 1;
            let ack = if c.control_request == 0 {
                let given = c
                    .passkey
                    .to_str()
                    .unwrap_or("")
                    .trim_end_matches('\0')
                    .to_string();
                self.take(gcs, station, &given, passkey)?
            } else {
                if self.holder == Some(station) {
                    self.set(gcs, None, "released")?;
                }
                0
            };
            gcs.send_to(
                station,
                MavMessage::CHANGE_OPERATOR_CONTROL_ACK(CHANGE_OPERATOR_CONTROL_ACK_DATA {
                    gcs_system_id: u8::try_from(header.system_id).unwrap_or(u8::MAX),
                    control_request: c.control_request,
                    ack,
                }),
            )?;
            return Ok(Verdict::Open);
        }
        if !is_command(msg) {
            return Ok(Verdict::Open);
        }
        match self.holder {
            None => {
                self.set(gcs, Some(station), "first to command")?;
                Ok(Verdict::Obey)
            }
            Some(h) if h == station => Ok(Verdict::Obey),
            Some(_) if is_disarm(msg) => {
                let text = format!("Disarm from {} (not in control)", gcs.label(station));
                gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
                Ok(Verdict::Obey)
            }
            Some(h) => {
                if matches!(msg, MavMessage::MANUAL_CONTROL(_)) {
                    self.manual_ignored += 1;
                    if self
                        .manual_noted
                        .is_none_or(|t| t.elapsed() >= MANUAL_NOTE_EVERY)
                    {
                        self.manual_noted = Some(Instant::now());
                        let text = format!(
                            "Sticks ignored: {} has control (CHANGE_OPERATOR_CONTROL to take it)",
                            gcs.label(h)
                        );
                        gcs.text_to(station, MavSeverity::MAV_SEVERITY_WARNING, &text)?;
                    }
                } else {
                    self.refused += 1;
                }
                Ok(Verdict::Refuse(h))
            }
        }
    }
}
