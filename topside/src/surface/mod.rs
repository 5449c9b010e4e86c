//! The surface program (`rov-topside`). One side speaks the tether to the vehicle, the other
//! MAVLink 2 to ground stations (QGroundControl, MAVProxy, pymavlink), with ArduSub's
//! conventions so that existing tools map the vehicle's modes and sticks.
//!
//! The vehicle is reached through a byte stream only ([`vehicle`]): `--serial DEV[:BAUD]` (a
//! real vehicle, or the topside board of the paper's layout: the same tether protocol) or
//! `--tcp HOST:PORT` (a simulated vehicle served by `host-sim vehicle`, or a serial-to-TCP
//! bridge). The vehicle runs on its own clock and navigates itself; the modes run on the
//! vehicle: the surface translates.
//!
//! | MAVLink in | tether out |
//! |---|---|
//! | `COMMAND_LONG` `MAV_CMD_COMPONENT_ARM_DISARM` | `Arm` / `Disarm`, answered by `COMMAND_ACK` (`DENIED` + `STATUSTEXT` with the firmware's reason) |
//! | `SET_MODE`, `COMMAND_LONG` `MAV_CMD_DO_SET_MODE` (ArduSub custom modes) | MANUAL (19): `SetMode(Manual)`; STABILIZE (0): `SetMode(Stabilize)` (heading held while the yaw stick is centred); ALT_HOLD (2): `SetMode(DepthHold)` (and the depth while the throttle is centred); POSHOLD (16): `SetMode(Hold)`; GUIDED (4): hold the current point, then `SET_POSITION_TARGET_LOCAL_NED` targets |
//! | `MANUAL_CONTROL` (x surge, r yaw in -1000..1000; z heave 0..1000, 500 neutral, above 500 up; y sway ignored: no thruster) | `ManualThrust` every control period while in MANUAL, STABILIZE or ALT_HOLD |
//! | `SET_POSITION_TARGET_LOCAL_NED` (position, NED) | `SetReference(Hold)` in GUIDED |
//!
//! AUTO (3) flies the uploaded mission on the vehicle (`SetMode(Auto)`), refused without one.
//! Missions: the standard protocol (`MISSION_COUNT` / `MISSION_REQUEST_INT` /
//! `MISSION_ITEM_INT` (or the float `MISSION_ITEM`) / `MISSION_ACK`, download with
//! `MISSION_REQUEST_LIST`,
//! `MISSION_CLEAR_ALL`), `MAV_CMD_NAV_WAYPOINT` items in `MAV_FRAME_LOCAL_NED` (x, y in metres
//! x 1e4, z the depth in metres), at most 32; a mission with another frame or command, a NaN,
//! an unreachable depth or too many items is refused with `MISSION_ACK` and a `STATUSTEXT`, and
//! the mission in use stays. In AUTO: `MISSION_ITEM_REACHED` for each waypoint passed and
//! `MISSION_CURRENT` at 1 Hz. Any other message is ignored and counted.
//!
//! Out: `HEARTBEAT` at 1 Hz (`MAV_TYPE_SUBMARINE`, `MAV_AUTOPILOT_ARDUPILOTMEGA`, the armed
//! flag, `custom_mode` = the mode), `SYS_STATUS` at 1 Hz, and at 10 Hz `ATTITUDE`,
//! `LOCAL_POSITION_NED`, `VFR_HUD` (heading, depth as negative altitude) and `SERVO_OUTPUT_RAW`
//! (the three pulse widths the ESCs see); a `STATUSTEXT` for every failsafe the firmware
//! raises or clears and every refusal.
//!
//! Several ground stations: all see everything, one commands (`commander`: the first to
//! command, the one that armed, or the one granted `CHANGE_OPERATOR_CONTROL` with the
//! passkey `CTRL_PASSKEY`; anyone may disarm). No input from a ground station ends the
//! topside (`transport`). What is refused or held back before it reaches the vehicle
//! (messages for another system, arming with a stick held, thrust before a centred stick
//! after an arm, mode change or change of commander) and what is not believed from it is in
//! `guard`. Refused inputs
//! are answered (`COMMAND_ACK` / `MISSION_ACK` / `PARAM_VALUE`) with a `STATUSTEXT` reason:
//! `ARM_DISARM` with param1 other than 1 or 0, `DO_SET_MODE` with param2 not a whole mode
//! number, GUIDED targets outside the surface..100 m / 1 km box, `VEH_PWM_NEUTRAL`.
//!
//! Every MAVLink message sent or received goes to a `.tlog` (each a big-endian 64-bit
//! microsecond UNIX time stamp followed by the MAVLink frame: what QGroundControl, MAVExplorer
//! and pymavlink read), under a new time-stamped name each start (`logs`).
//!
//! The start (arguments, the vehicle behind the tether, the ground stations, the logs) is in
//! `start`; `topside` owns the state and runs the loop, and each kind of message has its file.

pub mod ardusub_mode;
mod buttons;
mod calibration;
mod commander;
mod commands;
mod dvl_report;
mod faults;
mod frames;
mod gcs_failsafe;
mod gcs_watch;
mod geodesy;
mod goto;
mod guard;
mod ident;
mod ident_run;
mod inquiry;
pub mod joystick;
mod logs;
mod missions;
mod motor_test;
pub mod navigation;
mod options;
pub mod params;
pub mod params_file;
mod pending;
mod queries;
mod start;
mod sticks;
mod streams;
mod telemetry;
mod topside;
mod transport;
mod vehicle;
pub mod words;

pub use commander::{Commander, Verdict, COMMANDER_SILENCE};
pub use commands::{custom_mode_of_param, mode_name, refused_param};
pub use frames::split_text;
pub use geodesy::{item_position, GlobalOrigin};
pub use logs::{open_logs, utc_stamp};
pub use missions::MISSION_MAX_ITEMS;
pub use options::{SurfaceOptions, TopsideArgs};
pub use start::{main, start_with};
pub use sticks::{manual_thrust, sticks_centred, MANUAL_CONTROL_TIMEOUT, STICK_CENTRED};
pub use transport::{take_frames, GcsStats, StationId, POLL_LIMIT};
pub use vehicle::{check_telemetry, Vehicle, VehicleEnd, TETHER_TIMEOUT, VEHICLE_SILENCE};
