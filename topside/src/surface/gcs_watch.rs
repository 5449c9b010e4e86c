//! The ground stations' heartbeat as `FS_GCS_*` watches it: when one was last heard, whether
//! the loss is said and acted on.

use super::params::surface::GcsFailsafe;
use std::time::Instant;

/// The failsafe's state.
#[derive(Debug, Default)]
pub(super) struct GcsWatch {
    /// When a station's heartbeat was last heard (none yet: the failsafe waits for one).
    pub(super) heard_at: Option<Instant>,
    /// The failsafe holds (the heartbeat lost), and when it was last said.
    pub(super) lost_said_at: Option<Instant>,
    /// The action was taken in this loss.
    pub(super) acted: bool,
}

impl GcsWatch {
    /// A station's heartbeat.
    pub(super) fn heard(&mut self) {
        self.heard_at = Some(Instant::now());
    }

    /// The failsafe holds with the depth held: the surface sends centred sticks.
    pub(super) fn holding_depth(&self, action: GcsFailsafe) -> bool {
        self.acted && self.lost_said_at.is_some() && action == GcsFailsafe::DepthHold
    }
}
