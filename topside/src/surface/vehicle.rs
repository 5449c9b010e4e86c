//! The vehicle behind the tether, as the surface drives it: [`Vehicle`] over a
//! [`VehicleEnd`]. The program's own end is a vehicle on its own clock, reached through a
//! byte stream (`Real`: a serial device or a TCP stream, a real vehicle or a simulated one
//! served by `host-sim vehicle`); the trait lets a caller give another end (the simulator's
//! lock-step harness).
//!
//! Every telemetry frame is checked before it is believed ([`check_telemetry`]): finite
//! values in physical ranges, pulse widths an ESC can be sent, at most a mission's waypoints
//! reached; in a frame out of range no number is believed (the last good ones stay; the armed
//! flag, the mode and the fault flags, bounded by their types, are still shown) and it is
//! counted. A vehicle that says nothing for [`VEHICLE_SILENCE`] is silent: its commands are
//! refused at once (`Refusal::Silent`) instead of waited for, and a command it leaves
//! unanswered is a refusal, never the end of the surface program.

use crate::clock::us;
use crate::link::Link;
use crate::surface::params::{Group, Settings};
use anyhow::{anyhow, bail, Result};
use controller_core::params::VehicleParams;
use controller_core::state::NavState;
use protocol::{Command, NackReason, Reply, Status, Telemetry};
use std::time::{Duration, Instant};

/// A vehicle that sends no telemetry for this long (wall clock) is silent.
pub const VEHICLE_SILENCE: Duration = Duration::from_secs(1);

/// Why the vehicle did not take a command: its `Nack`, or no answer at all. Shown in the
/// refusals' words ([`words::nack`](super::words::nack)), never as an internal name.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(super) enum Refusal {
    /// The vehicle refused it.
    Nack(NackReason),
    /// The vehicle is silent (nothing for [`VEHICLE_SILENCE`], or the command unanswered).
    Silent,
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::Nack(r) => f.write_str(&super::words::nack(*r)),
            Refusal::Silent => f.write_str("no answer from the vehicle (silent)"),
        }
    }
}

// The same words wherever a refusal is shown.
impl std::fmt::Debug for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(self, f)
    }
}

/// Farthest position believed from the origin, horizontally (m).
const MAX_POSITION_M: f32 = 10_000.0;
/// Deepest (and highest) position believed (m).
const MAX_DEPTH_M: f32 = 1_000.0;
/// Largest speed believed (m/s) and turn rate (rad/s).
const MAX_SPEED_M_S: f32 = 20.0;
const MAX_RATE_RAD_S: f32 = 50.0;
/// Largest heading believed (rad): the vehicle may report it unwrapped.
const MAX_YAW_RAD: f32 = 10_000.0;
/// Largest thruster force believed (N).
const MAX_THRUST_N: f32 = 1_000.0;
/// Pulse widths believed (us): what an RC output can send an ESC; 0 is an output off.
pub const PULSE_RANGE_US: std::ops::RangeInclusive<u16> = 800..=2200;

/// Is `t` believable? Every value the topside forwards or acts on: finite and in range, or
/// the first field that is not.
pub fn check_telemetry(t: &Telemetry) -> std::result::Result<(), String> {
    let n = &t.nav;
    if !n.is_finite() || !t.requested.is_finite() || !t.achieved.is_finite() {
        return Err("a navigation value or force is not finite".into());
    }
    let e = &t.errors;
    if ![e.x_m, e.y_m, e.z_m, e.pitch_rad, e.yaw_rad]
        .iter()
        .chain(&t.nav_pos_std_m)
        .all(|v| v.is_finite())
    {
        return Err("a tracking error or position spread is not finite".into());
    }
    if n.x_m.hypot(n.y_m) > MAX_POSITION_M || n.z_m.abs() > MAX_DEPTH_M {
        return Err(format!(
            "position ({}, {}, {}) m out of range",
            n.x_m, n.y_m, n.z_m
        ));
    }
    let pi2 = 2.0 * std::f32::consts::PI;
    if n.roll_rad.abs() > pi2 || n.pitch_rad.abs() > pi2 || n.yaw_rad.abs() > MAX_YAW_RAD {
        return Err("an attitude angle out of range".into());
    }
    let speeds = [n.u_m_s, n.v_m_s, n.w_m_s];
    let rates = [n.p_rad_s, n.q_rad_s, n.r_rad_s];
    if speeds.iter().any(|v| v.abs() > MAX_SPEED_M_S)
        || rates.iter().any(|v| v.abs() > MAX_RATE_RAD_S)
    {
        return Err("a speed or turn rate out of range".into());
    }
    if t.thrust_n
        .iter()
        .any(|f| !f.is_finite() || f.abs() > MAX_THRUST_N)
    {
        return Err(format!("thrust {:?} N out of range", t.thrust_n));
    }
    if t.pulse_us
        .iter()
        .any(|&p| p != 0 && !PULSE_RANGE_US.contains(&p))
    {
        return Err(format!("pulse widths {:?} us out of range", t.pulse_us));
    }
    let most = protocol::limits::MAX_MISSION_ITEMS;
    if usize::from(t.mission_reached) > most {
        return Err(format!(
            "{} waypoints reached, a mission has at most {most}",
            t.mission_reached
        ));
    }
    Ok(())
}

/// What the topside needs of the vehicle behind the tether, whichever it is.
pub trait VehicleEnd {
    /// A command answered by `Ack` (`Ok`) or `Nack` (its reason).
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>>;
    /// A command not waited for (the pilot's sticks, every period).
    fn send(&mut self, cmd: &Command) -> Result<()>;
    /// One control period, the `periods`-th: the simulated time after it, and the latest
    /// telemetry if one came.
    fn step(&mut self, periods: u64) -> Result<(f64, Option<Telemetry>)>;
    /// The control period (s).
    fn period_s(&self) -> f64;
    /// The latest `Status` (the answer to a heartbeat).
    fn last_status(&mut self) -> Option<Status>;
    /// Frames dropped on the tether to the vehicle (bad CRC, framing), for `SYS_STATUS`.
    fn frames_dropped(&self) -> u64;
}

/// The vehicle behind the tether, and what the surface knows of it.
pub struct Vehicle {
    end: Box<dyn VehicleEnd>,
    pub(super) t_s: f64,
    pub(super) period_s: f64,
    /// Control periods run.
    pub(super) periods: u64,
    /// The vehicle's navigation state, from its telemetry (its own estimate, or the `Nav`
    /// it was sent).
    pub(super) state: NavState,
    pub(super) tel: Telemetry,
    /// The gains, timeouts and description in force on the vehicle (as last accepted).
    pub(super) settings: Settings,
    /// The pilot's sticks are forwarded every this many periods: every period of a vehicle
    /// on its own clock; a lock-step end with a finer loop than its control gives more.
    pub(super) stride: u64,
    /// When the vehicle last sent telemetry (wall clock).
    heard_at: Instant,
    /// The battery's figures from the vehicle's latest `Status` (zero: not measured).
    pub(super) battery: protocol::BatteryStatus,
    /// The identification manoeuvre as the vehicle's latest `Status` reports it, and that
    /// `Status`'s time stamp (the vehicle's clock, us).
    pub(super) ident: (protocol::IdentOutcome, u64),
    /// Telemetry frames still to come before the pulse widths are shown again after a change
    /// of what the vehicle is told (an accepted command, a change of commander): the first
    /// frame after it may have left the vehicle before the change reached it.
    pub(super) frames_before_pulses: u8,
    /// Telemetry frames refused by [`check_telemetry`], and the latest reason.
    pub(super) frames_refused: u64,
    pub(super) last_refusal: Option<String>,
}

/// How long a command waits for its answer on each of its tries.
pub const TETHER_TIMEOUT: Duration = Duration::from_millis(500);

/// A real vehicle on its own clock: a heartbeat every `heartbeat_every` periods and
/// whatever it said.
struct Real {
    link: Link,
    t_s: f64,
    heartbeat_every: u64,
}

/// The period the topside runs a real vehicle's side at (s).
const REAL_PERIOD_S: f64 = 0.02;

impl VehicleEnd for Real {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.link.command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }

    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.link.send(cmd).map(|_| ())
    }

    fn step(&mut self, periods: u64) -> Result<(f64, Option<Telemetry>)> {
        if periods.is_multiple_of(self.heartbeat_every) {
            self.link.send(&Command::Heartbeat { t_us: us(self.t_s) })?;
        }
        // What has arrived, for at most a tenth of the period (the rest waits for the next).
        let mut tel = None;
        let started = Instant::now();
        while let Some((_, reply)) = self.link.recv(Duration::ZERO)? {
            if let Reply::Telemetry(t) = reply {
                tel = Some(t);
            }
            if started.elapsed().as_secs_f64() >= REAL_PERIOD_S / 10.0 {
                break;
            }
        }
        self.t_s += REAL_PERIOD_S;
        Ok((self.t_s, tel))
    }

    fn period_s(&self) -> f64 {
        REAL_PERIOD_S
    }

    fn last_status(&mut self) -> Option<Status> {
        self.link.last_status
    }

    fn frames_dropped(&self) -> u64 {
        self.link.stats.frames_dropped
    }
}

impl Vehicle {
    /// A vehicle behind `end`, holding `settings` (what the end sends it at the start),
    /// the sticks forwarded every `stride` control periods; the first period is run.
    pub fn with_end(end: Box<dyn VehicleEnd>, settings: Settings, stride: u64) -> Result<Self> {
        let mut v = Self {
            period_s: end.period_s(),
            end,
            t_s: 0.0,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings,
            stride: stride.max(1),
            heard_at: Instant::now(),
            frames_before_pulses: 0,
            battery: protocol::BatteryStatus::default(),
            ident: (protocol::IdentOutcome::None, 0),
            frames_refused: 0,
            last_refusal: None,
        };
        v.step()?;
        Ok(v)
    }

    /// A real vehicle on `port`, running on its own clock: found by a heartbeat answered
    /// within 2 s. Its description is sent only when `vehicle` is given (a real vehicle
    /// keeps its own otherwise; the parameter list shows the Observer's until then). An
    /// onboard vehicle and a topside board of the topside layout answer alike: the same
    /// tether protocol.
    pub(super) fn real(
        port: Box<dyn crate::port::Port>,
        vehicle: Option<VehicleParams>,
        heartbeat_hz: u32,
    ) -> Result<Self> {
        // The vehicle's `HEARTBEAT_LOST` failsafe trips after 0.5 s without one.
        let heartbeat_every = ((1.0 / REAL_PERIOD_S) / f64::from(heartbeat_hz.max(1)))
            .round()
            .max(1.0) as u64;
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
            bail!(
                "the vehicle refused our heartbeat: {}",
                super::words::nack(why)
            );
        }
        let mut v = Self {
            end: Box::new(Real {
                link,
                t_s: 0.0,
                heartbeat_every,
            }),
            t_s: 0.0,
            period_s: REAL_PERIOD_S,
            periods: 0,
            state: NavState::default(),
            tel: Telemetry::default(),
            settings: Settings::new(vehicle.unwrap_or(VehicleParams::OBSERVER)),
            stride: 1,
            heard_at: Instant::now(),
            frames_before_pulses: 0,
            battery: protocol::BatteryStatus::default(),
            ident: (protocol::IdentOutcome::None, 0),
            frames_refused: 0,
            last_refusal: None,
        };
        if vehicle.is_some() {
            let s = v.settings;
            if let Err(why) = v.apply(s, Group::Vehicle)? {
                bail!("the vehicle refused the vehicle description: {why}");
            }
        }
        Ok(v)
    }

    /// A command not waited for (the pilot's sticks).
    pub(super) fn send(&mut self, cmd: &Command) -> Result<()> {
        self.end.send(cmd)
    }

    /// The vehicle's latest `Status`.
    pub(super) fn last_status(&mut self) -> Option<Status> {
        self.end.last_status()
    }

    /// Frames dropped on the tether.
    pub(super) fn frames_dropped(&self) -> u64 {
        self.end.frames_dropped()
    }

    /// Send one group of settings; on a refusal nothing changes, here or on the vehicle.
    pub(super) fn apply(
        &mut self,
        proposed: Settings,
        group: Group,
    ) -> Result<std::result::Result<(), Refusal>> {
        let cmd = match group {
            Group::Tracking => Command::SetTrackingGains(proposed.gains.tracking),
            Group::Paper => Command::SetPaperGains {
                xz: proposed.gains.paper_xz,
                xy: proposed.gains.paper_xy,
            },
            Group::Failsafe => match proposed.failsafe.to_firmware() {
                Ok(f) => Command::SetFailsafe(f),
                Err(_) => return Ok(Err(Refusal::Nack(NackReason::OutOfRange))),
            },
            Group::Vehicle => Command::SetVehicle(proposed.vehicle),
            Group::Compass => Command::SetCompassCal(proposed.compass.to_calibration()),
            Group::Health => match proposed.health.to_vehicle() {
                Ok(h) => Command::SetHealth(h),
                Err(_) => return Ok(Err(Refusal::Nack(NackReason::OutOfRange))),
            },
            Group::Mission | Group::Control | Group::Joystick | Group::Surface => {
                // Nothing to send now: kept at the surface (the next mission carries the
                // speed).
                self.settings.take_group(&proposed, group);
                return Ok(Ok(()));
            }
        };
        let r = self.command(&cmd)?;
        if r.is_ok() {
            self.settings.take_group(&proposed, group);
        }
        Ok(r)
    }

    /// What the vehicle's outputs follow changed (an accepted command, a new commander's
    /// sticks): the pulse widths of the frames that may predate it are not shown.
    pub(super) fn outputs_changed(&mut self) {
        self.frames_before_pulses = 2;
    }

    /// When the vehicle last sent telemetry (wall clock).
    pub(super) fn heard_at(&self) -> Instant {
        self.heard_at
    }

    /// How long the vehicle has said nothing (wall clock).
    pub(super) fn silent_for(&self) -> Duration {
        self.heard_at.elapsed()
    }

    /// A command answered by `Ack` / `Nack`; refused at once while the vehicle is silent, and
    /// a command left unanswered is a refusal (noted), never an error that ends the topside.
    pub(super) fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), Refusal>> {
        if self.silent_for() >= VEHICLE_SILENCE {
            return Ok(Err(Refusal::Silent));
        }
        match self.end.command(cmd) {
            Ok(r) => {
                if r.is_ok() {
                    self.outputs_changed();
                }
                Ok(r.map_err(Refusal::Nack))
            }
            Err(e) => {
                eprintln!("topside: {e:#} (refused; the topside goes on)");
                Ok(Err(Refusal::Silent))
            }
        }
    }

    /// One control period. Simulated: one step of the closed loop, its truth logged. Real:
    /// a heartbeat every `heartbeat_every` periods and whatever the vehicle said.
    pub(super) fn step(&mut self) -> Result<()> {
        let (t_s, tel) = self.end.step(self.periods)?;
        if let Some(t) = tel {
            self.heard_at = Instant::now();
            self.frames_before_pulses = self.frames_before_pulses.saturating_sub(1);
            match check_telemetry(&t) {
                Ok(()) => {
                    self.tel = t;
                    self.state = t.nav;
                }
                Err(why) => {
                    self.frames_refused += 1;
                    self.last_refusal = Some(why);
                    // What every frame says in values its type bounds (armed, the mode, the
                    // fault flags) is still shown; the numbers stay the last good ones.
                    self.tel.armed = t.armed;
                    self.tel.mode = t.mode;
                    self.tel.faults = t.faults;
                    self.tel.t_us = t.t_us;
                }
            }
        }
        if let Some(st) = self.end.last_status() {
            self.battery = st.battery;
            self.ident = (st.ident, st.t_us);
        }
        self.t_s = t_s;
        self.periods += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn telemetry_out_of_range_is_named_and_a_plain_frame_passes() {
        let good = Telemetry {
            pulse_us: [1500; 3],
            ..Telemetry::default()
        };
        assert_eq!(check_telemetry(&good), Ok(()));
        let mut t = good;
        t.mission_reached = u16::MAX;
        assert!(check_telemetry(&t).unwrap_err().contains("65535 waypoints"));
        let mut t = good;
        t.nav.x_m = f32::NAN;
        assert!(check_telemetry(&t).unwrap_err().contains("not finite"));
        let mut t = good;
        t.pulse_us = [1500, u16::MAX, 1500];
        assert!(check_telemetry(&t).unwrap_err().contains("pulse"));
        let mut t = good;
        t.nav.z_m = 5_000.0;
        assert!(check_telemetry(&t).unwrap_err().contains("position"));
        // An output off (0 us) is a pulse an ESC can be sent.
        let mut t = good;
        t.pulse_us = [0; 3];
        assert_eq!(check_telemetry(&t), Ok(()));
    }
}
