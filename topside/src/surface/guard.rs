//! What the topside refuses or holds back before it forwards anything, and what it will not
//! believe from the vehicle:
//!
//! - a message addressed to another system or component is ignored, as ArduPilot does, and
//!   counted (`SYS_STATUS` `errors_count2`);
//! - an arm in a stick mode: the commander's latest sticks go to the vehicle first (its own
//!   check refuses off-centre sticks), and the topside refuses while they are off centre
//!   ([`STICK_CENTRED`]), with the reason in words;
//! - the vehicle's silence, and its telemetry frames refused as out of range, said to the
//!   operator; the saved parameters it has not taken yet tried again.

use super::missions::Missions;
use super::sticks::{sticks_centred, MANUAL_CONTROL_TIMEOUT, STICK_CENTRED};
use super::topside::Topside;
use super::transport::{StationId, UnknownItem};
use super::vehicle;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{MavMessage, MavMissionResult, MavSeverity};
use mavlink::MavHeader;
use protocol::{Command, Mode};

/// Our MAVLink component id (`MAV_COMP_ID_AUTOPILOT1`).
pub(super) const COMPONENT_ID: u8 = 1;

impl Topside {
    /// Is `msg` addressed to another system or component (its `target_system` not ours and
    /// not 0, or its `target_component` not ours and not 0)? Then it is ignored, as ArduPilot
    /// does, counted and noted.
    pub(super) fn addressed_elsewhere(&mut self, station: StationId, msg: &MavMessage) -> bool {
        use mavlink::Message;
        let ours = self.gcs.system_id();
        let not_ours = msg.target_system_id().is_some_and(|t| t != 0 && t != ours)
            || msg
                .target_component_id()
                .is_some_and(|c| c != 0 && c != COMPONENT_ID);
        if not_ours {
            self.gcs.stats.not_ours += 1;
            let what = format!(
                "{}: {} addressed to {}/{} ignored (we are {ours}/{COMPONENT_ID})",
                self.gcs.label(station),
                msg.message_name(),
                msg.target_system_id().unwrap_or(0),
                msg.target_component_id().unwrap_or(0)
            );
            self.gcs.note(&what);
        }
        not_ours
    }

    /// Before an arm in a stick mode: the commander's latest sticks (if fresh) go to the
    /// vehicle, whose own check refuses off-centre sticks; off centre here, the arm is
    /// refused with the reason.
    pub(super) fn sticks_refuse_arming(&mut self) -> Result<Option<String>> {
        let stick_mode = matches!(
            self.v.tel.mode,
            Mode::Manual | Mode::Stabilize | Mode::DepthHold | Mode::Idle
        );
        let fresh = self
            .manual_at
            .is_some_and(|at| at.elapsed() < MANUAL_CONTROL_TIMEOUT);
        if !(stick_mode && fresh) {
            return Ok(None);
        }
        let m = self.manual;
        // The sticks are not acknowledged: sent, and one control period run so that the
        // vehicle holds them before the arm (its own check runs then).
        self.v.send(&Command::ManualThrust(m))?;
        self.v.step()?;
        if sticks_centred(&m) {
            return Ok(None);
        }
        Ok(Some(format!(
            "Arming refused: sticks not centred (surge {:+.2}, yaw {:+.2}, heave {:+.2}; \
             centred is within {STICK_CENTRED}): centre them first",
            m.surge, m.yaw, m.heave
        )))
    }

    /// Every control period: the vehicle's silence and refused frames said to the operator;
    /// once a second, the saved parameters it has not taken yet tried again.
    pub(super) fn watch_vehicle(&mut self, every_second: bool) -> Result<()> {
        let silent_for = self.v.silent_for();
        let silent = silent_for >= vehicle::VEHICLE_SILENCE;
        if silent != self.vehicle_silent {
            self.vehicle_silent = silent;
            let (severity, text) = if silent {
                (
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    format!(
                        "Vehicle silent for {:.1} s: commands refused until it answers; \
                         heartbeats go on",
                        silent_for.as_secs_f64()
                    ),
                )
            } else {
                (
                    MavSeverity::MAV_SEVERITY_INFO,
                    "Vehicle answers again".to_string(),
                )
            };
            eprintln!("topside: {text}");
            self.gcs.text(severity, &text)?;
        }
        if every_second && self.v.frames_refused > self.refusals_said {
            let n = self.v.frames_refused - self.refusals_said;
            self.refusals_said = self.v.frames_refused;
            let why = self.v.last_refusal.clone().unwrap_or_default();
            let text = format!("Vehicle frames refused: {n} ({why})");
            eprintln!("topside: {text}");
            self.gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
        }
        if every_second && !silent {
            self.pending.retry(&mut self.v, &mut self.gcs)?;
        }
        Ok(())
    }

    /// A mission item this dialect cannot parse: ignored if addressed elsewhere, refused for
    /// a station not in control, else answered by the mission protocol.
    pub(super) fn on_unknown_item(
        &mut self,
        station: StationId,
        header: MavHeader,
        item: UnknownItem,
    ) -> Result<()> {
        let ours = self.gcs.system_id();
        if (item.target_system != 0 && item.target_system != ours)
            || (item.target_component != 0 && item.target_component != COMPONENT_ID)
        {
            self.gcs.stats.not_ours += 1;
            return Ok(());
        }
        if let Some(holder) = self.commander.holder().filter(|&h| h != station) {
            let why = format!(
                "{} has control (CHANGE_OPERATOR_CONTROL to take it)",
                self.gcs.label(holder)
            );
            let peer = (
                station,
                u8::try_from(header.system_id).unwrap_or(u8::MAX),
                header.component_id,
            );
            return Missions::deny(
                &mut self.gcs,
                peer,
                MavMissionResult::MAV_MISSION_DENIED,
                &why,
            );
        }
        self.missions
            .unknown_item(&mut self.gcs, station, header, item)
    }
}
