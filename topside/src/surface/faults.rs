//! The vehicle's faults as ground stations see them: a `STATUSTEXT` when one rises
//! (CRITICAL) and when it clears (INFO), in words.

use super::transport::Gcs;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::MavSeverity;
use protocol::fault;

/// Names of the fault flags, for `STATUSTEXT`: the tether protocol's, then the topside
/// layout's (a topside board reports its node link in the same `faults`).
pub(super) const FAULT_NAMES: [(u16, &str); 15] = [
    (
        fault::HEARTBEAT_LOST,
        "tether heartbeat lost: thrusters neutral",
    ),
    (fault::LINK_DISARMED, "tether lost: disarmed"),
    (fault::NAV_STALE, "navigation stale: thrusters neutral"),
    (fault::MANUAL_STALE, "pilot input lost: thrusters neutral"),
    (fault::PWM_ERROR, "PWM output error"),
    (fault::SERIAL_ERROR, "tether serial error"),
    (fault::OVERRUN, "control loop overrun"),
    (
        fault::SENSOR_LOST,
        "IMU or pressure sensor lost: thrusters neutral",
    ),
    (fault::BATTERY_LOW, "battery low"),
    (fault::BATTERY_CRITICAL, "battery critical"),
    (fault::LEAK, "leak detected"),
    (fault::ENCLOSURE, "enclosure pressure or temperature high"),
    (fault::DEPTH_LIMIT, "at 90 % of the depth limit"),
    (
        protocol::fault::NODE_LINK_LOST,
        "node link lost: prediction only",
    ),
    (
        protocol::fault::NODE_NOT_ARMED,
        "node not armed: disarm and arm again",
    ),
];

/// Say every fault of `faults` that rose or cleared since `last`.
pub(super) fn report(gcs: &mut Gcs, faults: u16, last: u16) -> Result<()> {
    for (bit, name) in FAULT_NAMES {
        if faults & bit != 0 && last & bit == 0 {
            gcs.text(
                MavSeverity::MAV_SEVERITY_CRITICAL,
                &format!("Failsafe: {name}"),
            )?;
        } else if faults & bit == 0 && last & bit != 0 {
            gcs.text(MavSeverity::MAV_SEVERITY_INFO, &format!("Cleared: {name}"))?;
        }
    }
    Ok(())
}
