//! Why the vehicle refuses a command: the reason its `Nack` carries.

use controller_core::nav::Refusal;
use serde::{Deserialize, Serialize};

/// Why a command was refused.
#[cfg_attr(target_os = "none", derive(defmt::Format))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum NackReason {
    /// The frame's protocol version is not [`PROTOCOL_VERSION`](crate::PROTOCOL_VERSION).
    UnsupportedVersion,
    /// CRC was right but the payload did not decode as a command.
    Malformed,
    /// A number was NaN or infinite.
    NonFinite,
    /// A number was outside its range.
    OutOfRange,
    /// A value that must be positive was not.
    NotPositive,
    /// A value that must not be negative was.
    Negative,
    /// Parameters that describe no physical vehicle.
    NonPhysical,
    /// Arming refused: no heartbeat within the arming window.
    NoHeartbeat,
    /// Arming or hold refused: no fresh `NavState`.
    NavStale,
    /// A tracking mode without a reference.
    NoReference,
    /// A combination the firmware does not offer (e.g. the paper law in 3-D).
    Unsupported,
    /// A `Nav` while the on-board estimator runs, or a sensor reading or fix without it.
    NavSource,
    /// The estimator refused the measurement (its state is unchanged).
    NavRefused(Refusal),
    /// Not while armed (a new vehicle description; version 5).
    Armed,
    /// Arming in a stick mode refused: the pilot's latest input is fresh and off centre
    /// (version 6).
    SticksNotCentred,
    /// The frame is not of the session in force (or none is open): send `OpenSession`
    /// (version 6).
    NoSession,
    /// The frame's sequence number is not newer than the last one taken in this session
    /// (version 6): a replay or a duplicate.
    Replayed,
    /// A time stamp too far ahead of the sender's previous one for the time that passed on
    /// the vehicle's clock (version 6): one frame cannot move the vehicle's idea of time.
    ClockAhead,
    /// A sensor reading over the tether on a board that reads its own sensors (version 6).
    OwnSensors,
    /// A mode that needs a position while the on-board estimate is not ready (version 6).
    NavNotReady(controller_core::nav::NotReady),
    /// A compass calibration refused: the reason; the one in force stays.
    CompassCal(controller_core::nav::compass_cal::CalRefusal),
    /// A compass calibration turn while disarmed.
    NotArmed,
    /// A compass calibration turn outside `Hold` (not in AUTO, `Track` or the pilot modes).
    NotInHold,
    /// A target (reference, waypoint) deeper than the depth limit `DEPTH_LIMIT_M`
    /// (version 7).
    DepthLimit,
    /// Arming while a leak or a critical battery holds (version 7; ArduSub's pre-arm
    /// checks).
    Health,
    /// A GUIDED target outside [`Mode::Guided`](crate::Mode::Guided) (version 8).
    NotInGuided,
}

impl From<controller_core::Error> for NackReason {
    fn from(e: controller_core::Error) -> Self {
        use controller_core::Error as E;
        match e {
            E::NonFinite(_) => NackReason::NonFinite,
            E::NotPositive(_) => NackReason::NotPositive,
            E::Negative(_) => NackReason::Negative,
            E::NonPhysical(_) => NackReason::NonPhysical,
            _ => NackReason::OutOfRange,
        }
    }
}
