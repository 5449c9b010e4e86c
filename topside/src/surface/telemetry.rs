//! What the ground stations are sent every period: `HEARTBEAT` and `SYS_STATUS` at 1 Hz,
//! the state streams at 10 Hz, parameters on request.

use super::ardusub_mode::custom_mode_of;
use super::geodesy::GlobalOrigin;
use super::transport::Gcs;
use super::transport::StationId;
use super::vehicle::Vehicle;
use crate::surface::params::{self, Settings};
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{
    MavAutopilot, MavMessage, MavModeFlag, MavParamType, MavState, MavSysStatusSensor, MavType,
    ATTITUDE_DATA, GLOBAL_POSITION_INT_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA,
    PARAM_VALUE_DATA, SERVO_OUTPUT_RAW_DATA, SYS_STATUS_DATA, VFR_HUD_DATA,
};
use protocol::fault;
use protocol::fault as link_fault;

pub(super) fn param_name(id: &mavlink::types::CharArray<16>) -> String {
    id.iter()
        .take_while(|&&b| b != 0)
        .map(|&b| char::from(b))
        .collect()
}

/// A `PARAM_VALUE`: to `to` only, or to every station (after a change, so that all see it).
pub(super) fn send_param(
    gcs: &mut Gcs,
    settings: &Settings,
    index: usize,
    to: Option<StationId>,
) -> Result<()> {
    let Some(p) = params::at(index) else {
        return Ok(());
    };
    let msg = MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
        param_value: (p.get)(settings),
        param_count: params::count() as u16,
        param_index: index as u16,
        param_id: p.name.into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    });
    match to {
        Some(s) => gcs.send_to(s, msg),
        None => gcs.send(msg),
    }
}

/// The faults during which the vehicle is in a failsafe (thrust neutral, surfacing or
/// disarmed), not a warning.
const FAILSAFES: u16 = fault::HEARTBEAT_LOST
    | fault::LINK_DISARMED
    | fault::NAV_STALE
    | fault::MANUAL_STALE
    | fault::SENSOR_LOST
    | fault::BATTERY_LOW
    | fault::BATTERY_CRITICAL
    | fault::LEAK
    | link_fault::NODE_LINK_LOST;

/// `HEARTBEAT`: ArduSub's type and autopilot, the armed flag, the mode.
pub(super) fn heartbeat(v: &Vehicle) -> MavMessage {
    let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if v.tel.armed {
        base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: custom_mode_of(v.tel.mode),
        mavtype: MavType::MAV_TYPE_SUBMARINE,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: base,
        // CRITICAL while a failsafe holds, as ArduSub reports it.
        system_status: if v.tel.faults & FAILSAFES != 0 {
            MavState::MAV_STATE_CRITICAL
        } else if v.tel.armed {
            MavState::MAV_STATE_ACTIVE
        } else {
            MavState::MAV_STATE_STANDBY
        },
        mavlink_version: 3,
    })
}

/// `SYS_STATUS`: the sensors' health, the link's errors, the battery.
pub(super) fn sys_status(v: &Vehicle, not_ours: u64) -> MavMessage {
    let sensors = MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_MAG
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
        | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    let mut healthy = sensors;
    if v.tel.faults & fault::NAV_STALE != 0 {
        healthy &= !(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE);
    }
    if v.tel.faults & fault::PWM_ERROR != 0 {
        healthy &= !MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    }
    // The topside layout: the IMU, the pressure sensor and the ESCs are on the
    // node, behind the node link; lost, none of them reaches the topside.
    if v.tel.faults & link_fault::NODE_LINK_LOST != 0 {
        healthy &= !(MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_GYRO
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_3D_ACCEL
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
            | MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS);
    }
    if v.tel.faults & link_fault::NODE_NOT_ARMED != 0 {
        healthy &= !MavSysStatusSensor::MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS;
    }
    let drops = v.frames_dropped().min(u64::from(u16::MAX)) as u16;
    let b = &v.battery;
    MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        onboard_control_sensors_present: sensors,
        onboard_control_sensors_enabled: sensors,
        onboard_control_sensors_health: healthy,
        errors_comm: drops,
        // Vehicle frames refused as out of range, and MAVLink messages addressed to another
        // system or component (ignored).
        errors_count1: v.frames_refused.min(u64::from(u16::MAX)) as u16,
        errors_count2: not_ours.min(u64::from(u16::MAX)) as u16,
        // The vehicle's battery monitor (`Status.battery`): millivolts, centiamperes, %;
        // MAVLink's "not measured" where it measures nothing.
        voltage_battery: if b.voltage_v > 0.0 {
            (b.voltage_v * 1000.0).round().clamp(0.0, 65_534.0) as u16
        } else {
            u16::MAX
        },
        current_battery: if b.current_a >= 0.0 {
            (b.current_a * 100.0).round().clamp(0.0, 32_767.0) as i16
        } else {
            -1
        },
        battery_remaining: if b.voltage_v > 0.0 {
            b.remaining_pct.round().clamp(0.0, 100.0) as i8
        } else {
            -1
        },
        ..Default::default()
    })
}

/// The state messages (`ATTITUDE`, `LOCAL_POSITION_NED`, `VFR_HUD`, `GLOBAL_POSITION_INT`
/// once an origin is set, `SERVO_OUTPUT_RAW`) by MAVLink id.
pub(super) fn state(id: u32, v: &Vehicle, origin: Option<&GlobalOrigin>) -> Option<MavMessage> {
    use super::streams as ids;
    let s = &v.state;
    // The vehicle's own clock, as an autopilot stamps its messages.
    let time_boot_ms = (v.tel.t_us / 1000) as u32;
    let (sp, cp) = s.yaw_rad.sin_cos();
    let vn = cp * s.u_m_s - sp * s.v_m_s;
    let ve = sp * s.u_m_s + cp * s.v_m_s;
    let heading_deg = s.yaw_rad.to_degrees().rem_euclid(360.0);
    Some(match id {
        ids::ATTITUDE => MavMessage::ATTITUDE(ATTITUDE_DATA {
            time_boot_ms,
            roll: s.roll_rad,
            pitch: s.pitch_rad,
            yaw: s.yaw_rad,
            rollspeed: s.p_rad_s,
            pitchspeed: s.q_rad_s,
            yawspeed: s.r_rad_s,
        }),
        ids::LOCAL_POSITION_NED => MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
            time_boot_ms,
            x: s.x_m,
            y: s.y_m,
            z: s.z_m,
            vx: vn,
            vy: ve,
            vz: s.w_m_s,
        }),
        ids::VFR_HUD => MavMessage::VFR_HUD(VFR_HUD_DATA {
            airspeed: s.u_m_s.abs(),
            groundspeed: (vn * vn + ve * ve).sqrt(),
            alt: -s.z_m,
            climb: -s.w_m_s,
            heading: heading_deg.round() as i16,
            throttle: 0,
        }),
        ids::GLOBAL_POSITION_INT => {
            // On the map: the local position on the globe, depth as negative altitude.
            let o = origin?;
            let [lat, lon] = o.to_global(f64::from(s.x_m), f64::from(s.y_m));
            MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms,
                lat: (lat * 1e7).round() as i32,
                lon: (lon * 1e7).round() as i32,
                alt: ((o.alt_m - f64::from(s.z_m)) * 1e3).round() as i32,
                relative_alt: (-s.z_m * 1e3).round() as i32,
                vx: (vn * 100.0).round() as i16,
                vy: (ve * 100.0).round() as i16,
                vz: (s.w_m_s * 100.0).round() as i16,
                hdg: (heading_deg * 100.0).round() as u16 % 36000,
            })
        }
        ids::SERVO_OUTPUT_RAW => {
            // The pulse widths of a frame the vehicle may have sent before its latest
            // accepted command (an arm, a mode change) or change of commander are not what
            // its ESCs see now.
            if v.frames_before_pulses > 0 {
                return None;
            }
            let [p1, p2, p3] = v.tel.pulse_us;
            MavMessage::SERVO_OUTPUT_RAW(SERVO_OUTPUT_RAW_DATA {
                time_usec: v.tel.t_us as u32,
                servo1_raw: p1,
                servo2_raw: p2,
                servo3_raw: p3,
                ..Default::default()
            })
        }
        _ => return None,
    })
}
