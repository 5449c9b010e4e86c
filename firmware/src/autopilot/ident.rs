//! The identification manoeuvre's commands on the autopilot: its start (`StartIdent`), its
//! step in `Hold` and its end ([`IdentFlight`](super::ident_flight::IdentFlight) holds the
//! schedule).

use super::ident_flight::*;
use super::Autopilot;
use crate::protocol::{ManualThrust, Mode, NackReason};
use controller_core::reference::Reference;

impl Autopilot {
    /// How the latest identification manoeuvre ended, or that one is flying.
    pub fn ident_outcome(&self) -> IdentOutcome {
        self.ident_outcome
    }

    /// Stop the manoeuvre in flight for `why`.
    pub(super) fn abort_ident(&mut self, why: IdentAbort) {
        if self.ident.take().is_some() {
            self.ident_outcome = IdentOutcome::Aborted(why);
        }
    }

    /// A pilot input: any stick off centre stops the manoeuvre.
    pub(super) fn ident_sticks(&mut self, m: &ManualThrust) {
        if [m.surge, m.yaw, m.heave]
            .iter()
            .any(|v| v.abs() > super::STICK_CENTRED)
        {
            self.abort_ident(IdentAbort::Sticks);
        }
    }

    /// Start the manoeuvre (`StartIdent`): only armed (`NotArmed`), in `Hold` (`NotInHold`),
    /// with the on-board estimator (`NavSource`), fresh (`NavStale`) and ready
    /// (`NavNotReady`), no compass turn flying (`Unsupported`), and a room in range with the
    /// start deeper than the band (`OutOfRange`). On `Err` nothing changed.
    #[inline(never)]
    pub(super) fn start_ident(
        &mut self,
        now_us: u64,
        radius_m: f32,
        depth_band_m: f32,
    ) -> Result<(), NackReason> {
        if !self.armed {
            return Err(NackReason::NotArmed);
        }
        if self.mode != Mode::Hold {
            return Err(NackReason::NotInHold);
        }
        let o = self.onboard.as_ref().ok_or(NackReason::NavSource)?;
        if !self.nav_fresh(now_us) {
            return Err(NackReason::NavStale);
        }
        o.position_ready().map_err(NackReason::NavNotReady)?;
        if self.swing.is_some() {
            return Err(NackReason::Unsupported);
        }
        let nav = self.nav_state();
        let flight =
            IdentFlight::new(&nav, radius_m, depth_band_m).ok_or(NackReason::OutOfRange)?;
        self.ident = Some(flight);
        self.ident_outcome = IdentOutcome::Flying { elapsed_s: 0.0 };
        Ok(())
    }

    /// One control step of the manoeuvre (in `Hold`, armed, the step's `faults` known):
    /// its forces, or `None` when none flies or it just ended (then `Hold` at its start).
    #[inline(never)]
    pub(super) fn ident_step(
        &mut self,
        now_us: u64,
        nav_fresh: bool,
        faults: u16,
        dt_s: f32,
    ) -> Option<(f32, f32, Option<f32>)> {
        self.ident.as_ref()?;
        if self.mode != Mode::Hold {
            self.abort_ident(IdentAbort::ModeChange);
            return None;
        }
        if faults != 0 || !nav_fresh {
            self.abort_ident(IdentAbort::Failsafe);
            return None;
        }
        let nav = self.nav_state();
        let vehicle = *self.controller.vehicle();
        let flight = self.ident.as_mut()?;
        let start_m = flight.start_m;
        match flight.step(&vehicle, &nav, dt_s) {
            Ok(Some(forces)) => {
                self.ident_outcome = IdentOutcome::Flying {
                    elapsed_s: flight.elapsed_s(),
                };
                Some(forces)
            }
            Ok(None) => {
                self.ident = None;
                self.ident_outcome = IdentOutcome::Done;
                self.controller.reset();
                self.hold = Some((Reference::Hold { pos_m: start_m }, now_us));
                None
            }
            Err(why) => {
                self.abort_ident(why);
                self.controller.reset();
                self.hold = Some((Reference::Hold { pos_m: start_m }, now_us));
                None
            }
        }
    }
}
