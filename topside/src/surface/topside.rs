//! The surface program's state and its loop: the ground stations, the vehicle behind the
//! tether, who commands, the missions, the pilot's sticks and the mode shown. The handlers
//! of each kind of message extend [`Topside`] in their own files (`commands`, `goto`,
//! `calibration`, `ident`, `motor_test`, ...).

use super::commander::{Commander, Verdict};
use super::gcs_watch::GcsWatch;
use super::geodesy::GlobalOrigin;
use super::ident_run::IdentRun;
use super::missions::Missions;
use super::options::SurfaceOptions;
use super::pending::Pending;
use super::sticks::{manual_thrust, sticks_centred, MANUAL_CONTROL_TIMEOUT};
use super::transport::{Gcs, StationId};
use super::vehicle::Vehicle;
use super::{faults, joystick, missions, navigation, params, streams, telemetry};
use anyhow::Result;
use mavlink::dialects::ardupilotmega::{
    MavCmd, MavMessage, MavMissionResult, MavResult, MavSeverity, GPS_GLOBAL_ORIGIN_DATA,
};
use mavlink::MavHeader;
use protocol::{fault, Command, ManualThrust, Mode};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Depth rate (positive down) of a navigation state: the body's velocities turned by roll
/// and pitch.
pub(super) fn depth_rate_m_s(s: &controller_core::state::NavState) -> f32 {
    let (sp, cp) = s.pitch_rad.sin_cos();
    let (sr, cr) = s.roll_rad.sin_cos();
    -s.u_m_s * sp + s.v_m_s * sr * cp + s.w_m_s * cr * cp
}

/// A sender's MAVLink system and component ids (8 bits on the wire).
pub(super) fn peer_of(header: MavHeader) -> (u8, u8) {
    (
        u8::try_from(header.system_id).unwrap_or(u8::MAX),
        header.component_id,
    )
}

/// The topside's state: the ground stations, the vehicle behind the tether, who commands,
/// the missions, the pilot's sticks and the mode shown.
pub(super) struct Topside {
    pub(super) gcs: Gcs,
    pub(super) v: Vehicle,
    pub(super) commander: Commander,
    pub(super) missions: Missions,
    /// The commander's latest sticks, and when they came (wall clock: the pilot's stream is
    /// real time).
    pub(super) manual: ManualThrust,
    pub(super) manual_at: Option<Instant>,
    /// The point GUIDED holds or goes to (`POSITION_TARGET_LOCAL_NED`): the latest one the
    /// vehicle took from this surface (none after a restart until one is sent).
    pub(super) guided_target: Option<[f32; 3]>,
    /// The streamed messages' rates, each station's own where it set one.
    pub(super) streams: streams::Streams,
    /// The faults last reported (`STATUSTEXT` on each change).
    pub(super) last_faults: u16,
    /// Where accepted parameters are saved.
    pub(super) params_file: PathBuf,
    /// The compass calibration turn's outcome last reported (`calibration.rs`).
    pub(super) mag_cal: Option<firmware::compass_swing::SwingOutcome>,
    /// The commander's sticks have been seen at centre since the last arm, mode change or
    /// change of commander: until then the vehicle is sent centred sticks.
    pub(super) sticks_seen_centred: bool,
    /// Saved parameters the vehicle did not take at start, applied when it does.
    pub(super) pending: Pending,
    /// The vehicle was last said to be silent.
    pub(super) vehicle_silent: bool,
    /// Telemetry refusals already said.
    pub(super) refusals_said: u64,
    /// The vehicle's navigation from the surface: its estimator's start, the USBL's fixes.
    pub(super) nav: navigation::SurfaceNav,
    /// The identification manoeuvre flying, as the surface follows it.
    pub(super) ident: Option<IdentRun>,
    /// The joystick gain the sticks are scaled by (`JS_GAIN_*`).
    pub(super) js_gain: f32,
    /// The commander's buttons: what was held, the stream's sequence numbers.
    pub(super) buttons: joystick::ButtonState,
    /// The end of the motor test's window (simulated or vehicle seconds) and its request,
    /// while one runs.
    pub(super) motor_test_until: Option<(f64, protocol::MotorTest)>,
    /// The ground stations' heartbeat, for `FS_GCS_*`.
    pub(super) gcs_watch: GcsWatch,
    /// The time of validity of the last DVL report sent to the stations (`dvl_report`).
    pub(super) dvl_sent_us: u64,
}

impl Topside {
    pub(super) fn run(&mut self, a: &SurfaceOptions, speedup: f64) -> Result<()> {
        let wall0 = Instant::now();
        let mut k: u64 = 0;
        let per_second = (1.0 / self.v.period_s).round().max(1.0) as u64;
        loop {
            if let Some(d) = a.duration {
                if self.v.t_s >= d {
                    break;
                }
            }
            // Pace: simulated time runs `speedup` times the wall clock.
            let due = wall0 + Duration::from_secs_f64(self.v.t_s / speedup);
            if let Some(wait) = due.checked_duration_since(Instant::now()) {
                std::thread::sleep(wait);
            }

            for (station, header, msg, mission_type) in self.gcs.poll()? {
                self.on_message(station, header, msg, mission_type)?;
            }
            for (station, header, item) in std::mem::take(&mut self.gcs.unknown_items) {
                self.on_unknown_item(station, header, item)?;
            }
            let before = self.commander.holder();
            self.commander.tick(&mut self.gcs)?;
            self.after_control_change(before)?;

            self.watch_gcs()?;
            let fresh = self
                .manual_at
                .is_some_and(|at| at.elapsed() < MANUAL_CONTROL_TIMEOUT);
            let holding = self
                .gcs_watch
                .holding_depth(self.v.settings.surface.gcs_failsafe());
            let v = &mut self.v;
            let pilot_mode = matches!(v.tel.mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold);
            if pilot_mode && v.tel.armed && (fresh || holding) && k.is_multiple_of(v.stride) {
                // Forwarded every period (every stride of the topside layout's finer loop)
                // while the pilot's stream lives, centred until the commander's sticks were
                // seen at centre; when it stops, nothing is forwarded and the firmware's
                // MANUAL_STALE failsafe neutralizes the thrusters.
                // The ground station failsafe's depth hold: centred.
                let mut sticks = if self.sticks_seen_centred && fresh {
                    self.manual
                } else {
                    ManualThrust::default()
                };
                if v.tel.mode == Mode::DepthHold {
                    // At most PILOT_SPEED_UP / PILOT_SPEED_DN, as ArduSub's ALT_HOLD.
                    sticks.heave = v
                        .settings
                        .surface
                        .limit_heave(sticks.heave, depth_rate_m_s(&v.state));
                }
                v.send(&Command::ManualThrust(sticks))?;
            }
            v.step()?;
            for text in self.nav.tick(&mut self.v)? {
                eprintln!("topside: {text}");
                self.gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
            }
            self.poll_mag_cal()?;
            self.poll_motor_test()?;
            self.poll_ident()?;
            self.watch_vehicle(k.is_multiple_of(per_second))?;

            let faults = self.v.tel.faults & !fault::SATURATED;
            faults::report(&mut self.gcs, faults, self.last_faults)?;
            self.last_faults = faults;

            self.missions
                .tick(&mut self.gcs, &self.v.tel, k.is_multiple_of(per_second))?;
            self.send_streams(k)?;
            self.forward_dvl()?;
            if self.guided() && k.is_multiple_of(per_second) {
                self.send_position_target()?;
            }
            k += 1;
            self.gcs.flush()?;
        }
        let s = self.gcs.stats;
        eprintln!(
            "topside: {:.1} s simulated; MAVLink {} sent, {} handled, {} ignored, {} malformed, \
             {} addressed to another system or component, {} disconnects; {} commands refused \
             and {} MANUAL_CONTROL ignored from stations not in control, {} takeovers \
             refused; {} vehicle frames refused",
            self.v.t_s,
            s.sent,
            s.handled,
            s.ignored,
            s.malformed,
            s.not_ours,
            s.disconnects,
            self.commander.refused,
            self.commander.manual_ignored,
            self.commander.takeovers_refused,
            self.v.frames_refused
        );
        let u = self.nav.stats;
        if u.sentences > 0 {
            eprintln!(
                "topside: USBL {} sentences, {} fixes relayed, {} bad, {} head-up, {} untimed; \
                 {} estimator starts",
                u.sentences, u.relayed, u.bad, u.head_up, u.untimed, self.nav.starts
            );
        }
        Ok(())
    }

    /// When control changed hands: the old commander's sticks and upload are dropped.
    pub(super) fn after_control_change(&mut self, before: Option<StationId>) -> Result<()> {
        let now = self.commander.holder();
        if now == before {
            return Ok(());
        }
        self.manual = ManualThrust::default();
        self.manual_at = None;
        self.buttons.forget();
        self.sticks_seen_centred = false;
        self.v.outputs_changed();
        if self.missions.uploader().is_some_and(|u| Some(u) != now) {
            self.missions
                .abandon(&mut self.gcs, "control changed during the upload")?;
        }
        Ok(())
    }

    /// One message from `station`: ignored if addressed to another system or component,
    /// else arbitrated, then handled.
    // (The deprecated MISSION_ITEM is still sent by ground stations.)
    #[allow(deprecated)]
    pub(super) fn on_message(
        &mut self,
        station: StationId,
        header: MavHeader,
        msg: MavMessage,
        mission_type: u8,
    ) -> Result<()> {
        if self.addressed_elsewhere(station, &msg) {
            return Ok(());
        }
        let before = self.commander.holder();
        let passkey = self.v.settings.passkey();
        let verdict =
            self.commander
                .judge(&mut self.gcs, station, header, &msg, passkey.as_deref())?;
        self.after_control_change(before)?;
        if let Verdict::Refuse(holder) = verdict {
            return self.refuse_station(station, header, holder, &msg);
        }
        if matches!(msg, MavMessage::CHANGE_OPERATOR_CONTROL(_)) {
            return Ok(());
        }
        // The buttons act after the frame's sticks are taken (an arm checks them).
        let buttons = match &msg {
            MavMessage::MANUAL_CONTROL(m) => Some((
                m.buttons,
                self.manual_at
                    .is_some_and(|at| at.elapsed() < MANUAL_CONTROL_TIMEOUT),
            )),
            _ => None,
        };
        if matches!(msg, MavMessage::HEARTBEAT(_)) {
            self.gcs_watch.heard();
        }
        if let MavMessage::MANUAL_CONTROL(m) = &msg {
            self.manual_at = Some(Instant::now());
            if sticks_centred(&manual_thrust(m.x, m.z, m.r)) {
                self.sticks_seen_centred = true;
            }
        }
        // A guided mission item (MAVProxy's `guided`, `current` = 2) is a go-to, not a
        // mission upload.
        match &msg {
            MavMessage::MISSION_ITEM_INT(i) if i.current == 2 => {
                return self.guided_item(station, peer_of(header), i)
            }
            MavMessage::MISSION_ITEM(i) if i.current == 2 => {
                return self.guided_item(station, peer_of(header), &missions::int_item(i))
            }
            _ => {}
        }
        if !self.missions.handle(
            &mut self.gcs,
            &mut self.v,
            station,
            header,
            &msg,
            mission_type,
        )? {
            self.handle(station, msg)?;
        }
        if let Some((pressed, live)) = buttons {
            self.on_buttons(station, header.sequence, pressed, live)?;
        }
        Ok(())
    }

    /// A command from a station not in control: refused with the reason, nothing changes.
    // (The deprecated SET_MODE and MISSION_ITEM are still sent by ground stations.)
    #[allow(deprecated)]
    pub(super) fn refuse_station(
        &mut self,
        station: StationId,
        header: MavHeader,
        holder: StationId,
        msg: &MavMessage,
    ) -> Result<()> {
        let gcs = &mut self.gcs;
        if matches!(msg, MavMessage::MANUAL_CONTROL(_)) {
            // Counted and noted by the commander.
            gcs.stats.ignored += 1;
            return Ok(());
        }
        gcs.stats.handled += 1;
        let why = format!(
            "{} has control (CHANGE_OPERATOR_CONTROL to take it)",
            gcs.label(holder)
        );
        let warn = MavSeverity::MAV_SEVERITY_WARNING;
        let rejected = MavResult::MAV_RESULT_TEMPORARILY_REJECTED;
        match msg {
            MavMessage::COMMAND_LONG(c) => {
                gcs.text_to(station, warn, &format!("Command refused: {why}"))?;
                gcs.ack(station, c.command, rejected)
            }
            MavMessage::COMMAND_INT(c) => {
                gcs.text_to(station, warn, &format!("Command refused: {why}"))?;
                gcs.ack(station, c.command, rejected)
            }
            MavMessage::SET_MODE(_) => {
                gcs.text_to(station, warn, &format!("Mode refused: {why}"))?;
                gcs.ack(station, MavCmd::MAV_CMD_DO_SET_MODE, rejected)
            }
            MavMessage::PARAM_SET(p) => {
                let name = telemetry::param_name(&p.param_id);
                gcs.text_to(station, warn, &format!("{name} refused: {why}"))?;
                match params::find(&name) {
                    Some((i, _)) => telemetry::send_param(gcs, &self.v.settings, i, Some(station)),
                    None => Ok(()),
                }
            }
            MavMessage::MISSION_COUNT(_)
            | MavMessage::MISSION_ITEM(_)
            | MavMessage::MISSION_ITEM_INT(_)
            | MavMessage::MISSION_CLEAR_ALL(_) => {
                let peer = (
                    station,
                    u8::try_from(header.system_id).unwrap_or(u8::MAX),
                    header.component_id,
                );
                Missions::deny(gcs, peer, MavMissionResult::MAV_MISSION_DENIED, &why)
            }
            _ => gcs.text_to(station, warn, &format!("Refused: {why}")),
        }
    }

    pub(super) fn refuse(&mut self, station: StationId, cmd: MavCmd, why: &str) -> Result<()> {
        self.gcs
            .text_to(station, MavSeverity::MAV_SEVERITY_WARNING, why)?;
        self.gcs.ack(station, cmd, MavResult::MAV_RESULT_DENIED)
    }

    // `SET_MODE` is deprecated in favour of `MAV_CMD_DO_SET_MODE`, but pymavlink's
    // `set_mode` and MAVProxy's `mode` still send it, so both are obeyed.
    #[allow(deprecated)]
    pub(super) fn handle(&mut self, station: StationId, msg: MavMessage) -> Result<()> {
        let warn = MavSeverity::MAV_SEVERITY_WARNING;
        match msg {
            MavMessage::PARAM_REQUEST_LIST(_) => {
                self.gcs.stats.handled += 1;
                for i in 0..params::count() {
                    telemetry::send_param(&mut self.gcs, &self.v.settings, i, Some(station))?;
                }
            }
            MavMessage::PARAM_REQUEST_READ(r) => {
                self.gcs.stats.handled += 1;
                let index = if r.param_index >= 0 {
                    Some(r.param_index as usize).filter(|&i| i < params::count())
                } else {
                    params::find(telemetry::param_name(&r.param_id).as_str()).map(|(i, _)| i)
                };
                match index {
                    Some(i) => {
                        telemetry::send_param(&mut self.gcs, &self.v.settings, i, Some(station))?
                    }
                    None => self.gcs.text_to(station, warn, "No such parameter")?,
                }
            }
            MavMessage::PARAM_SET(p) => self.param_set(station, &p)?,
            MavMessage::COMMAND_LONG(c) => self.command_long(station, c)?,
            MavMessage::COMMAND_INT(c) => self.command_int(station, c)?,
            MavMessage::SET_MODE(m) => {
                self.gcs.stats.handled += 1;
                self.set_mode(station, m.custom_mode)?;
            }
            MavMessage::MANUAL_CONTROL(m) => {
                self.gcs.stats.handled += 1;
                // Scaled by the joystick gain, as ArduSub scales every axis.
                let g = self.js_gain;
                let t = manual_thrust(m.x, m.z, m.r);
                self.manual = ManualThrust {
                    surge: t.surge * g,
                    yaw: t.yaw * g,
                    heave: t.heave * g,
                };
            }
            MavMessage::SET_GPS_GLOBAL_ORIGIN(o) => {
                self.gcs.stats.handled += 1;
                match GlobalOrigin::from_mavlink(o.latitude, o.longitude, o.altitude) {
                    Some(origin) => {
                        self.gcs.origin = Some(origin);
                        self.gcs.text(
                            MavSeverity::MAV_SEVERITY_INFO,
                            &format!("Origin set: {:.7}, {:.7}", origin.lat_deg, origin.lon_deg),
                        )?;
                        // ArduPilot answers with the origin in force.
                        self.gcs
                            .send(MavMessage::GPS_GLOBAL_ORIGIN(GPS_GLOBAL_ORIGIN_DATA {
                                latitude: o.latitude,
                                longitude: o.longitude,
                                altitude: o.altitude,
                            }))?;
                    }
                    None => self.gcs.text_to(
                        station,
                        warn,
                        "Origin refused: latitude or longitude off the globe",
                    )?,
                }
            }
            MavMessage::SET_POSITION_TARGET_LOCAL_NED(p) => self.target_local(station, &p)?,
            MavMessage::SET_POSITION_TARGET_GLOBAL_INT(p) => self.target_global(station, &p)?,
            _ => self.gcs.stats.ignored += 1,
        }
        Ok(())
    }
}
