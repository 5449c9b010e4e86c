//! The vehicle's refusals in words: what a ground station's operator reads in a
//! `STATUSTEXT`. Every reason says why and what state or range is needed, never the name of
//! an internal type (`NoReference`, `OutOfRange`): the operator does not read our source.

use controller_core::nav::compass_cal::{CalRefusal, MAX_DEVIATION_RAD};
use controller_core::nav::{NotReady, Refusal as NavRefusal};
use controller_core::nav::{HEADING_READY_STD_RAD, POSITION_READY_STD_M};
use protocol::NackReason;

/// Why the vehicle refused a command, in words.
pub fn nack(r: NackReason) -> String {
    use NackReason as N;
    match r {
        N::UnsupportedVersion => {
            "the vehicle speaks another tether protocol version (update the surface program or \
             the firmware)"
                .into()
        }
        N::Malformed => "the vehicle could not read the command".into(),
        N::NonFinite => "a value is not a number (NaN or infinite)".into(),
        N::OutOfRange => "a value is outside its allowed range".into(),
        N::NotPositive => "a value that must be above 0 is not".into(),
        N::Negative => "a value that must not be negative is".into(),
        N::NonPhysical => "the values describe no physical vehicle".into(),
        N::NoHeartbeat => {
            "no recent heartbeat from the surface on the vehicle (check the tether)".into()
        }
        N::NavStale => {
            "the vehicle has no fresh navigation (it needs a position within the last 0.2 s)".into()
        }
        N::NoReference => "nothing to fly: upload a mission or give a target first".into(),
        N::Unsupported => "not possible in the vehicle's present mode or setup".into(),
        N::NavSource => {
            "the vehicle's own estimator navigates (navigation from the surface is not taken)"
                .into()
        }
        N::NavRefused(why) => format!("the estimator refused the measurement: {}", nav(why)),
        N::Armed => "not while armed: disarm first".into(),
        N::SticksNotCentred => "the vehicle saw a stick off centre: centre the sticks".into(),
        N::NoSession => "no tether session open (the surface opens one again)".into(),
        N::Replayed => "a repeated or old command frame".into(),
        N::ClockAhead => "a time stamp too far ahead of the vehicle's clock".into(),
        N::OwnSensors => "the vehicle reads its own sensors".into(),
        N::NavNotReady(why) => not_ready(why),
        N::CompassCal(why) => compass(why),
        N::NotArmed => "the vehicle is disarmed: arm first".into(),
        N::NotInHold => "only in POSHOLD: switch to POSHOLD first".into(),
        N::DepthLimit => "deeper than the depth limit DEPTH_LIMIT_M".into(),
        N::Health => "a leak or a critical battery: fix it first".into(),
        N::NotInGuided => "not in GUIDED (switch to GUIDED first)".into(),
        // A reason added to the protocol after this table: said as a plain refusal.
        _ => "refused by the vehicle".into(),
    }
}

/// Why the position estimate is not ready for a mode that needs it.
pub fn not_ready(r: NotReady) -> String {
    match r {
        NotReady::PositionUncertain => format!(
            "the position estimate is not ready (uncertain by more than {POSITION_READY_STD_M} m: \
             wait for position fixes)"
        ),
        NotReady::HeadingUncertain => format!(
            "the heading estimate is not ready (uncertain by more than {:.0} deg: wait for the \
             compass)",
            HEADING_READY_STD_RAD.to_degrees()
        ),
        _ => "the position estimate is not ready: wait for position fixes".into(),
    }
}

/// Why the estimator refused a measurement.
pub fn nav(r: NavRefusal) -> &'static str {
    match r {
        NavRefusal::NonFinite => "a value is not a number",
        NavRefusal::OutOfRange => "a value is outside what the sensor can produce",
        NavRefusal::BadAccuracy => "its accuracy is not above 0",
        NavRefusal::InFuture => "it is dated after the estimator's time",
        NavRefusal::TooOld => "it is older than the estimator's history",
        NavRefusal::ImuGap => "too long since the previous IMU sample",
        NavRefusal::Outlier => "it disagrees with the estimate beyond the gate (an outlier)",
        _ => "the estimator does not take it",
    }
}

/// Why a compass calibration was refused.
pub fn compass(r: CalRefusal) -> String {
    match r {
        CalRefusal::NotFullTurn => "the vehicle turned less than a full circle".into(),
        CalRefusal::TooFewReadings => "too few compass readings during the turn".into(),
        CalRefusal::ResidualTooLarge => {
            "the compass readings do not fit a deviation curve (residual too large)".into()
        }
        CalRefusal::NonFinite => "a reading or rate is not a number".into(),
        CalRefusal::OutOfRange => format!(
            "the deviation is over {:.0} deg",
            MAX_DEVIATION_RAD.to_degrees()
        ),
        _ => "the calibration does not fit".into(),
    }
}

/// A CamelCase word in `text` (an internal name such as `NoReference`): a word that starts
/// with a capital, has a small letter and then another capital. MAVLink's names
/// (`MAV_FRAME_LOCAL_NED`), ordinary words and `NaN` pass.
pub fn internal_name(text: &str) -> Option<&str> {
    text.split(|c: char| !c.is_ascii_alphanumeric() && c != '_')
        .find(|w| {
            // "NaN" is how a ground station's operator knows a bad number.
            if *w == "NaN" {
                return false;
            }
            let mut chars = w.chars();
            let starts_capital = chars.next().is_some_and(|c| c.is_ascii_uppercase());
            let mut seen_small = false;
            starts_capital
                && chars.any(|c| {
                    if c.is_ascii_lowercase() {
                        seen_small = true;
                    }
                    seen_small && c.is_ascii_uppercase()
                })
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every reason the vehicle can give (the protocol's list), each said in words.
    pub(crate) fn every_nack() -> Vec<NackReason> {
        use NackReason as N;
        let mut all = vec![
            N::UnsupportedVersion,
            N::Malformed,
            N::NonFinite,
            N::OutOfRange,
            N::NotPositive,
            N::Negative,
            N::NonPhysical,
            N::NoHeartbeat,
            N::NavStale,
            N::NoReference,
            N::Unsupported,
            N::NavSource,
            N::Armed,
            N::SticksNotCentred,
            N::NoSession,
            N::Replayed,
            N::ClockAhead,
            N::OwnSensors,
            N::NotArmed,
            N::NotInHold,
            N::DepthLimit,
            N::Health,
            N::NotInGuided,
            N::NavNotReady(NotReady::PositionUncertain),
            N::NavNotReady(NotReady::HeadingUncertain),
        ];
        for r in [
            NavRefusal::NonFinite,
            NavRefusal::OutOfRange,
            NavRefusal::BadAccuracy,
            NavRefusal::InFuture,
            NavRefusal::TooOld,
            NavRefusal::ImuGap,
            NavRefusal::Outlier,
        ] {
            all.push(N::NavRefused(r));
        }
        for r in [
            CalRefusal::NotFullTurn,
            CalRefusal::TooFewReadings,
            CalRefusal::ResidualTooLarge,
            CalRefusal::NonFinite,
            CalRefusal::OutOfRange,
        ] {
            all.push(N::CompassCal(r));
        }
        all
    }

    #[test]
    fn every_vehicle_refusal_is_said_in_words() {
        for r in every_nack() {
            let text = nack(r);
            assert!(internal_name(&text).is_none(), "{r:?}: {text}");
            assert!(text.len() >= 20, "{r:?}: {text}");
            assert_ne!(text, "refused by the vehicle", "{r:?} has no words");
        }
    }

    #[test]
    fn internal_names_are_found_and_mavlink_names_pass() {
        assert_eq!(
            internal_name("Mode refused: NoReference"),
            Some("NoReference")
        );
        assert_eq!(internal_name("item 0: OutOfRange"), Some("OutOfRange"));
        assert_eq!(internal_name("refused (NavStale)"), Some("NavStale"));
        for fine in [
            "frame MAV_FRAME_BODY_NED, only MAV_FRAME_LOCAL_NED",
            "TRK_XY_KP 5000 refused: allowed 0-1000",
            "MAVLink: Reached command #2 of MAV_CMD_NAV_WAYPOINT",
        ] {
            assert_eq!(internal_name(fine), None, "{fine}");
        }
    }
}
