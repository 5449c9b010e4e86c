//! What the topside layout's harness measures: the sensor-to-pulse latency histogram and
//! the run's report (`layout.json`).

use firmware::node_link::NodeCounters;
use firmware::topside_link::TopsideCounters;
use serde::Serialize;
use sim_world::tether_wire::WireCounters;

/// A latency histogram: 0.5 ms bins.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Latency {
    /// Every sample (us), in order.
    #[serde(skip)]
    pub samples_us: Vec<u64>,
}

impl Latency {
    /// The `q` quantile (0..=1) in ms, none without samples.
    pub fn quantile_ms(&self, q: f64) -> Option<f64> {
        if self.samples_us.is_empty() {
            return None;
        }
        let mut v = self.samples_us.clone();
        v.sort_unstable();
        let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
        Some(v[i] as f64 * 1e-3)
    }

    /// Counts per bin of `bin_ms`, from 0 to the largest sample.
    pub fn histogram(&self, bin_ms: f64) -> Vec<(f64, u64)> {
        let max = self.samples_us.iter().copied().max().unwrap_or(0) as f64 * 1e-3;
        let n = (max / bin_ms).floor() as usize + 1;
        let mut h: Vec<(f64, u64)> = (0..n).map(|i| (i as f64 * bin_ms, 0)).collect();
        for &s in &self.samples_us {
            let i = ((s as f64 * 1e-3) / bin_ms).floor() as usize;
            h[i.min(n - 1)].1 += 1;
        }
        h
    }
}

/// What the harness measured of one topside-layout run.
#[derive(Debug, Clone, Default, Serialize)]
pub struct LayoutReport {
    /// Where the two roles ran: "in process" or "emulated (QEMU netduinoplus2 x 2)".
    pub roles: String,
    /// The wire's figures.
    pub baud: u32,
    /// Added one-way latency (s).
    pub latency_s: f64,
    /// Corruption rate of bytes.
    pub corruption: f64,
    /// The delay told to the laws (s), if told.
    pub told_delay_s: Option<f64>,
    /// IMU sample on the node -> the pulse it caused on the node: from the newest sample
    /// the uplink's increments hold (read in the node's pass that sent the uplink).
    pub latency: Latency,
    /// The same from the oldest sample the increments cover (the previous uplink's newest):
    /// one link period more.
    pub latency_oldest: Latency,
    /// `latency`'s median, 99th percentile and largest (ms), for `layout.json`.
    pub latency_p50_p99_max_ms: Option<[f64; 3]>,
    /// The node's IMU reads per second of the run (emulated: the IMU intervals its uplinks
    /// integrated per second they cover).
    pub node_imu_hz: f64,
    /// Downlinks the node applied (accepted and taken).
    pub downlinks_applied: u64,
    /// Applied downlinks whose pulses or arm state differ from what the topside sent with
    /// that sequence number (a corrupted frame taken as good).
    pub wrong_commands_applied: u64,
    /// The node's counters at the end.
    pub node_counters: NodeCounters,
    /// The topside link's counters at the end.
    #[serde(skip)]
    pub topside_counters: TopsideCounters,
    /// Downlink wire (topside -> node) and uplink wire counters.
    pub down_wire: WireCounters,
    /// Node -> topside.
    pub up_wire: WireCounters,
    /// The latest round trip the topside measured (us).
    pub round_trip_us: Option<u32>,
    /// The latest good downlink the node applied before the cut (s).
    pub last_good_frame_s: Option<f64>,
    /// The node's outputs all neutral, first time after the cut (s).
    pub node_neutral_s: Option<f64>,
    /// The node disarmed and latched, first time after the cut (s).
    pub node_latched_s: Option<f64>,
    /// The first `Telemetry` the ground station received with the node link's loss after
    /// the cut (its time on the topside's clock, s).
    pub ground_saw_loss_s: Option<f64>,
    /// Telemetry frames the ground station received.
    pub telemetry_frames: u64,
    /// Commands the topside refused (a `Nack`).
    pub nacks: u64,
    /// The refusals by reason (e.g. a fix the estimator found too old).
    pub nack_reasons: std::collections::BTreeMap<String, u64>,
    /// USBL fixes the topside's estimator refused on its innovation gate (the summary's
    /// `navigation.usbl_fixes_rejected`).
    pub usbl_fixes_rejected: u64,
    /// Uplinks that carried a DVL velocity (the node's DVL port's reports, parsed and
    /// gated on the node).
    pub dvl_uplinks: u64,
    /// DVL measurements the ground station saw the topside's estimator take (distinct
    /// times of validity of the telemetry's DVL reading).
    pub dvl_fixes_on_ground: u64,
}
