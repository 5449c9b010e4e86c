//! The topside layout with its PC outside the simulation: the topside App's PC tether is a
//! byte stream another program writes (`host-sim vehicle` serves it to a surface program),
//! and the harness adds only the instruments' readings that reach the topside over that
//! tether in this layout (the compass, the DVL and the USBL fixes, and at the start the
//! vehicle's description and, if asked, the estimator's start at the launch point). The
//! harness's own session, heartbeats and scenario commands are off: the surface commands.

use super::{ExternalPc, TopsideLayout};

impl TopsideLayout {
    /// The same layout with its PC tether moved by `pc`; with `start_nav` the topside's
    /// estimator is started at the launch point at the start (else the PC starts it).
    pub fn with_external_pc(mut self, pc: Box<dyn ExternalPc>, start_nav: bool) -> Self {
        self.external = Some(pc);
        self.external_start_nav = start_nav;
        self
    }
}
