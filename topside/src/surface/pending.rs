//! Saved parameter groups the vehicle refused at start (a description while its estimator
//! runs or while armed): kept, tried again every second, applied when the vehicle takes them,
//! the operator told either way.

use super::params::{self, Group, Settings};
use super::transport::Gcs;
use super::vehicle::Vehicle;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::MavSeverity;
use std::time::{Duration, Instant};

/// Saved parameters waiting for the vehicle to take them, said again this often.
const PENDING_REMINDER: Duration = Duration::from_secs(30);

/// Saved parameter groups the vehicle refused at start: the saved values and the groups
/// still to apply.
#[derive(Debug, Default)]
pub(super) struct Pending {
    pub(super) saved: Option<Settings>,
    pub(super) groups: Vec<Group>,
    pub(super) said_at: Option<Instant>,
}

impl Pending {
    /// `settings` with the waiting groups' saved values (what the file keeps).
    pub(super) fn merged(&self, settings: &Settings) -> Settings {
        let mut s = *settings;
        if let Some(saved) = &self.saved {
            for &g in &self.groups {
                s.take_group(saved, g);
            }
        }
        s
    }

    /// The operator set a parameter of `group`: its saved values no longer wait.
    pub(super) fn forget(&mut self, group: Group) {
        self.groups.retain(|&g| g != group);
    }

    /// Try the waiting groups again; each the vehicle takes is said, and what still waits
    /// is said again every [`PENDING_REMINDER`].
    pub(super) fn retry(&mut self, v: &mut Vehicle, gcs: &mut Gcs) -> Result<()> {
        let Some(saved) = self.saved else {
            return Ok(());
        };
        let mut waiting = Vec::new();
        let mut last_why = None;
        for g in std::mem::take(&mut self.groups) {
            match v.apply(saved, g)? {
                Ok(()) => {
                    let text = format!("Saved {} parameters applied", g.names());
                    eprintln!("topside: {text}");
                    gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
                }
                Err(why) => {
                    waiting.push(g);
                    last_why = Some(why);
                }
            }
        }
        self.groups = waiting;
        if let Some(why) = last_why {
            if self.said_at.is_none_or(|t| t.elapsed() >= PENDING_REMINDER) {
                self.said_at = Some(Instant::now());
                let text = format!(
                    "Saved {} parameters wait: the vehicle refuses them now ({why}); \
                     applied when it takes them",
                    params::group_names(&self.groups)
                );
                eprintln!("topside: {text}");
                gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
            }
        }
        Ok(())
    }
}
