//! The identification manoeuvre from a ground station (docs/identification.md):
//! `MAV_CMD_USER_2` (31011) in a `COMMAND_LONG`, param1 the room's radius (m, 3-100; 0 is
//! [`RADIUS_M`]), param2 the depth band either side of the start depth (m, 0.5-20, the start
//! deeper than it; 0 is [`DEPTH_BAND_M`]), becomes the vehicle's `StartIdent`. A user
//! command because MAVLink has none for a system-identification manoeuvre (ArduPilot's
//! `MAV_CMD_DO_AUTOTUNE_ENABLE` carries an axis mask, not a room) and `MAV_CMD_USER_1` is the
//! estimator's restart. The vehicle takes it armed in `Hold` (POSHOLD) with its estimate
//! ready: `COMMAND_ACK` accepted, or denied with the vehicle's reason in words.
//!
//! While it flies every station is told its progress every [`PROGRESS_EVERY_S`] of the
//! vehicle's clock and its end by `STATUSTEXT`: finished, or stopped, with the reason the
//! surface sees (the vehicle disarmed or left POSHOLD, a failsafe, the commander's stick off
//! centre, the vehicle out of its room) or the one the vehicle reports. The vehicle stops it
//! for the same reasons, judged on its own 50 Hz estimate, and reports its outcome in its
//! `Status` (protocol version 9): from a `Status` made after the start (stamped later than the
//! latest one before its acknowledgement: the tether keeps the vehicle's order), the
//! vehicle's end (flown, or stopped and why: a brief excursion out of the band that the
//! surface's 10 Hz telemetry does not show) is what the stations are told.

use super::ident_run::{vehicle_time_s, IdentNews, IdentRun, PROGRESS_EVERY_S};
use super::topside::Topside;
use super::transport::StationId;
use anyhow::Result;
use firmware::autopilot::IDENT_DURATION_S;
use mavlink::dialects::ardupilotmega::{MavCmd, MavResult, MavSeverity};
use protocol::{Command, NackReason};

/// The room's radius when param1 is 0 (m).
pub const RADIUS_M: f32 = 30.0;
/// The depth band when param2 is 0 (m).
pub const DEPTH_BAND_M: f32 = 6.0;

/// param1 / param2 as the room, or why they are refused.
pub fn room_of(param1: f32, param2: f32) -> Result<(f32, f32), String> {
    let pick = |v: f32, default: f32| if v == 0.0 { default } else { v };
    let (r, b) = (pick(param1, RADIUS_M), pick(param2, DEPTH_BAND_M));
    if !(r.is_finite() && (3.0..=100.0).contains(&r)) {
        return Err(format!(
            "Identification refused: radius {param1} m outside 3-100 m (0 is {RADIUS_M} m)"
        ));
    }
    if !(b.is_finite() && (0.5..=20.0).contains(&b)) {
        return Err(format!(
            "Identification refused: depth band {param2} m outside 0.5-20 m (0 is {DEPTH_BAND_M} m)"
        ));
    }
    Ok((r, b))
}

impl Topside {
    /// `MAV_CMD_USER_2` from `station`: the manoeuvre asked of the vehicle.
    pub(super) fn start_ident(
        &mut self,
        station: StationId,
        param1: f32,
        param2: f32,
    ) -> Result<()> {
        let cmd = MavCmd::MAV_CMD_USER_2;
        let (radius_m, depth_band_m) = match room_of(param1, param2) {
            Ok(room) => room,
            Err(why) => return self.refuse(station, cmd, &why),
        };
        let s = self.v.state;
        match self.v.command(&Command::StartIdent {
            radius_m,
            depth_band_m,
        })? {
            Ok(()) => {
                let now_s = vehicle_time_s(&self.v.tel);
                self.ident = Some(IdentRun {
                    started_s: now_s,
                    start_m: [s.x_m, s.y_m, s.z_m],
                    radius_m,
                    depth_band_m,
                    next_report_s: now_s + PROGRESS_EVERY_S,
                    status_before_us: self.v.last_status().map_or(0, |st| st.t_us),
                });
                let text = format!(
                    "Identification started: {IDENT_DURATION_S:.0} s of force steps within {radius_m} m and {depth_band_m} m up or down of the start; a stick, a mode change or leaving the room stops it"
                );
                self.gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
                self.gcs.ack(station, cmd, MavResult::MAV_RESULT_ACCEPTED)
            }
            Err(super::vehicle::Refusal::Nack(NackReason::OutOfRange)) => {
                let why = format!(
                    "Identification refused: the vehicle at {:.1} m is not deeper than the depth band {depth_band_m} m (the band must fit below the surface)",
                    s.z_m
                );
                self.refuse(station, cmd, &why)
            }
            Err(why) => self.refuse(station, cmd, &format!("Identification refused: {why}")),
        }
    }

    /// After each control period: the manoeuvre's progress, its end, or why it stopped.
    pub(super) fn poll_ident(&mut self) -> Result<()> {
        let Some(mut run) = self.ident else {
            return Ok(());
        };
        let tel = self.v.tel;
        let stick = self.manual_at.is_some() && !super::sticks::sticks_centred(&self.manual);
        let news = run.news(&tel, self.v.ident, stick);
        let elapsed = vehicle_time_s(&tel) - run.started_s;
        let s = tel.nav;
        let off_m = (s.x_m - run.start_m[0]).hypot(s.y_m - run.start_m[1]);
        let (severity, text) = match news {
            IdentNews::Flying => return Ok(()),
            IdentNews::Stopped(why) => {
                self.ident = None;
                if stick {
                    // The sticks are not forwarded in POSHOLD: this one goes, and the vehicle
                    // stops the manoeuvre on it.
                    self.v.send(&Command::ManualThrust(self.manual))?;
                }
                (
                    MavSeverity::MAV_SEVERITY_WARNING,
                    format!("Identification stopped after {elapsed:.0} s: {why}"),
                )
            }
            IdentNews::Finished => {
                self.ident = None;
                (
                    MavSeverity::MAV_SEVERITY_INFO,
                    format!(
                        "Identification finished: {IDENT_DURATION_S:.0} s flown; holding at the start point"
                    ),
                )
            }
            IdentNews::Progress => {
                run.reported();
                self.ident = Some(run);
                (
                    MavSeverity::MAV_SEVERITY_INFO,
                    format!(
                        "Identification: {elapsed:.0} of {IDENT_DURATION_S:.0} s, {off_m:.1} m from the start"
                    ),
                )
            }
        };
        self.gcs.text(severity, &text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_room_is_taken_in_range_and_refused_in_words_outside() {
        assert_eq!(room_of(0.0, 0.0), Ok((RADIUS_M, DEPTH_BAND_M)));
        assert_eq!(room_of(20.0, 1.5), Ok((20.0, 1.5)));
        for (r, b, says) in [
            (2.0, 1.0, "radius 2 m outside 3-100 m"),
            (f32::NAN, 1.0, "radius NaN m"),
            (20.0, 0.2, "depth band 0.2 m outside 0.5-20 m"),
            (20.0, 25.0, "depth band 25 m"),
        ] {
            let why = room_of(r, b).err().unwrap_or_default();
            assert!(why.contains(says), "{why}");
        }
    }
}
