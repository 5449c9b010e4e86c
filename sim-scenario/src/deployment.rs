//! `[deployment]` of a scenario: where the control loop runs, and the node
//! link's tether for the topside layout (host-sim's `tether::topside_layout`). A module of its own,
//! below both the scenario and the layout, so neither depends on the other through it.

use anyhow::{anyhow, bail, Result};
use serde::{Deserialize, Serialize};
use sim_world::sensors::NavSource;
use sim_world::tether_wire::{WireSpec, DEFAULT_BAUD};

/// Where the control loop runs (`[deployment] control`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Control {
    /// On the vehicle (today's layout).
    #[default]
    Onboard,
    /// On a topside MCU, with a thin node on the vehicle (the paper's layout).
    Topside,
}

/// `[deployment]`: the layout and, for the topside layout, the node link's tether.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DeploymentSpec {
    /// `"onboard"` or `"topside"`.
    pub control: Control,
    /// The node link's rate (Bd, 8N1).
    pub tether_baud: u32,
    /// Added one-way latency of the node link (s).
    pub tether_latency_s: f64,
    /// Extra latency drawn per frame, uniform in `[0, tether_jitter_s]` (s).
    pub tether_jitter_s: f64,
    /// Share of the node link's bytes corrupted (each direction).
    pub tether_corruption: f64,
    /// The node link is cut at this time (s).
    pub tether_cut_s: Option<f64>,
    /// Tell the laws the delay of the layout: the expected time from an IMU sample to the
    /// pulse it causes ([`told_delay_s`]); the core then predicts the state forward over it.
    pub tell_delay: bool,
    /// The delay told to the laws (s), instead of the layout's expected one
    /// ([`told_delay_s`]); implies `tell_delay`.
    pub told_delay_s: Option<f64>,
    /// Seed of the wire's jitter and corruption.
    pub tether_seed: u64,
    /// The node link's period (s): an uplink and at least one downlink each. Default: from
    /// the rate ([`firmware::node_link::default_link_period_us`]: 20 ms at 115,200 Bd, 5 ms
    /// at 1 Mbd). Refused below the node's IMU period, above 20 ms, or when the uplink would
    /// keep the link more than half busy.
    pub link_period_s: Option<f64>,
    /// Stamp the node's increments with their newest sample's time, placed on the topside's
    /// clock through the round trip, instead of their arrival.
    pub stamp_node_time: bool,
}

impl Default for DeploymentSpec {
    fn default() -> Self {
        Self {
            control: Control::Onboard,
            tether_baud: DEFAULT_BAUD,
            tether_latency_s: 0.0,
            tether_jitter_s: 0.0,
            tether_corruption: 0.0,
            tether_cut_s: None,
            tell_delay: false,
            told_delay_s: None,
            tether_seed: 1,
            link_period_s: None,
            stamp_node_time: false,
        }
    }
}

impl DeploymentSpec {
    /// The wire the keys describe.
    pub fn wire(&self) -> WireSpec {
        WireSpec {
            baud: self.tether_baud,
            latency_s: self.tether_latency_s,
            jitter_s: self.tether_jitter_s,
            corruption_rate: self.tether_corruption,
            cut_at_s: self.tether_cut_s,
        }
    }

    /// The node link's period (us): `link_period_s`, or the rate's default.
    pub fn link_period_us(&self) -> u32 {
        match self.link_period_s {
            Some(p) => (p * 1e6).round().clamp(0.0, f64::from(u32::MAX)) as u32,
            None => firmware::node_link::default_link_period_us(self.tether_baud),
        }
    }

    /// Refuse bad values, naming the key (`deployment.tether_...`).
    pub fn validate(&self) -> Result<()> {
        self.wire()
            .validate()
            .map_err(|e| anyhow!("deployment.{e}"))?;
        let imu_us = firmware::node::NodeConfig::DEFAULT.imu_period_us;
        if let Some(p) = self.link_period_s {
            if !p.is_finite() {
                bail!("deployment.link_period_s = {p} is not a number of seconds");
            }
        }
        let period_us = self.link_period_us();
        firmware::node_link::check_link_period(period_us, imu_us, self.tether_baud).map_err(
            |e| {
                anyhow!(
                    "deployment.link_period_s = {} s at tether_baud = {}: {e} (the uplink's \
                     {} B take {} us; the IMU period is {imu_us} us)",
                    f64::from(period_us) * 1e-6,
                    self.tether_baud,
                    firmware::node_link::MAX_UPLINK_FRAME_LEN,
                    firmware::node_link::wire_time_us(
                        firmware::node_link::MAX_UPLINK_FRAME_LEN,
                        self.tether_baud
                    )
                )
            },
        )?;
        if let Some(t) = self.told_delay_s {
            if !(t.is_finite() && (0.0..=f64::from(MAX_TOLD_DELAY_S)).contains(&t)) {
                bail!(
                    "deployment.told_delay_s = {t} is outside 0..={MAX_TOLD_DELAY_S} s (what the \
                     laws can be told)"
                );
            }
        } else if self.tell_delay && told_delay_s(self) > f64::from(MAX_TOLD_DELAY_S) {
            bail!(
                "deployment.tell_delay: the layout's delay ({:.3} s at tether_latency_s = {} s) is \
                 over the {} s the laws can be told",
                told_delay_s(self),
                self.tether_latency_s,
                MAX_TOLD_DELAY_S
            );
        }
        Ok(())
    }

    /// Checks against the rest of the scenario: the topside layout needs the estimator
    /// (the node's IMU and pressure feed the topside's).
    pub fn check_with(&self, source: NavSource) -> Result<()> {
        if self.control == Control::Topside && source != NavSource::Estimator {
            bail!(
                "deployment.control = \"topside\" needs navigation.source = \"estimator\": the \
                 node's IMU and pressure feed the topside's estimator"
            );
        }
        Ok(())
    }
}

/// The longest delay the laws take (s): the core's limit
/// (`controller_core::nav::predict::MAX_DELAY_S`).
pub const MAX_TOLD_DELAY_S: f32 = controller_core::nav::predict::MAX_DELAY_S;

/// The delay told to the laws with `tell_delay` (s): from an IMU sample on the node to the
/// pulse it causes, expected: half a link period (the increments average the period), the
/// uplink's wire time, the one-way latency, the downlink's wire time, the latency again.
pub fn told_delay_s(d: &DeploymentSpec) -> f64 {
    if let Some(t) = d.told_delay_s {
        return t;
    }
    let byte_s = d.wire().byte_time_s();
    let up_s = firmware::node_link::MAX_UPLINK_FRAME_LEN as f64 * byte_s;
    let down_s = firmware::node_link::MAX_DOWNLINK_FRAME_LEN as f64 * byte_s;
    let half_period_s = f64::from(d.link_period_us()) * 0.5e-6;
    half_period_s + up_s + down_s + 2.0 * d.tether_latency_s
}
