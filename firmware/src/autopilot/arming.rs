//! The arming gate and the stick gate: when the vehicle may arm, what arming, disarming and a
//! change of mode clear, and when the pilot's sticks may produce thrust.

use super::{Autopilot, MISSION_TURN_RADIUS_M, STICK_CENTRED};
use crate::protocol::{ManualThrust, Mode, NackReason};
use controller_core::reference::mission::MissionPath;
use controller_core::reference::Reference;

/// Every stick within [`STICK_CENTRED`] of centre.
fn centred(m: &ManualThrust) -> bool {
    [m.surge, m.yaw, m.heave]
        .iter()
        .all(|v| v.abs() <= STICK_CENTRED)
}

impl Autopilot {
    /// Disarm now (neutral from the next step). What was commanded before is forgotten: the
    /// pilot's input, the tracking reference, the hold point and AUTO's path (a re-arming
    /// starts clean).
    pub fn disarm(&mut self) {
        self.armed = false;
        self.controller.reset();
        self.manual = None;
        self.reference = None;
        self.hold = None;
        self.auto = None;
        self.sticks_seen_centred = false;
        self.motor_test = None;
        self.abort_swing();
        self.abort_ident(super::IdentAbort::ModeChange);
    }

    /// Arm (from disarmed): a clean start in the current mode. A stick mode refuses while
    /// the latest pilot input received (of any age: one sent while disarmed counts) is off
    /// centre, then forgets it (thrust waits for input sent after the arming, and for the
    /// sticks seen at centre: [`Self::sticks_may_act`]); a tracking mode needs a reference
    /// sent since the last disarm; HOLD holds where the vehicle is and AUTO flies its mission
    /// from here, both from now. Out of line (the mission path's temporaries).
    #[inline(never)]
    pub(super) fn arm(&mut self, now_us: u64) -> Result<(), NackReason> {
        let stick_mode = matches!(self.mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold);
        if stick_mode && self.manual.is_some_and(|(_, m)| !centred(&m)) {
            return Err(NackReason::SticksNotCentred);
        }
        self.enter_mode(now_us, self.mode)?;
        self.sticks_seen_centred = self.sticks_centred_now(now_us);
        self.manual = None;
        self.engaged_us = now_us;
        self.controller.reset();
        self.armed = true;
        self.motor_test = None;
        self.sticky = 0;
        Ok(())
    }

    /// The latest pilot input is fresh and centred: the sticks are seen at centre at this
    /// moment.
    pub(super) fn sticks_centred_now(&self, now_us: u64) -> bool {
        self.manual.is_some_and(|(t, m)| {
            now_us.saturating_sub(t) < self.failsafe.manual_stale_us && centred(&m)
        })
    }

    /// Take the pilot's input received at `now_us` (checked by the caller). A centred one
    /// opens the stick gate.
    pub(super) fn take_sticks(&mut self, now_us: u64, m: &ManualThrust) {
        self.manual = Some((now_us, *m));
        self.sticks_seen_centred |= centred(m);
    }

    /// The pilot's input as the laws and the thrusters see it: itself once the sticks were
    /// seen at centre since the latest arming, change of mode or restart; centred until then
    /// (a stick held through one of those events never gives thrust by itself).
    pub(super) fn sticks_may_act(&self, m: ManualThrust) -> ManualThrust {
        if self.sticks_seen_centred {
            m
        } else {
            ManualThrust::default()
        }
    }

    /// The sticks were seen at centre since the latest arming, change of mode or restart.
    pub fn sticks_seen_centred(&self) -> bool {
        self.sticks_seen_centred
    }

    /// Out of line, so that the temporaries of a new mission path (AUTO) are not in every
    /// command's frame (docs/hil-and-mcu-cost.md: where the stack went).
    #[inline(never)]
    pub(super) fn set_mode(&mut self, now_us: u64, mode: Mode) -> Result<(), NackReason> {
        let changed = mode != self.mode;
        self.enter_mode(now_us, mode)?;
        self.abort_swing();
        self.abort_ident(super::IdentAbort::ModeChange);
        if changed {
            self.controller.reset();
            self.engaged_us = now_us;
            self.sticks_seen_centred = self.sticks_centred_now(now_us);
        }
        self.mode = mode;
        if matches!(mode, Mode::Manual | Mode::Stabilize | Mode::DepthHold) {
            // A manual command from before the mode change must not start the thrusters.
            self.manual = None;
        }
        Ok(())
    }

    /// Check that `mode` can be flown now and set up what it flies from `now_us` (HOLD's
    /// point, AUTO's path); on `Err` nothing changed.
    pub(super) fn enter_mode(&mut self, now_us: u64, mode: Mode) -> Result<(), NackReason> {
        let needs_nav = !matches!(
            mode,
            Mode::Idle | Mode::Manual | Mode::Track { .. } | Mode::Surface
        );
        if needs_nav && !self.nav_fresh(now_us) {
            return Err(NackReason::NavStale);
        }
        // A position mode waits for the on-board estimate to be ready.
        let position_mode = matches!(
            mode,
            Mode::Auto | Mode::Hold | Mode::Guided | Mode::Track { .. }
        );
        if let (true, Some(o)) = (position_mode, &self.onboard) {
            o.position_ready().map_err(NackReason::NavNotReady)?;
        }
        let s = self.nav_state();
        let here_m = [s.x_m, s.y_m, s.z_m];
        match mode {
            Mode::Auto => {
                if self.mission.waypoints.is_empty() {
                    return Err(NackReason::NoReference);
                }
                let m = &self.mission;
                let path =
                    MissionPath::new(here_m, &m.waypoints, m.speed_m_s, MISSION_TURN_RADIUS_M)?;
                self.auto = Some((path, now_us));
            }
            Mode::Track { plane, law } => {
                law.in_plane(plane).ok_or(NackReason::Unsupported)?;
                if self.reference.is_none() {
                    return Err(NackReason::NoReference);
                }
            }
            // GUIDED holds here until its first target.
            Mode::Hold | Mode::Guided => {
                self.hold = Some((Reference::Hold { pos_m: here_m }, now_us))
            }
            Mode::Surface => self.surface = super::SurfacePhase::Ascent,
            Mode::Idle | Mode::Manual | Mode::Stabilize | Mode::DepthHold => {}
        }
        Ok(())
    }
}
