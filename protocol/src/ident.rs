//! The identification manoeuvre's outcome as the vehicle reports it in `Status` (version 9):
//! flying and how far into its schedule, flown to its end, or stopped and why
//! (docs/identification.md).

use serde::{Deserialize, Serialize};

/// Why a manoeuvre stopped before its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum IdentAbort {
    /// A stick off centre.
    Sticks,
    /// A change of mode, a disarm or the estimator stopped.
    ModeChange,
    /// A failsafe fault in the step, or stale navigation.
    Failsafe,
    /// Farther from the start than the radius.
    Radius,
    /// Out of the depth band.
    DepthBand,
}

impl IdentAbort {
    /// The reason in words, for an operator.
    pub fn words(self) -> &'static str {
        match self {
            Self::Sticks => "a stick off centre",
            Self::ModeChange => "a mode change, a disarm or the estimator stopped",
            Self::Failsafe => "a failsafe or stale navigation",
            Self::Radius => "the vehicle left its room",
            Self::DepthBand => "the vehicle left its depth band",
        }
    }
}

/// How the latest identification manoeuvre ended, or that one is flying.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum IdentOutcome {
    /// None flown since boot.
    #[default]
    None,
    /// Flying, this far into the schedule (s).
    Flying {
        /// Time since the start (s).
        elapsed_s: f32,
    },
    /// Flown to its end.
    Done,
    /// Stopped early.
    Aborted(IdentAbort),
}
