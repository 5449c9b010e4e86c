//! The informational commands, which any station may send without taking control.

// The deprecated query commands are still sent by ground stations: they are answered.
#![allow(deprecated)]

use mavlink::dialects::ardupilotmega::MavCmd;

/// The informational commands: answered to any station, never taking control.
pub(super) fn is_query(command: MavCmd) -> bool {
    matches!(
        command,
        MavCmd::MAV_CMD_REQUEST_MESSAGE
            | MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL
            | MavCmd::MAV_CMD_GET_MESSAGE_INTERVAL
            | MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES
            | MavCmd::MAV_CMD_GET_HOME_POSITION
    )
}
