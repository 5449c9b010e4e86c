//! ArduSub's ground station failsafe (`FS_GCS_ENABLE`, `FS_GCS_TIMEOUT`), at the surface: no
//! station's `HEARTBEAT` for the timeout, after one was heard, is said (every 30 s while it
//! lasts) and, armed, acted on once: 2 disarm, 3 ALT_HOLD (the depth held, centred sticks
//! sent while the failsafe lasts: the pilot's stream went with the station), 4 SURFACE; a
//! mode the vehicle refuses is a disarm, as ArduSub's. A heartbeat heard again ends it.

use super::params::surface::GcsFailsafe;
use super::topside::Topside;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::MavSeverity;
use protocol::{Command, Mode};
use std::time::{Duration, Instant};

/// How often the lost heartbeat is said again while it lasts.
const REMINDER: Duration = Duration::from_secs(30);

impl Topside {
    /// Every control period: the ground stations' heartbeat against `FS_GCS_TIMEOUT`.
    pub(super) fn watch_gcs(&mut self) -> Result<()> {
        let s = self.v.settings.surface;
        let action = s.gcs_failsafe();
        let Some(heard_at) = self.gcs_watch.heard_at else {
            return Ok(());
        };
        let silent = heard_at.elapsed();
        if action == GcsFailsafe::Disabled || silent.as_secs_f32() < s.gcs_timeout_s {
            if self.gcs_watch.lost_said_at.take().is_some() {
                let text = "Ground station heartbeat back: its failsafe ends";
                eprintln!("topside: {text}");
                self.gcs.text(MavSeverity::MAV_SEVERITY_INFO, text)?;
            }
            self.gcs_watch.acted = false;
            return Ok(());
        }
        if self
            .gcs_watch
            .lost_said_at
            .is_none_or(|t| t.elapsed() >= REMINDER)
        {
            self.gcs_watch.lost_said_at = Some(Instant::now());
            let text = format!(
                "Ground station heartbeat lost for {:.0} s (FS_GCS_TIMEOUT {} s)",
                silent.as_secs_f32(),
                super::params::show(s.gcs_timeout_s)
            );
            eprintln!("topside: {text}");
            self.gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
        }
        if self.gcs_watch.acted || !self.v.tel.armed {
            return Ok(());
        }
        self.gcs_watch.acted = true;
        let mode = match action {
            GcsFailsafe::Disabled | GcsFailsafe::Warn => return Ok(()),
            GcsFailsafe::Disarm => None,
            GcsFailsafe::DepthHold => Some(Mode::DepthHold),
            GcsFailsafe::Surface => Some(Mode::Surface),
        };
        let taken = match mode {
            Some(m) => match self.v.command(&Command::SetMode(m))? {
                Ok(()) => {
                    self.v.tel.mode = m;
                    self.guided_target = None;
                    Some(m)
                }
                Err(why) => {
                    eprintln!("topside: ground station failsafe: mode refused ({why}): disarming");
                    None
                }
            },
            None => None,
        };
        let text = match taken {
            Some(Mode::DepthHold) => "Ground station failsafe: depth hold".to_string(),
            Some(_) => "Ground station failsafe: surfacing".to_string(),
            None => match self.v.command(&Command::Disarm)? {
                Ok(()) => {
                    self.v.tel.armed = false;
                    "Ground station failsafe: disarmed".to_string()
                }
                Err(why) => {
                    format!("Ground station failsafe: disarm refused by the vehicle: {why}")
                }
            },
        };
        eprintln!("topside: {text}");
        self.gcs.text(MavSeverity::MAV_SEVERITY_CRITICAL, &text)
    }
}
