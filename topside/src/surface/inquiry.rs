//! What a ground station asks at connection, answered as ArduSub answers it:
//! `AUTOPILOT_VERSION` (capabilities declared truthfully: only what this program does),
//! `HOME_POSITION` (the origin, once one is set), `MAV_CMD_REQUEST_MESSAGE` (any streamed
//! message once), `MAV_CMD_SET_MESSAGE_INTERVAL` / `GET_MESSAGE_INTERVAL` (per station,
//! [`streams`](super::streams)), `SYSTEM_TIME`, `EKF_STATUS_REPORT` (the vehicle's
//! estimator: its spread against the readiness bounds) and `BATTERY_STATUS` (the vehicle's
//! battery monitor). None of these commands takes control: asking is not commanding.

// The superseded commands (`GET_HOME_POSITION`, `REQUEST_AUTOPILOT_CAPABILITIES`,
// `GET_MESSAGE_INTERVAL`) and `PARAM_FLOAT` are what ground stations still send and read.
#![allow(deprecated)]

use super::streams::{self as ids, Rate};
use super::telemetry;
use super::topside::Topside;
use super::transport::StationId;
use anyhow::Result;
use controller_core::nav::POSITION_READY_STD_M;
use mavlink::dialects::ardupilotmega::{
    EkfStatusFlags, MavBatteryFunction, MavBatteryType, MavCmd, MavMessage,
    MavProtocolCapability as C, MavResult, AUTOPILOT_VERSION_DATA, BATTERY_STATUS_DATA,
    EKF_STATUS_REPORT_DATA, HOME_POSITION_DATA, MESSAGE_INTERVAL_DATA, SYSTEM_TIME_DATA,
};
use protocol::fault;

/// What this program does of MAVLink's optional protocols: missions as floats and integers,
/// `COMMAND_INT`, float parameters (every one `REAL32`, sent as its value), local and global position targets, MAVLink 2. Not FTP,
/// terrain, fences or rallies (refused), attitude targets, flight termination, or the
/// onboard compass calibration's progress messages.
pub fn capabilities() -> C {
    C::MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
        | C::MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
        | C::MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
        | C::MAV_PROTOCOL_CAPABILITY_MISSION_INT
        | C::MAV_PROTOCOL_CAPABILITY_COMMAND_INT
        | C::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
        | C::MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
        | C::MAV_PROTOCOL_CAPABILITY_MAVLINK2
}

/// This program's version as ArduPilot packs it (major, minor, patch, release type 255).
fn flight_sw_version() -> u32 {
    let part = |s: &str| s.parse::<u32>().unwrap_or(0).min(255);
    (part(env!("CARGO_PKG_VERSION_MAJOR")) << 24)
        | (part(env!("CARGO_PKG_VERSION_MINOR")) << 16)
        | (part(env!("CARGO_PKG_VERSION_PATCH")) << 8)
        | 255
}

impl Topside {
    /// A message by MAVLink id as it is now, if this program sends it.
    pub(super) fn message(&self, id: u32) -> Option<MavMessage> {
        let v = &self.v;
        let time_boot_ms = (v.tel.t_us / 1000) as u32;
        Some(match id {
            ids::HEARTBEAT => telemetry::heartbeat(v),
            ids::SYS_STATUS => telemetry::sys_status(v, self.gcs.stats.not_ours),
            ids::SYSTEM_TIME => MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_micros() as u64),
                time_boot_ms,
            }),
            ids::AUTOPILOT_VERSION => MavMessage::AUTOPILOT_VERSION(AUTOPILOT_VERSION_DATA {
                capabilities: capabilities(),
                uid: u64::from(self.gcs.system_id()),
                flight_sw_version: flight_sw_version(),
                ..Default::default()
            }),
            ids::HOME_POSITION => {
                // Home is the origin of the local frame, on the globe once one is set.
                let o = self.gcs.origin?;
                MavMessage::HOME_POSITION(HOME_POSITION_DATA {
                    latitude: (o.lat_deg * 1e7).round() as i32,
                    longitude: (o.lon_deg * 1e7).round() as i32,
                    altitude: (o.alt_m * 1e3).round() as i32,
                    q: [1.0, 0.0, 0.0, 0.0],
                    ..Default::default()
                })
            }
            ids::EKF_STATUS_REPORT => self.ekf_status(),
            ids::BATTERY_STATUS => {
                let b = &v.battery;
                let measured = b.voltage_v > 0.0;
                let mut voltages = [u16::MAX; 10];
                voltages[0] = if measured {
                    (b.voltage_v * 1000.0).round().clamp(0.0, 65_534.0) as u16
                } else {
                    u16::MAX
                };
                MavMessage::BATTERY_STATUS(BATTERY_STATUS_DATA {
                    current_consumed: -1,
                    energy_consumed: -1,
                    temperature: i16::MAX,
                    voltages,
                    current_battery: if b.current_a >= 0.0 {
                        (b.current_a * 100.0).round().clamp(0.0, 32_767.0) as i16
                    } else {
                        -1
                    },
                    id: 0,
                    battery_function: MavBatteryFunction::MAV_BATTERY_FUNCTION_ALL,
                    mavtype: MavBatteryType::MAV_BATTERY_TYPE_LIPO,
                    battery_remaining: if measured {
                        b.remaining_pct.round().clamp(0.0, 100.0) as i8
                    } else {
                        -1
                    },
                })
            }
            other => telemetry::state(other, v, self.gcs.origin.as_ref())?,
        })
    }

    /// `EKF_STATUS_REPORT` from the vehicle's navigation: every solution flag while its
    /// navigation is fresh, the horizontal position ones only while the estimate is ready;
    /// the variances are the estimate's spread over the readiness bound (1 = the bound,
    /// ArduPilot's test ratios' meaning).
    fn ekf_status(&self) -> MavMessage {
        let v = &self.v;
        let [sx, sy, sz] = v.tel.nav_pos_std_m;
        let horiz = sx.max(sy) / POSITION_READY_STD_M;
        let fresh = v.tel.faults & fault::NAV_STALE == 0 && v.tel.t_us > 0;
        let mut flags = EkfStatusFlags::empty();
        if fresh {
            flags |= EkfStatusFlags::EKF_ATTITUDE
                | EkfStatusFlags::EKF_VELOCITY_HORIZ
                | EkfStatusFlags::EKF_VELOCITY_VERT
                | EkfStatusFlags::EKF_POS_VERT_ABS;
            if horiz <= 1.0 {
                flags |= EkfStatusFlags::EKF_POS_HORIZ_REL | EkfStatusFlags::EKF_PRED_POS_HORIZ_REL;
                if self.gcs.origin.is_some() {
                    flags |=
                        EkfStatusFlags::EKF_POS_HORIZ_ABS | EkfStatusFlags::EKF_PRED_POS_HORIZ_ABS;
                }
            }
        } else {
            flags |= EkfStatusFlags::EKF_UNINITIALIZED;
        }
        MavMessage::EKF_STATUS_REPORT(EKF_STATUS_REPORT_DATA {
            velocity_variance: 0.0,
            pos_horiz_variance: horiz,
            pos_vert_variance: sz / POSITION_READY_STD_M,
            compass_variance: 0.0,
            terrain_alt_variance: 0.0,
            flags,
        })
    }

    /// Every control period `k`: each streamed message to the stations it is due to.
    pub(super) fn send_streams(&mut self, k: u64) -> Result<()> {
        let period_s = self.v.period_s;
        for &(id, _) in ids::STREAMS {
            let (default_due, own) = self.streams.due(id, k, period_s);
            if !default_due && own.is_empty() {
                continue;
            }
            let Some(msg) = self.message(id) else {
                continue;
            };
            let streams = &self.streams;
            self.gcs.send_filtered(msg, |s| {
                own.contains(&s) || (default_due && !streams.has_own(s, id))
            })?;
        }
        Ok(())
    }

    /// The informational commands ([`is_query`]), each answered with a `COMMAND_ACK`.
    pub(super) fn query(
        &mut self,
        station: StationId,
        command: MavCmd,
        param1: f32,
        param2: f32,
    ) -> Result<()> {
        self.gcs.stats.handled += 1;
        let id =
            (param1.is_finite() && param1 >= 0.0 && param1.fract() == 0.0).then_some(param1 as u32);
        let (result, reply) = match command {
            MavCmd::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES => (
                MavResult::MAV_RESULT_ACCEPTED,
                self.message(ids::AUTOPILOT_VERSION),
            ),
            MavCmd::MAV_CMD_GET_HOME_POSITION => match self.message(ids::HOME_POSITION) {
                Some(m) => (MavResult::MAV_RESULT_ACCEPTED, Some(m)),
                // ArduPilot's answer while home is not set.
                None => (MavResult::MAV_RESULT_FAILED, None),
            },
            MavCmd::MAV_CMD_REQUEST_MESSAGE => match id.and_then(|id| self.message(id)) {
                Some(m) => (MavResult::MAV_RESULT_ACCEPTED, Some(m)),
                None if id == Some(ids::HOME_POSITION) => (MavResult::MAV_RESULT_FAILED, None),
                None => (MavResult::MAV_RESULT_UNSUPPORTED, None),
            },
            MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL => {
                match id.map(|id| self.streams.set(station, id, param2)) {
                    Some(Ok(_)) => (MavResult::MAV_RESULT_ACCEPTED, None),
                    Some(Err(why)) => {
                        return self.refuse(
                            station,
                            command,
                            &format!("Message interval refused: {why}"),
                        )
                    }
                    None => {
                        return self.refuse(
                            station,
                            command,
                            &format!(
                            "Message interval refused: message id {param1} is not a whole number"
                        ),
                        )
                    }
                }
            }
            MavCmd::MAV_CMD_GET_MESSAGE_INTERVAL => match id {
                Some(id) if ids::default_interval(id).is_some() => {
                    let interval_us = match self.streams.rate(station, id) {
                        Rate::Off => -1,
                        Rate::Every(s) => (s * 1e6).round() as i32,
                    };
                    let m = MavMessage::MESSAGE_INTERVAL(MESSAGE_INTERVAL_DATA {
                        interval_us,
                        message_id: id as u16,
                    });
                    (MavResult::MAV_RESULT_ACCEPTED, Some(m))
                }
                _ => {
                    let m = MavMessage::MESSAGE_INTERVAL(MESSAGE_INTERVAL_DATA {
                        interval_us: 0,
                        message_id: id.unwrap_or(0).min(u32::from(u16::MAX)) as u16,
                    });
                    (MavResult::MAV_RESULT_ACCEPTED, Some(m))
                }
            },
            _ => (MavResult::MAV_RESULT_UNSUPPORTED, None),
        };
        self.gcs.ack(station, command, result)?;
        if let Some(m) = reply {
            self.gcs.send_to(station, m)?;
        }
        Ok(())
    }
}
