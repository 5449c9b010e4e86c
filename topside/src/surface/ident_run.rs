//! The identification manoeuvre flying, as the surface follows it: what each control period's
//! telemetry, the vehicle's latest `Status` and the commander's sticks say of it.

use firmware::autopilot::IDENT_DURATION_S;
use protocol::{fault, IdentOutcome, Mode, Telemetry};

/// Progress is said this often (s of the vehicle's time).
pub const PROGRESS_EVERY_S: f64 = 20.0;

/// The faults that stop the manoeuvre on the vehicle (a failsafe in the step).
const STOPPING_FAULTS: u16 = fault::HEARTBEAT_LOST
    | fault::LINK_DISARMED
    | fault::NAV_STALE
    | fault::SENSOR_LOST
    | fault::MANUAL_STALE;

/// A manoeuvre flying: when it started, where, its room, the next progress report (times
/// on the vehicle's clock, s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct IdentRun {
    pub(super) started_s: f64,
    pub(super) start_m: [f32; 3],
    pub(super) radius_m: f32,
    pub(super) depth_band_m: f32,
    pub(super) next_report_s: f64,
    /// The time stamp of the vehicle's latest `Status` when it acknowledged the start (us of
    /// its clock; 0: none yet). The tether keeps the vehicle's order, so a `Status` stamped
    /// later was made after the start and reports this manoeuvre, not an earlier one.
    pub(super) status_before_us: u64,
}

/// What a control period says of the manoeuvre.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum IdentNews {
    /// Stopped, and why in words.
    Stopped(String),
    /// Flown to its end.
    Finished,
    /// A progress report is due.
    Progress,
    /// Flying, nothing to say.
    Flying,
}

impl IdentRun {
    /// The manoeuvre after a control period: `tel` the latest telemetry (its position and
    /// the vehicle's clock), `vehicle_says` the outcome in the vehicle's latest `Status` and
    /// that `Status`'s time stamp (us), `stick` the commander's stick off centre. The
    /// vehicle's own end counts from a `Status` made after the start; beside it, the
    /// surface's own checks on the telemetry.
    pub(super) fn news(
        &self,
        tel: &Telemetry,
        vehicle_says: (IdentOutcome, u64),
        stick: bool,
    ) -> IdentNews {
        let (outcome, said_at_us) = vehicle_says;
        let this_one = said_at_us > self.status_before_us;
        let s = &tel.nav;
        let off_m = (s.x_m - self.start_m[0]).hypot(s.y_m - self.start_m[1]);
        let off_depth_m = (s.z_m - self.start_m[2]).abs();
        let why = match (this_one, outcome) {
            (true, IdentOutcome::Aborted(why)) => {
                Some(format!("{} (the vehicle's own check)", why.words()))
            }
            _ if !tel.armed || tel.mode != Mode::Hold => {
                Some("the vehicle disarmed or left POSHOLD".to_string())
            }
            _ if tel.faults & STOPPING_FAULTS != 0 => {
                let names: Vec<&str> = super::faults::FAULT_NAMES
                    .iter()
                    .filter(|(bit, _)| tel.faults & STOPPING_FAULTS & bit != 0)
                    .map(|(_, name)| *name)
                    .collect();
                Some(format!("a failsafe ({})", names.join(", ")))
            }
            _ if stick => Some("a stick off centre".to_string()),
            _ if off_m > self.radius_m => Some(format!(
                "the vehicle left its room ({off_m:.1} m from the start, radius {} m)",
                self.radius_m
            )),
            _ if off_depth_m > self.depth_band_m => Some(format!(
                "the vehicle left its depth band ({off_depth_m:.1} m from the start depth, band {} m)",
                self.depth_band_m
            )),
            _ => None,
        };
        if let Some(why) = why {
            return IdentNews::Stopped(why);
        }
        let now_s = vehicle_time_s(tel);
        let vehicle_done = this_one && outcome == IdentOutcome::Done;
        if vehicle_done || now_s - self.started_s >= f64::from(IDENT_DURATION_S) {
            return IdentNews::Finished;
        }
        if now_s >= self.next_report_s {
            return IdentNews::Progress;
        }
        IdentNews::Flying
    }

    /// A progress report was said: the next is due [`PROGRESS_EVERY_S`] later.
    pub(super) fn reported(&mut self) {
        self.next_report_s += PROGRESS_EVERY_S;
    }
}

/// The vehicle's clock in its latest telemetry (s): the manoeuvre's schedule runs on it, so
/// the surface follows it at the vehicle's pace (a simulated vehicle may run faster than
/// the wall clock).
pub(super) fn vehicle_time_s(tel: &Telemetry) -> f64 {
    tel.t_us as f64 * 1e-6
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::IdentAbort;

    fn run() -> IdentRun {
        IdentRun {
            started_s: 10.0,
            start_m: [0.0, 0.0, 10.0],
            radius_m: 30.0,
            depth_band_m: 6.0,
            next_report_s: 30.0,
            status_before_us: 10_500_000,
        }
    }

    /// Armed in Hold at the start, at `t_s` of the vehicle's clock.
    fn tel(t_s: f64) -> Telemetry {
        let mut t = Telemetry {
            t_us: (t_s * 1e6) as u64,
            armed: true,
            mode: Mode::Hold,
            ..Telemetry::default()
        };
        t.nav.z_m = 10.0;
        t
    }

    #[test]
    fn the_vehicles_own_stop_is_said_from_a_status_made_after_the_start() {
        let r = run();
        let aborted = IdentOutcome::Aborted(IdentAbort::DepthBand);
        // An earlier manoeuvre's outcome in a `Status` from before the start: not this one's.
        assert_eq!(
            r.news(&tel(11.0), (aborted, 10_500_000), false),
            IdentNews::Flying
        );
        let flying = IdentOutcome::Flying { elapsed_s: 2.0 };
        assert_eq!(
            r.news(&tel(12.0), (flying, 11_000_000), false),
            IdentNews::Flying
        );
        // A brief excursion the telemetry does not show, or a stop at once (never reported
        // flying): the vehicle's word.
        let stopped =
            IdentNews::Stopped("the vehicle left its depth band (the vehicle's own check)".into());
        assert_eq!(r.news(&tel(13.0), (aborted, 12_000_000), false), stopped);
        assert_eq!(r.news(&tel(11.0), (aborted, 10_600_000), false), stopped);
    }

    #[test]
    fn the_end_is_the_vehicles_or_the_schedules_and_progress_runs_on_the_vehicles_clock() {
        let mut r = run();
        let flying = (IdentOutcome::Flying { elapsed_s: 1.0 }, 11_000_000);
        assert_eq!(r.news(&tel(29.9), flying, false), IdentNews::Flying);
        assert_eq!(r.news(&tel(30.0), flying, false), IdentNews::Progress);
        r.reported();
        assert_eq!(r.next_report_s, 50.0);
        assert_eq!(r.news(&tel(30.1), flying, false), IdentNews::Flying);
        // The vehicle's `Done` from before the start does not end this one; its own does.
        assert_eq!(
            r.news(&tel(31.0), (IdentOutcome::Done, 10_000_000), false),
            IdentNews::Flying
        );
        assert_eq!(
            r.news(&tel(31.0), (IdentOutcome::Done, 31_000_000), false),
            IdentNews::Finished
        );
        // Without the vehicle's word, the schedule's end on the vehicle's clock.
        let end_s = 10.0 + f64::from(IDENT_DURATION_S);
        assert_eq!(
            run().news(&tel(end_s), (IdentOutcome::None, 0), false),
            IdentNews::Finished
        );
    }

    #[test]
    fn the_surfaces_own_checks_stop_it_in_words() {
        let none = (IdentOutcome::None, 0);
        let mut t = tel(12.0);
        t.nav.x_m = 31.0;
        assert!(
            matches!(run().news(&t, none, false), IdentNews::Stopped(w) if w.contains("left its room"))
        );
        let mut t = tel(12.0);
        t.nav.z_m = 3.0;
        assert!(
            matches!(run().news(&t, none, false), IdentNews::Stopped(w) if w.contains("depth band (7.0 m"))
        );
        let mut t = tel(12.0);
        t.mode = Mode::Manual;
        assert!(
            matches!(run().news(&t, none, false), IdentNews::Stopped(w) if w.contains("left POSHOLD"))
        );
        let mut t = tel(12.0);
        t.faults = fault::NAV_STALE;
        assert!(
            matches!(run().news(&t, none, false), IdentNews::Stopped(w) if w.contains("a failsafe"))
        );
        assert_eq!(
            run().news(&tel(12.0), none, true),
            IdentNews::Stopped("a stick off centre".to_string())
        );
    }
}
