//! `host-sim topside`: the program at the surface. One side speaks the tether to the vehicle,
//! the other MAVLink 2 to ground stations (QGroundControl, MAVProxy, pymavlink), with
//! ArduSub's conventions so that existing tools map the vehicle's modes and sticks.
//!
//! The vehicle side today is `--sim SCENARIO`: the scenario's plant and navigation stage with
//! the firmware library's `App` in this process, reached through the tether protocol (the
//! same frames, state machine and failsafes as the image), or with `--emulated` the firmware
//! image itself in QEMU; in real time or `--speedup K` faster. The modes run on the vehicle:
//! the topside translates.
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
//! Every MAVLink message sent or received goes to a `.tlog` (each a big-endian 64-bit
//! microsecond UNIX time stamp followed by the MAVLink frame: what QGroundControl, MAVExplorer
//! and pymavlink read).

use crate::estimator_nav::navigation_for;
use crate::in_process::InProcessFirmware;
use crate::link::Link;
use crate::params::{self, Group, Settings, PARAMS};
use crate::plant::Plant;
use crate::qemu::{qemu_firmware_image, start_qemu_link, workspace_root, FirmwareImage};
use crate::scenario::Scenario;
use crate::sim_loop::{make_plant, nominal_plant_params, Navigation};
use anyhow::{anyhow, bail, Context, Result};
use controller_core::alloc::PwmMap;
use controller_core::params::VehicleParams;
use controller_core::reference::Reference;
use controller_core::state::NavState;
use firmware::protocol::{
    fault, Command, Law, ManualThrust, Mode, NackReason, NavSample, Plane, Reply, Telemetry,
};
use mavlink::dialects::ardupilotmega::{
    MavAutopilot, MavCmd, MavFrame, MavMessage, MavMissionResult, MavModeFlag, MavParamType,
    MavResult, MavSeverity, MavState, MavSysStatusSensor, MavType, ATTITUDE_DATA, COMMAND_ACK_DATA,
    GLOBAL_POSITION_INT_DATA, GPS_GLOBAL_ORIGIN_DATA, HEARTBEAT_DATA, LOCAL_POSITION_NED_DATA,
    MISSION_ACK_DATA, MISSION_COUNT_DATA, MISSION_CURRENT_DATA, MISSION_ITEM_INT_DATA,
    MISSION_ITEM_REACHED_DATA, MISSION_REQUEST_INT_DATA, PARAM_VALUE_DATA, SERVO_OUTPUT_RAW_DATA,
    STATUSTEXT_DATA, SYS_STATUS_DATA, VFR_HUD_DATA,
};
use mavlink::{MavConnection, MavHeader};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// ArduSub's custom mode numbers (`ArduSub/mode.h`).
pub mod ardusub_mode {
    /// Heading hold with the yaw stick centred.
    pub const STABILIZE: u32 = 0;
    /// Depth hold with the pilot steering.
    pub const ALT_HOLD: u32 = 2;
    /// The uploaded mission.
    pub const AUTO: u32 = 3;
    /// Go to and hold a point.
    pub const GUIDED: u32 = 4;
    /// Hold the position.
    pub const POSHOLD: u32 = 16;
    /// Sticks straight to the thrusters.
    pub const MANUAL: u32 = 19;
}

/// `host-sim topside` options.
#[derive(clap::Args, Debug, Clone)]
pub struct TopsideArgs {
    /// The simulated vehicle: a built-in scenario or a .toml file (its plant, navigation and
    /// start; the reference is not used: the ground station commands).
    #[arg(long, required_unless_present = "serial", conflicts_with = "serial")]
    pub sim: Option<String>,
    /// A real vehicle on this serial device (`/dev/ttyUSB0`): it runs on its own clock and
    /// navigates itself; the topside sends it heartbeats and the ground stations' commands.
    #[arg(long, value_name = "DEV", conflicts_with_all = ["emulated", "speedup"])]
    pub serial: Option<PathBuf>,
    /// With --serial: the baud rate.
    #[arg(long, default_value_t = 115_200, requires = "serial")]
    pub baud: u32,
    /// MAVLink address: udpout:HOST:PORT (to a ground station listening, QGroundControl's
    /// default 14550), udpin:HOST:PORT, tcpin:HOST:PORT, tcpout:HOST:PORT. Give it again
    /// for more ground stations: each gets everything the vehicle says, and any may command.
    #[arg(long, default_value = "udpout:127.0.0.1:14550")]
    pub mavlink: Vec<String>,
    /// Run the simulated vehicle this many times faster than real time.
    #[arg(long, default_value_t = 1.0)]
    pub speedup: f64,
    /// Stop after this much simulated time (s); default: run until stopped.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Where the .tlog goes.
    #[arg(long, default_value = "out/topside.tlog")]
    pub tlog: PathBuf,
    /// MAVLink system id of the vehicle.
    #[arg(long, default_value_t = 1)]
    pub system_id: u8,
    /// Run the vehicle's firmware image in QEMU (the emulated STM32F405, lock-step) instead of
    /// the firmware library in process; the plant stays simulated here.
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: this image (default: the workspace's `qemu` image, built if needed).
    #[arg(long, value_name = "ELF", requires = "emulated")]
    pub qemu: Option<PathBuf>,
    /// The parameters set from the ground station: restored from this file at start, saved
    /// to it after every accepted `PARAM_SET`.
    #[arg(long, default_value = "out/topside-params.json")]
    pub params: PathBuf,
    /// The vehicle's description (a vehicle file, `vehicles/observer.toml`'s format): sent
    /// to the vehicle at start, and the simulated vehicle's body. Default: the scenario's.
    #[arg(long)]
    pub vehicle: Option<PathBuf>,
    /// Where the raw tether log goes (every byte both ways, time-stamped; `tether_log`).
    /// Default: the `.tlog`'s path with the extension `.tether`.
    #[arg(long)]
    pub tether_log: Option<PathBuf>,
}

/// Most waypoints a mission may have (the vehicle's store).
pub const MISSION_MAX_ITEMS: usize = controller_core::reference::mission::MAX_WAYPOINTS;
/// An upload that waits this long for the next item asks again (5 times, then gives up).
const MISSION_RETRY: Duration = Duration::from_secs(1);

/// A mission item as the ground station sent it, and its waypoint in the local frame.
type ReceivedItem = (MISSION_ITEM_INT_DATA, [f32; 3]);

/// The mission protocol at the surface: uploads item by item to the vehicle, the mission in
/// use for downloads, and the progress reported in AUTO.
#[derive(Debug, Default)]
struct Missions {
    /// Upload in progress: items so far, the count announced, when the last request went and
    /// how many times it went.
    upload: Option<(Vec<ReceivedItem>, u16, Instant, u32)>,
    /// The mission the vehicle holds, as the ground station sent it.
    items: Vec<MISSION_ITEM_INT_DATA>,
    /// Waypoints reported reached in the current AUTO run.
    reached: u16,
    /// The ground station of the latest mission exchange (system, component): requests and
    /// acknowledgements are addressed to it, as ground stations check.
    peer: (u8, u8),
}

impl Missions {
    fn request(peer: (u8, u8), gcs: &mut Gcs, seq: u16) -> Result<()> {
        gcs.send(MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
            seq,
            target_system: peer.0,
            target_component: peer.1,
        }))
    }

    fn ack(peer: (u8, u8), gcs: &mut Gcs, result: MavMissionResult) -> Result<()> {
        gcs.send(MavMessage::MISSION_ACK(MISSION_ACK_DATA {
            target_system: peer.0,
            target_component: peer.1,
            mavtype: result,
        }))
    }

    /// Refuse the upload in progress with `result` and say why; the mission in use stays.
    fn refuse(&mut self, gcs: &mut Gcs, result: MavMissionResult, why: &str) -> Result<()> {
        self.upload = None;
        gcs.text(
            MavSeverity::MAV_SEVERITY_WARNING,
            &format!("Mission refused: {why}"),
        )?;
        Self::ack(self.peer, gcs, result)
    }

    /// A mission message from the ground station; false if `msg` is not one. `MISSION_REQUEST`
    /// is deprecated, but older ground stations still download with it: both are answered.
    #[allow(deprecated)]
    fn handle(
        &mut self,
        gcs: &mut Gcs,
        v: &mut SimVehicle,
        from: MavHeader,
        msg: &MavMessage,
    ) -> Result<bool> {
        if matches!(
            msg,
            MavMessage::MISSION_COUNT(_)
                | MavMessage::MISSION_REQUEST_LIST(_)
                | MavMessage::MISSION_CLEAR_ALL(_)
        ) {
            // (MAVLink system ids are 8 bits on the wire.)
            let system = u8::try_from(from.system_id).unwrap_or(u8::MAX);
            self.peer = (system, from.component_id);
        }
        match msg {
            MavMessage::MISSION_COUNT(c) => {
                if usize::from(c.count) > MISSION_MAX_ITEMS {
                    let why = format!("{} items, the vehicle holds {MISSION_MAX_ITEMS}", c.count);
                    return self
                        .refuse(gcs, MavMissionResult::MAV_MISSION_NO_SPACE, &why)
                        .map(|_| true);
                }
                if c.count == 0 {
                    return self.clear(gcs, v).map(|_| true);
                }
                self.upload = Some((Vec::new(), c.count, Instant::now(), 1));
                Self::request(self.peer, gcs, 0)?;
            }
            MavMessage::MISSION_ITEM_INT(item) => self.item(gcs, v, item)?,
            // The float form, which MAVProxy sends to a vehicle that does not announce
            // MISSION_INT in AUTOPILOT_VERSION: the same item, x and y in metres (local) or
            // degrees (global).
            MavMessage::MISSION_ITEM(i) => {
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
                let item = MISSION_ITEM_INT_DATA {
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
                };
                self.item(gcs, v, &item)?
            }
            MavMessage::MISSION_REQUEST_LIST(_) => {
                gcs.send(MavMessage::MISSION_COUNT(MISSION_COUNT_DATA {
                    count: self.items.len() as u16,
                    target_system: self.peer.0,
                    target_component: self.peer.1,
                }))?;
            }
            MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA { seq, .. })
            | MavMessage::MISSION_REQUEST(
                mavlink::dialects::ardupilotmega::MISSION_REQUEST_DATA { seq, .. },
            ) => match self.items.get(usize::from(*seq)) {
                Some(item) => gcs.send(MavMessage::MISSION_ITEM_INT(item.clone()))?,
                None => Self::ack(
                    self.peer,
                    gcs,
                    MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                )?,
            },
            MavMessage::MISSION_CLEAR_ALL(_) => self.clear(gcs, v)?,
            // The end of a download.
            MavMessage::MISSION_ACK(_) => {}
            _ => return Ok(false),
        }
        gcs.stats.handled += 1;
        Ok(true)
    }

    fn clear(&mut self, gcs: &mut Gcs, v: &mut SimVehicle) -> Result<()> {
        self.upload = None;
        match v.command(&Command::MissionClear)? {
            Ok(()) => {
                self.items.clear();
                Self::ack(self.peer, gcs, MavMissionResult::MAV_MISSION_ACCEPTED)
            }
            Err(why) => {
                gcs.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("Mission not cleared: {why:?} (leave AUTO first)"),
                )?;
                Self::ack(self.peer, gcs, MavMissionResult::MAV_MISSION_DENIED)
            }
        }
    }

    /// One uploaded item: checked, kept; the last one sends the whole mission to the vehicle.
    fn item(
        &mut self,
        gcs: &mut Gcs,
        v: &mut SimVehicle,
        item: &MISSION_ITEM_INT_DATA,
    ) -> Result<()> {
        let Some((items, count, at, tries)) = self.upload.as_mut() else {
            return Ok(());
        };
        let count = *count;
        if usize::from(item.seq) != items.len() {
            // Out of order (a lost or repeated item): ask for the one expected.
            *at = Instant::now();
            *tries += 1;
            return Self::request(self.peer, gcs, items.len() as u16);
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
        let max_depth = firmware::autopilot::MAX_MISSION_DEPTH_M;
        if !(0.0..=max_depth).contains(&depth) {
            let why = format!(
                "item {}: depth {depth} m is unreachable (0 to {max_depth} m)",
                item.seq
            );
            return self.refuse(gcs, R::MAV_MISSION_INVALID_PARAM7, &why);
        }
        items.push((item.clone(), pos_m));
        if items.len() < usize::from(count) {
            *at = Instant::now();
            *tries = 1;
            return Self::request(self.peer, gcs, items.len() as u16);
        }
        // Complete: to the vehicle, which replaces its mission only when the last one is in.
        let items = std::mem::take(items);
        for (i, (_, pos_m)) in items.iter().enumerate() {
            let cmd = Command::MissionItem {
                index: i as u16,
                count,
                pos_m: *pos_m,
                speed_m_s: v.settings.mission_speed_m_s,
            };
            if let Err(why) = v.command(&cmd)? {
                let why = format!("item {i} refused by the vehicle: {why:?}");
                return self.refuse(gcs, R::MAV_MISSION_INVALID, &why);
            }
        }
        self.upload = None;
        self.items = items.into_iter().map(|(item, _)| item).collect();
        gcs.text(
            MavSeverity::MAV_SEVERITY_INFO,
            &format!("Mission of {count} waypoints accepted"),
        )?;
        Self::ack(self.peer, gcs, R::MAV_MISSION_ACCEPTED)
    }

    /// Every control period: ask again for a late item; in AUTO, report the waypoints reached.
    fn tick(&mut self, gcs: &mut Gcs, tel: &Telemetry, every_second: bool) -> Result<()> {
        if let Some((items, _, at, tries)) = self.upload.as_mut() {
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
                Self::request(self.peer, gcs, next)?;
            }
        }
        if tel.mode != Mode::Auto {
            self.reached = 0;
            return Ok(());
        }
        while self.reached < tel.mission_reached {
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

/// Counters of the MAVLink side.
#[derive(Debug, Clone, Copy, Default)]
pub struct GcsStats {
    /// Messages received and understood.
    pub handled: u64,
    /// Messages received that the topside does not act on (ignored, counted).
    pub ignored: u64,
    /// Frames that failed to parse.
    pub malformed: u64,
    /// Messages sent.
    pub sent: u64,
}

/// The ground-station side: the MAVLink connections, the sequence number, the .tlog.
struct Gcs {
    conns: Vec<mavlink::Connection<MavMessage>>,
    system_id: u8,
    seq: u8,
    tlog: BufWriter<File>,
    stats: GcsStats,
    /// The origin of the local frame on the globe, once a ground station set it.
    origin: Option<GlobalOrigin>,
}

fn unix_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

impl Gcs {
    fn log(&mut self, header: MavHeader, msg: &MavMessage) -> Result<()> {
        let mut frame = Vec::with_capacity(300);
        mavlink::write_v2_msg(&mut frame, header, msg).map_err(|e| anyhow!("tlog: {e:?}"))?;
        self.tlog.write_all(&unix_us().to_be_bytes())?;
        self.tlog.write_all(&frame)?;
        Ok(())
    }

    fn send(&mut self, msg: MavMessage) -> Result<()> {
        let header = MavHeader {
            system_id: u32::from(self.system_id),
            component_id: 1,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        self.log(header, &msg)?;
        // A ground station that is not there yet (udpout before it listens) is not an error.
        for conn in &self.conns {
            if conn.send(&header, &msg).is_ok() {
                self.stats.sent += 1;
            }
        }
        Ok(())
    }

    /// A `STATUSTEXT`; a text longer than the message's 50 characters goes as several,
    /// split between words (this dialect's `STATUSTEXT` has no chunk fields).
    fn text(&mut self, severity: MavSeverity, text: &str) -> Result<()> {
        for line in split_text(text, 50) {
            self.send(MavMessage::STATUSTEXT(STATUSTEXT_DATA {
                severity,
                text: line.as_str().into(),
            }))?;
        }
        Ok(())
    }

    fn ack(&mut self, command: MavCmd, result: MavResult) -> Result<()> {
        self.send(MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command,
            result,
        }))
    }

    /// What has arrived on every connection, without waiting: at most [`POLL_LIMIT`]
    /// messages of each per control period, so that one ground station flooding (a
    /// `MANUAL_CONTROL` storm) neither stalls the tether loop nor crowds out another.
    fn poll(&mut self) -> Result<Vec<(MavHeader, MavMessage)>> {
        let mut out = Vec::new();
        for i in 0..self.conns.len() {
            for _ in 0..POLL_LIMIT {
                match self.conns[i].try_recv() {
                    Ok((header, msg)) => {
                        self.log(header, &msg)?;
                        out.push((header, msg));
                    }
                    Err(mavlink::error::MessageReadError::Io(e))
                        if matches!(
                            e.kind(),
                            std::io::ErrorKind::WouldBlock
                                | std::io::ErrorKind::TimedOut
                                // udpout to a port nobody listens on yet.
                                | std::io::ErrorKind::ConnectionRefused
                        ) =>
                    {
                        break
                    }
                    Err(mavlink::error::MessageReadError::Io(e)) => {
                        return Err(anyhow!("MAVLink connection: {e}"))
                    }
                    Err(_) => self.stats.malformed += 1,
                }
            }
        }
        Ok(out)
    }
}

/// Most MAVLink messages taken from one connection in one control period (10,000 a second
/// at 50 Hz); the rest waits in the socket, where a flood's excess is dropped by the OS.
pub const POLL_LIMIT: usize = 200;

/// The geodetic point of the local frame's origin (`SET_GPS_GLOBAL_ORIGIN`), on the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GlobalOrigin {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Altitude of the surface above mean sea level, metres.
    pub alt_m: f64,
}

impl GlobalOrigin {
    /// From `SET_GPS_GLOBAL_ORIGIN`'s integers (degrees x 1e7, millimetres); `None` off the
    /// globe.
    pub fn from_mavlink(lat_e7: i32, lon_e7: i32, alt_mm: i32) -> Option<Self> {
        let o = Self {
            lat_deg: f64::from(lat_e7) * 1e-7,
            lon_deg: f64::from(lon_e7) * 1e-7,
            alt_m: f64::from(alt_mm) * 1e-3,
        };
        ((-90.0..=90.0).contains(&o.lat_deg) && (-180.0..=180.0).contains(&o.lon_deg)).then_some(o)
    }

    /// Metres per radian north and east at the origin: the WGS-84 ellipsoid's meridian and
    /// prime-vertical radii of curvature (a local tangent plane, exact enough within the
    /// 1 km a mission may reach).
    fn radii_m(&self) -> (f64, f64) {
        const A: f64 = 6_378_137.0;
        const E2: f64 = 6.694_379_990_14e-3;
        let s = self.lat_deg.to_radians().sin();
        let w = (1.0 - E2 * s * s).sqrt();
        (A * (1.0 - E2) / (w * w * w), A / w)
    }

    /// North and east of the origin (m) of a latitude and longitude (degrees).
    pub fn to_local(&self, lat_deg: f64, lon_deg: f64) -> [f64; 2] {
        let (rn, re) = self.radii_m();
        let dlon = (lon_deg - self.lon_deg + 540.0).rem_euclid(360.0) - 180.0;
        [
            (lat_deg - self.lat_deg).to_radians() * rn,
            dlon.to_radians() * re * self.lat_deg.to_radians().cos(),
        ]
    }

    /// Latitude and longitude (degrees) of a point north and east of the origin (m).
    pub fn to_global(&self, north_m: f64, east_m: f64) -> [f64; 2] {
        let (rn, re) = self.radii_m();
        [
            self.lat_deg + (north_m / rn).to_degrees(),
            self.lon_deg + (east_m / (re * self.lat_deg.to_radians().cos())).to_degrees(),
        ]
    }
}

/// A mission item's waypoint as `[north, east, depth]` (m) in the local frame: local frames
/// carry metres x 1e4; global ones degrees x 1e7 and an altitude (negative below the
/// surface, ArduSub's convention), relative to the origin's or above mean sea level.
// The `_INT` frames are superseded by their plain names but still sent (QGroundControl's
// older releases, MAVProxy), so both are taken.
#[allow(deprecated)]
pub fn item_position(
    frame: MavFrame,
    x: i32,
    y: i32,
    z: f32,
    origin: Option<&GlobalOrigin>,
) -> std::result::Result<[f32; 3], String> {
    use MavFrame as F;
    let global = |o: Option<&GlobalOrigin>| {
        o.map(|o| o.to_local(f64::from(x) * 1e-7, f64::from(y) * 1e-7))
            .ok_or_else(|| format!("{frame:?} needs SET_GPS_GLOBAL_ORIGIN first"))
    };
    Ok(match frame {
        F::MAV_FRAME_LOCAL_NED => [x as f32 * 1e-4, y as f32 * 1e-4, z],
        F::MAV_FRAME_GLOBAL_RELATIVE_ALT | F::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => {
            let [n, e] = global(origin)?;
            [n as f32, e as f32, -z]
        }
        F::MAV_FRAME_GLOBAL | F::MAV_FRAME_GLOBAL_INT => {
            let [n, e] = global(origin)?;
            let surface = origin.map_or(0.0, |o| o.alt_m);
            [n as f32, e as f32, (surface - f64::from(z)) as f32]
        }
        other => {
            return Err(format!(
                "frame {other:?}: MAV_FRAME_LOCAL_NED or a global frame"
            ))
        }
    })
}

/// `text` in lines of at most `width` characters, broken at spaces where it can be.
pub fn split_text(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let mut word = word.to_string();
        while word.chars().count() > width {
            if !line.is_empty() {
                lines.push(std::mem::take(&mut line));
            }
            let head: String = word.chars().take(width).collect();
            word = word.chars().skip(width).collect();
            lines.push(head);
        }
        let extra = usize::from(!line.is_empty());
        if line.chars().count() + extra + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        } else if extra == 1 {
            line.push(' ');
        }
        line.push_str(&word);
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

/// The vehicle behind the tether: a simulated one (the plant and its navigation here, the
/// firmware in lock-step) or a real one on its own clock (`--serial`).
struct SimVehicle {
    /// The simulated body; `None` for a real vehicle.
    body: Option<Body>,
    link: Link,
    t_s: f64,
    period_s: f64,
    /// Control periods run.
    periods: u64,
    /// The vehicle's navigation state (a real vehicle's: from its telemetry).
    state: NavState,
    tel: Telemetry,
    /// The gains, timeouts and description in force on the vehicle (as last accepted).
    settings: Settings,
}

/// A simulated vehicle's body: plant, navigation, the ESCs' pulse curve.
struct Body {
    plant: Box<dyn Plant>,
    nav: Box<dyn Navigation>,
    pwm: PwmMap,
    plant_dt_s: f64,
    steps_per_period: usize,
    held_n: [f64; 3],
}

/// A real vehicle is sent a heartbeat every this many control periods (10 Hz): its
/// `HEARTBEAT_LOST` failsafe trips after 0.5 s without one.
const HEARTBEAT_EVERY: u64 = 5;

const TETHER_TIMEOUT: Duration = Duration::from_millis(500);

/// A `MANUAL_CONTROL` older than this (wall clock) is no longer forwarded.
pub const MANUAL_CONTROL_TIMEOUT: Duration = Duration::from_millis(500);

fn us(t_s: f64) -> u64 {
    (t_s * 1e6).round().max(0.0) as u64
}

impl SimVehicle {
    /// The scenario's plant and navigation with the firmware behind `port`, waiting up to
    /// `hello_wait` for its `Hello`.
    fn new(sc: &Scenario, port: Box<dyn crate::port::Port>, hello_wait: Duration) -> Result<Self> {
        let params = nominal_plant_params(sc);
        let plant = make_plant(
            sc.plane,
            &params,
            crate::plant::Environment {
                current_m_s: sc.disturbance.current_m_s,
            },
            sc.thrusters.saturate,
            sc.initial.to_plant(),
        )?;
        let nav = navigation_for(sc, None)?;
        let mut link = Link::new(port, None);
        link.wait_for(
            hello_wait,
            |r| matches!(r, Reply::Hello { .. }).then_some(()),
            |_| {},
        )?
        .ok_or_else(|| anyhow!("no Hello from the firmware"))?;
        let n = sc.plant_steps_per_control().max(1);
        let mut v = Self {
            body: Some(Body {
                plant,
                nav,
                pwm: PwmMap::for_vehicle(&sc.vehicle_model()?),
                plant_dt_s: sc.plant_dt_s,
                steps_per_period: n,
                held_n: [0.0; 3],
            }),
            link,
            t_s: 0.0,
            period_s: sc.plant_dt_s * n as f64,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings: Settings::new(sc.vehicle_params),
        };
        // The firmware boots with the Observer's description: send the scenario's.
        let vehicle = v.settings;
        if let Err(why) = v.apply(vehicle, Group::Vehicle)? {
            bail!("the vehicle refused the vehicle description: {why:?}");
        }
        v.step()?;
        Ok(v)
    }

    /// A real vehicle on `port`, running on its own clock: found by a heartbeat answered
    /// within 2 s. Its description is sent only when `vehicle` is given (a real vehicle
    /// keeps its own otherwise; the parameter list shows the Observer's until then).
    fn real(port: Box<dyn crate::port::Port>, vehicle: Option<VehicleParams>) -> Result<Self> {
        let mut link = Link::new(port, None);
        link.send(&Command::Heartbeat { t_us: 0 })?;
        let first = link
            .wait_for(
                Duration::from_secs(2),
                |r| match r {
                    Reply::Status(_) | Reply::Telemetry(_) | Reply::Hello { .. } => Some(Ok(())),
                    Reply::Nack { reason, .. } => Some(Err(*reason)),
                    Reply::Ack { .. } | Reply::Session { .. } => None,
                },
                |_| {},
            )?
            .ok_or_else(|| anyhow!("no answer from a vehicle on the serial port within 2 s"))?;
        if let Err(why) = first {
            bail!("the vehicle refused our heartbeat: {why:?} (another protocol version?)");
        }
        let mut v = Self {
            body: None,
            link,
            t_s: 0.0,
            period_s: 0.02,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings: Settings::new(vehicle.unwrap_or(VehicleParams::OBSERVER)),
        };
        if vehicle.is_some() {
            let s = v.settings;
            if let Err(why) = v.apply(s, Group::Vehicle)? {
                bail!("the vehicle refused the vehicle description: {why:?}");
            }
        }
        Ok(v)
    }

    /// Send one group of settings; on a refusal nothing changes, here or on the vehicle.
    fn apply(
        &mut self,
        proposed: Settings,
        group: Group,
    ) -> Result<std::result::Result<(), NackReason>> {
        let cmd = match group {
            Group::Tracking => Command::SetTrackingGains(proposed.gains.tracking),
            Group::Paper => Command::SetPaperGains {
                xz: proposed.gains.paper_xz,
                xy: proposed.gains.paper_xy,
            },
            Group::Failsafe => match proposed.failsafe.to_firmware() {
                Ok(f) => Command::SetFailsafe(f),
                Err(_) => return Ok(Err(NackReason::OutOfRange)),
            },
            Group::Vehicle => Command::SetVehicle(proposed.vehicle),
            Group::Mission => {
                // Nothing to send now: the next mission carries it.
                self.settings.mission_speed_m_s = proposed.mission_speed_m_s;
                return Ok(Ok(()));
            }
        };
        let r = self.command(&cmd)?;
        if r.is_ok() {
            let s = &mut self.settings;
            match group {
                Group::Tracking => s.gains.tracking = proposed.gains.tracking,
                Group::Paper => {
                    s.gains.paper_xz = proposed.gains.paper_xz;
                    s.gains.paper_xy = proposed.gains.paper_xy;
                }
                Group::Failsafe => s.failsafe = proposed.failsafe,
                Group::Vehicle => s.vehicle = proposed.vehicle,
                Group::Mission => s.mission_speed_m_s = proposed.mission_speed_m_s,
            }
        }
        Ok(r)
    }

    /// A command answered by `Ack` / `Nack`.
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.link.command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }

    /// One control period. Simulated: heartbeat and navigation to the firmware, its
    /// telemetry back, the plant through the period with the thrust of the pulse widths.
    /// Real: a heartbeat every [`HEARTBEAT_EVERY`] periods and whatever the vehicle said.
    fn step(&mut self) -> Result<()> {
        let t_us = us(self.t_s);
        let Some(body) = self.body.as_mut() else {
            if self.periods.is_multiple_of(HEARTBEAT_EVERY) {
                self.link.send(&Command::Heartbeat { t_us })?;
            }
            self.periods += 1;
            while let Some((_, reply)) = self.link.recv(Duration::ZERO)? {
                if let Reply::Telemetry(t) = reply {
                    self.tel = t;
                    self.state = t.nav;
                }
            }
            self.t_s += self.period_s;
            return Ok(());
        };
        self.state = body.state_at(self.t_s);
        self.link.send(&Command::Heartbeat { t_us })?;
        let nav_seq = self.link.send(&Command::Nav(NavSample {
            t_us,
            state: self.state,
        }))?;
        let tel = self
            .link
            .wait_for(
                TETHER_TIMEOUT,
                |r| match r {
                    Reply::Telemetry(tl) if tl.nav_seq == nav_seq => Some(*tl),
                    _ => None,
                },
                |_| {},
            )?
            .ok_or_else(|| anyhow!("tether: no Telemetry at t = {:.2} s", self.t_s))?;
        self.tel = tel;
        body.advance(self.t_s, &tel);
        self.t_s += self.period_s;
        Ok(())
    }
}

impl Body {
    /// What the simulated vehicle's navigation says at `t_s`.
    fn state_at(&mut self, t_s: f64) -> NavState {
        self.nav.estimate(t_s, self.held_n)
    }

    /// The plant through one control period from `t_s` under the telemetry's pulse widths.
    fn advance(&mut self, t_s: f64, tel: &Telemetry) {
        let applied = tel
            .pulse_us
            .map(|p| f64::from(self.pwm.thrust_n(f32::from(p))));
        for i in 0..self.steps_per_period {
            self.plant.step(applied, self.plant_dt_s);
            self.nav
                .observe(t_s + (i + 1) as f64 * self.plant_dt_s, &self.plant.state());
        }
        self.held_n = tel.thrust_n.map(f64::from);
    }
}

/// The ArduSub mode a firmware mode is shown as.
fn custom_mode_of(mode: Mode, guided: bool) -> u32 {
    match mode {
        Mode::Manual => ardusub_mode::MANUAL,
        Mode::Stabilize => ardusub_mode::STABILIZE,
        Mode::Auto => ardusub_mode::AUTO,
        Mode::DepthHold => ardusub_mode::ALT_HOLD,
        Mode::Hold => ardusub_mode::POSHOLD,
        Mode::Track { .. } if guided => ardusub_mode::GUIDED,
        Mode::Track { .. } => ardusub_mode::AUTO,
        Mode::Idle => ardusub_mode::MANUAL,
    }
}

/// `MANUAL_CONTROL` to normalized thrust, ArduSub's conventions: x forward and r clockwise in
/// -1000..1000, z 0..1000 with 500 neutral and above 500 up (our heave is positive down); y
/// (sway) has no thruster.
pub fn manual_thrust(x: i16, z: i16, r: i16) -> ManualThrust {
    let norm = |v: f32| (v / 1000.0).clamp(-1.0, 1.0);
    ManualThrust {
        surge: norm(f32::from(x)),
        yaw: norm(f32::from(r)),
        heave: -((f32::from(z) - 500.0) / 500.0).clamp(-1.0, 1.0),
    }
}

/// Names of the fault flags, for `STATUSTEXT`.
const FAULT_NAMES: [(u16, &str); 7] = [
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
];

/// Run the topside until `--duration` (or forever).
pub fn main(a: TopsideArgs) -> Result<()> {
    let vehicle_file = a.vehicle.as_deref().map(crate::vehicle::load).transpose()?;
    if !(a.speedup.is_finite() && a.speedup > 0.0) {
        bail!("--speedup must be > 0 (got {})", a.speedup);
    }
    let mut conns = Vec::new();
    for address in &a.mavlink {
        let mut conn = mavlink::connect::<MavMessage>(address)
            .with_context(|| format!("MAVLink address {address:?}"))?;
        // Send MAVLink 2, take 1 and 2: ground stations still send some messages in
        // MAVLink 1 (MAVProxy's mission items, for one).
        conn.set_allow_recv_any_version(true);
        conns.push(conn);
    }
    if let Some(dir) = a.tlog.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)?;
        }
    }
    let tlog = BufWriter::new(
        File::create(&a.tlog).with_context(|| format!("create {}", a.tlog.display()))?,
    );
    let mut gcs = Gcs {
        conns,
        system_id: a.system_id,
        seq: 0,
        tlog,
        stats: GcsStats::default(),
        origin: None,
    };
    let tether_log = a
        .tether_log
        .clone()
        .unwrap_or_else(|| a.tlog.with_extension("tether"));
    // The QEMU child lives as long as this guard.
    let mut _qemu = None;
    let (mut v, what) = if let Some(device) = &a.serial {
        let port = crate::port::serial_port(device, a.baud)?;
        let port = Box::new(crate::tether_log::LoggedPort::new(port, &tether_log)?);
        let v = SimVehicle::real(port, vehicle_file)?;
        (
            v,
            format!("vehicle on {} at {} Bd", device.display(), a.baud),
        )
    } else {
        let Some(sim) = &a.sim else {
            bail!("--sim SCENARIO or --serial DEV");
        };
        let mut sc = Scenario::load(sim)?;
        if let Some(p) = vehicle_file {
            sc.vehicle_params = p;
        }
        let (port, hello_wait, firmware): (Box<dyn crate::port::Port>, _, _) = if a.emulated {
            let elf = match a.qemu.clone() {
                Some(elf) => elf,
                None => match qemu_firmware_image(&workspace_root())? {
                    FirmwareImage::Ready(elf) => elf,
                    FirmwareImage::Unavailable(why) => {
                        bail!("the emulated board cannot run here: {why}")
                    }
                },
            };
            let (q, p) = start_qemu_link("qemu-system-arm", &elf, None, false)?;
            _qemu = Some(q);
            (
                p,
                Duration::from_secs(30),
                format!("firmware image {} in QEMU", elf.display()),
            )
        } else {
            (
                Box::new(InProcessFirmware::new()?),
                Duration::from_secs(2),
                "firmware library in process".to_string(),
            )
        };
        let port = Box::new(crate::tether_log::LoggedPort::new(port, &tether_log)?);
        let v = SimVehicle::new(&sc, port, hello_wait)?;
        let what = format!(
            "simulated vehicle {:?} ({}), {firmware}",
            sc.name,
            sc.plane.as_str()
        );
        (v, what)
    };
    if a.params.exists() {
        let saved = params::load(&a.params, v.settings)?;
        for group in params::GROUPS {
            if let Err(why) = v.apply(saved, group)? {
                bail!(
                    "the vehicle refused the saved parameters of {}: {why:?}",
                    a.params.display()
                );
            }
        }
        eprintln!("topside: parameters restored from {}", a.params.display());
    }
    eprintln!(
        "topside: {what}, MAVLink on {}, tlog {}",
        a.mavlink.join(", "),
        a.tlog.display()
    );

    let wall0 = Instant::now();
    let mut manual = ManualThrust::default();
    // Wall time of the latest MANUAL_CONTROL: the pilot's stream is real time.
    let mut manual_at: Option<Instant> = None;
    let mut guided = false;
    let mut missions = Missions::default();
    let mut last_faults = 0u16;
    let mut k: u64 = 0;
    let per_second = (1.0 / v.period_s).round().max(1.0) as u64;
    let per_tenth = (per_second / 10).max(1);
    loop {
        if let Some(d) = a.duration {
            if v.t_s >= d {
                break;
            }
        }
        // Pace: simulated time runs `speedup` times the wall clock.
        let due = wall0 + Duration::from_secs_f64(v.t_s / a.speedup);
        if let Some(wait) = due.checked_duration_since(Instant::now()) {
            std::thread::sleep(wait);
        }

        for (header, msg) in gcs.poll()? {
            if matches!(msg, MavMessage::MANUAL_CONTROL(_)) {
                manual_at = Some(Instant::now());
            }
            if !missions.handle(&mut gcs, &mut v, header, &msg)? {
                handle(&mut gcs, &mut v, &mut manual, &mut guided, &a.params, msg)?;
            }
        }
        let fresh = manual_at.is_some_and(|at| at.elapsed() < MANUAL_CONTROL_TIMEOUT);
        let pilot_mode = matches!(v.tel.mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold);
        if pilot_mode && v.tel.armed && fresh {
            // Forwarded every period while the pilot's stream lives; when it stops, nothing
            // is forwarded and the firmware's MANUAL_STALE failsafe neutralizes the thrusters.
            v.link.send(&Command::ManualThrust(manual))?;
        }
        v.step()?;

        let faults = v.tel.faults & !fault::SATURATED;
        for (bit, name) in FAULT_NAMES {
            if faults & bit != 0 && last_faults & bit == 0 {
                gcs.text(
                    MavSeverity::MAV_SEVERITY_CRITICAL,
                    &format!("Failsafe: {name}"),
                )?;
            } else if faults & bit == 0 && last_faults & bit != 0 {
                gcs.text(MavSeverity::MAV_SEVERITY_INFO, &format!("Cleared: {name}"))?;
            }
        }
        last_faults = faults;

        missions.tick(&mut gcs, &v.tel, k.is_multiple_of(per_second))?;
        if k.is_multiple_of(per_second) {
            send_heartbeat(&mut gcs, &v, guided)?;
        }
        if k.is_multiple_of(per_tenth) {
            send_state(&mut gcs, &v)?;
        }
        k += 1;
        if let Err(e) = gcs.tlog.flush() {
            bail!("tlog: {e}");
        }
    }
    let s = gcs.stats;
    eprintln!(
        "topside: {:.1} s simulated; MAVLink {} sent, {} handled, {} ignored, {} malformed",
        v.t_s, s.sent, s.handled, s.ignored, s.malformed
    );
    Ok(())
}

fn refuse(gcs: &mut Gcs, cmd: MavCmd, why: &str) -> Result<()> {
    gcs.text(MavSeverity::MAV_SEVERITY_WARNING, why)?;
    gcs.ack(cmd, MavResult::MAV_RESULT_DENIED)
}

fn set_mode(gcs: &mut Gcs, v: &mut SimVehicle, guided: &mut bool, custom: u32) -> Result<()> {
    let cmd = MavCmd::MAV_CMD_DO_SET_MODE;
    let (firmware_mode, reference) = match custom {
        ardusub_mode::MANUAL => (Mode::Manual, None),
        ardusub_mode::STABILIZE => (Mode::Stabilize, None),
        ardusub_mode::ALT_HOLD => (Mode::DepthHold, None),
        ardusub_mode::POSHOLD => (Mode::Hold, None),
        ardusub_mode::GUIDED => (
            Mode::Track {
                plane: Plane::ThreeD,
                law: Law::Tracking,
            },
            Some(Reference::Hold {
                pos_m: [v.state.x_m, v.state.y_m, v.state.z_m],
            }),
        ),
        ardusub_mode::AUTO => (Mode::Auto, None),
        other => return refuse(gcs, cmd, &format!("Unknown mode {other}")),
    };
    if let Some(reference) = reference {
        if let Err(why) = v.command(&Command::SetReference {
            reference,
            start_us: None,
        })? {
            return refuse(gcs, cmd, &format!("Reference refused: {why:?}"));
        }
    }
    match v.command(&Command::SetMode(firmware_mode))? {
        Ok(()) => {
            *guided = custom == ardusub_mode::GUIDED;
            gcs.ack(cmd, MavResult::MAV_RESULT_ACCEPTED)
        }
        Err(why) => refuse(gcs, cmd, &format!("Mode refused: {why:?}")),
    }
}

// `SET_MODE` is deprecated in favour of `MAV_CMD_DO_SET_MODE`, but pymavlink's `set_mode` and
// MAVProxy's `mode` still send it, so both are obeyed.
#[allow(deprecated)]
fn handle(
    gcs: &mut Gcs,
    v: &mut SimVehicle,
    manual: &mut ManualThrust,
    guided: &mut bool,
    params_file: &std::path::Path,
    msg: MavMessage,
) -> Result<()> {
    match msg {
        MavMessage::PARAM_REQUEST_LIST(_) => {
            gcs.stats.handled += 1;
            for i in 0..PARAMS.len() {
                send_param(gcs, &v.settings, i)?;
            }
        }
        MavMessage::PARAM_REQUEST_READ(r) => {
            gcs.stats.handled += 1;
            let index = if r.param_index >= 0 {
                Some(r.param_index as usize).filter(|&i| i < PARAMS.len())
            } else {
                params::find(param_name(&r.param_id).as_str()).map(|(i, _)| i)
            };
            match index {
                Some(i) => send_param(gcs, &v.settings, i)?,
                None => gcs.text(MavSeverity::MAV_SEVERITY_WARNING, "No such parameter")?,
            }
        }
        MavMessage::PARAM_SET(p) => {
            gcs.stats.handled += 1;
            let name = param_name(&p.param_id);
            let Some((i, param)) = params::find(&name) else {
                gcs.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    &format!("No parameter {name}"),
                )?;
                return Ok(());
            };
            let mut proposed = v.settings;
            (param.set)(&mut proposed, p.param_value);
            let group = params::group(param);
            // The checks the vehicle makes, here first (a clear reason), then the vehicle's.
            let refusal = match proposed.check(group) {
                // The reason without the name said twice.
                Err(e) => Some(format!(
                    "{name} refused: {}",
                    format!("{e:#}").replacen(&format!("{name} "), "", 1)
                )),
                Ok(()) => match v.apply(proposed, group)? {
                    Ok(()) => None,
                    Err(why) => Some(format!("{name} refused by the vehicle: {why:?}")),
                },
            };
            match refusal {
                Some(text) => gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?,
                None => params::save(params_file, &v.settings)?,
            }
            // The answer is the value in force: the new one, or the old one on a refusal.
            send_param(gcs, &v.settings, i)?;
        }
        MavMessage::COMMAND_LONG(c) => {
            gcs.stats.handled += 1;
            match c.command {
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM => {
                    let cmd = if c.param1 >= 0.5 {
                        Command::Arm
                    } else {
                        Command::Disarm
                    };
                    match v.command(&cmd)? {
                        Ok(()) => gcs.ack(c.command, MavResult::MAV_RESULT_ACCEPTED)?,
                        Err(why) => refuse(gcs, c.command, &format!("Arming refused: {why:?}"))?,
                    }
                }
                MavCmd::MAV_CMD_DO_SET_MODE => set_mode(gcs, v, guided, c.param2 as u32)?,
                other => {
                    gcs.ack(other, MavResult::MAV_RESULT_UNSUPPORTED)?;
                }
            }
        }
        MavMessage::SET_MODE(m) => {
            gcs.stats.handled += 1;
            set_mode(gcs, v, guided, m.custom_mode)?;
        }
        MavMessage::MANUAL_CONTROL(m) => {
            gcs.stats.handled += 1;
            *manual = manual_thrust(m.x, m.z, m.r);
        }
        MavMessage::SET_GPS_GLOBAL_ORIGIN(o) => {
            gcs.stats.handled += 1;
            match GlobalOrigin::from_mavlink(o.latitude, o.longitude, o.altitude) {
                Some(origin) => {
                    gcs.origin = Some(origin);
                    gcs.text(
                        MavSeverity::MAV_SEVERITY_INFO,
                        &format!("Origin set: {:.7}, {:.7}", origin.lat_deg, origin.lon_deg),
                    )?;
                    // ArduPilot answers with the origin in force.
                    gcs.send(MavMessage::GPS_GLOBAL_ORIGIN(GPS_GLOBAL_ORIGIN_DATA {
                        latitude: o.latitude,
                        longitude: o.longitude,
                        altitude: o.altitude,
                    }))?;
                }
                None => gcs.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "Origin refused: latitude or longitude off the globe",
                )?,
            }
        }
        MavMessage::SET_POSITION_TARGET_LOCAL_NED(p) => {
            gcs.stats.handled += 1;
            let pos = [p.x, p.y, p.z];
            if !*guided {
                gcs.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "Position target ignored: not in GUIDED",
                )?;
            } else if pos.iter().all(|x| x.is_finite()) {
                if let Err(why) = v.command(&Command::SetReference {
                    reference: Reference::Hold { pos_m: pos },
                    start_us: None,
                })? {
                    gcs.text(
                        MavSeverity::MAV_SEVERITY_WARNING,
                        &format!("Target refused: {why:?}"),
                    )?;
                }
            } else {
                gcs.text(
                    MavSeverity::MAV_SEVERITY_WARNING,
                    "Target refused: not finite",
                )?;
            }
        }
        _ => gcs.stats.ignored += 1,
    }
    Ok(())
}

/// A `param_id` as text (NUL-padded to 16 bytes on the wire).
fn param_name(id: &mavlink::types::CharArray<16>) -> String {
    id.iter()
        .take_while(|&&b| b != 0)
        .map(|&b| char::from(b))
        .collect()
}

fn send_param(gcs: &mut Gcs, settings: &Settings, index: usize) -> Result<()> {
    let Some(p) = PARAMS.get(index) else {
        return Ok(());
    };
    gcs.send(MavMessage::PARAM_VALUE(PARAM_VALUE_DATA {
        param_value: (p.get)(settings),
        param_count: PARAMS.len() as u16,
        param_index: index as u16,
        param_id: p.name.into(),
        param_type: MavParamType::MAV_PARAM_TYPE_REAL32,
    }))
}

fn send_heartbeat(gcs: &mut Gcs, v: &SimVehicle, guided: bool) -> Result<()> {
    let mut base = MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED;
    if v.tel.armed {
        base |= MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED;
    }
    gcs.send(MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: custom_mode_of(v.tel.mode, guided),
        mavtype: MavType::MAV_TYPE_SUBMARINE,
        autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
        base_mode: base,
        system_status: if v.tel.armed {
            MavState::MAV_STATE_ACTIVE
        } else {
            MavState::MAV_STATE_STANDBY
        },
        mavlink_version: 3,
    }))?;
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
    let drops = v.link.stats.frames_dropped.min(u64::from(u16::MAX)) as u16;
    gcs.send(MavMessage::SYS_STATUS(SYS_STATUS_DATA {
        onboard_control_sensors_present: sensors,
        onboard_control_sensors_enabled: sensors,
        onboard_control_sensors_health: healthy,
        errors_comm: drops,
        battery_remaining: -1,
        ..Default::default()
    }))
}

fn send_state(gcs: &mut Gcs, v: &SimVehicle) -> Result<()> {
    let s = &v.state;
    let time_boot_ms = (v.t_s * 1000.0) as u32;
    let (sp, cp) = s.yaw_rad.sin_cos();
    let vn = cp * s.u_m_s - sp * s.v_m_s;
    let ve = sp * s.u_m_s + cp * s.v_m_s;
    gcs.send(MavMessage::ATTITUDE(ATTITUDE_DATA {
        time_boot_ms,
        roll: s.roll_rad,
        pitch: s.pitch_rad,
        yaw: s.yaw_rad,
        rollspeed: s.p_rad_s,
        pitchspeed: s.q_rad_s,
        yawspeed: s.r_rad_s,
    }))?;
    gcs.send(MavMessage::LOCAL_POSITION_NED(LOCAL_POSITION_NED_DATA {
        time_boot_ms,
        x: s.x_m,
        y: s.y_m,
        z: s.z_m,
        vx: vn,
        vy: ve,
        vz: s.w_m_s,
    }))?;
    let heading_deg = s.yaw_rad.to_degrees().rem_euclid(360.0);
    gcs.send(MavMessage::VFR_HUD(VFR_HUD_DATA {
        airspeed: s.u_m_s.abs(),
        groundspeed: (vn * vn + ve * ve).sqrt(),
        alt: -s.z_m,
        climb: -s.w_m_s,
        heading: heading_deg.round() as i16,
        throttle: 0,
    }))?;
    if let Some(o) = &gcs.origin {
        // On the map: the local position on the globe, depth as negative altitude.
        let [lat, lon] = o.to_global(f64::from(s.x_m), f64::from(s.y_m));
        gcs.send(MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            time_boot_ms,
            lat: (lat * 1e7).round() as i32,
            lon: (lon * 1e7).round() as i32,
            alt: ((o.alt_m - f64::from(s.z_m)) * 1e3).round() as i32,
            relative_alt: (-s.z_m * 1e3).round() as i32,
            vx: (vn * 100.0).round() as i16,
            vy: (ve * 100.0).round() as i16,
            vz: (s.w_m_s * 100.0).round() as i16,
            hdg: (heading_deg * 100.0).round() as u16 % 36000,
        }))?;
    }
    let [p1, p2, p3] = v.tel.pulse_us;
    gcs.send(MavMessage::SERVO_OUTPUT_RAW(SERVO_OUTPUT_RAW_DATA {
        time_usec: (v.t_s * 1e6) as u32,
        servo1_raw: p1,
        servo2_raw: p2,
        servo3_raw: p3,
        ..Default::default()
    }))
}
