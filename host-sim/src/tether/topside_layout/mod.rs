//! The paper's layout in the closed loop: the control loop on a topside MCU, a
//! thin node on the vehicle, the node link between them over the byte-level tether model
//! ([`sim_world::tether_wire`]).
//!
//! [`TopsideLayout`] is a [`ControllerEndpoint`](crate::closed_loop::ControllerEndpoint) of [`crate::closed_loop`]'s loop: the
//! harness (the PC on the topside's tether, the wire, the watched bytes, the report) around
//! the two MCUs, which sit behind the [`Roles`] interface with two implementations:
//! [`InProcessRoles`] ([`TopsideLayout::for_scenario`], described below) and
//! [`EmulatedRoles`] ([`TopsideLayout::emulated`]: the `topside-emu` and `node-emu` images,
//! each in QEMU `netduinoplus2`, stepped through their harness UARTs at the node's IMU
//! times and at frame arrivals; `emulated.rs`). In process, both roles are the firmware
//! library's own code, run in this process on one virtual clock (the simulation's time,
//! microseconds):
//! - the topside: the same [`App`] as every image, its thrusters the node link
//!   ([`LinkThruster`]), its sensors the node's uplinks ([`LinkSensors`]), the link
//!   [`TopsideLink`]; its loop is the topside board's (`app.tick()`, an accepted uplink runs
//!   `app.step_now()`, `link.send_if_due()`), with the board's 25 ms fallback period;
//! - the node: [`Node`], sampling the plant's IMU at 400 Hz (host-sim's simulated IMU, run
//!   at 400 Hz in this layout) and the plant's pressure (the simulated depth sensor, as the
//!   pressure it would read), reading the simulated DVL's A50 reports on its DVL port
//!   ([`DvlWire`]: parsed and gated on the node, carried in its next uplink, as the
//!   `node-emu` image reads them on its USART3), and writing the pulses it applies to three
//!   PWM outputs whose thrust the plant gets (the core's ESC map);
//! - the PC: what `host-sim hil` sends the onboard App (the vehicle, `StartNav`, the
//!   reference, the mode, arm, heartbeats, and the USBL and compass fixes) goes to the
//!   topside over an in-memory tether (the PC sits next to the topside box). The USBL is
//!   measured at the surface and reaches the topside at once; the compass is on the
//!   vehicle without a port on the node, so its readings reach it the tether's one-way
//!   latency later (their own cable; the wire times of the node link are not added).
//!
//! The DVL takes one of two paths ([`DvlPath`]): its A50 reports on the node's DVL UART
//! ([`DvlPath::NodeUart`], [`run_layout_dvl`]: the real path, the node's `DvlPort` in
//! process, the `node-emu`'s USART3 emulated), or, by default, as the PC's `DvlFix`
//! commands the tether's one-way latency after the measurement ([`DvlPath::Tether`]: its
//! own cable). The default stays the tether: at 115,200 Bd the uplinks that carry a DVL
//! velocity (5 Hz: 10 % of them) take the latency from an IMU sample to its pulse to
//! 11.3 ms, which is then the p99 (`host-sim deployment`'s 60 s latency run), over the
//! layout's 10 ms.
//!
//! In process, both MCUs run one pass of their main loop every [`PASS_US`] of virtual time
//! (emulated: see `emulated.rs`). Each loop tick of the closed loop runs the passes since
//! the previous tick; the node's outputs at the tick are held over the next period. So that holding adds little delay of its own,
//! [`layout_scenario`] runs the loop at the node's IMU period or finer (the largest multiple
//! of the plant step not above 2.5 ms): the measured sensor-to-thruster latency is the
//! node's own timeline, and the plant sees the pulses at most one such period later.
//!
//! The harness watches the bytes each side reads and writes (without changing them) to
//! measure what the firmware does not report: the latency from an IMU sample on the node to
//! the pulse it causes on the node, the pulses the node applied against what the topside
//! sent (a wrong command applied), the time the node went neutral and latched after a cut,
//! and when the ground station's `Telemetry` showed the loss.

mod emulated;
mod endpoint;
mod external;
mod pc;
mod ports;
mod report;
mod roles;
mod watch;

use crate::closed_loop::estimator_nav::{onboard_config, VehicleNav};
use crate::closed_loop::{run_closed_loop, RunOptions, RunOutput};
use crate::tether::in_process::{SimPwm, SimSerial};
pub use crate::tether::qemu::LayoutElfs;
use anyhow::{anyhow, Result};
use controller_core::alloc::PwmMap;
use controller_core::controller::{Controller, Gains};
use controller_core::nav::onboard::OnboardConfig;
use controller_core::reference::Reference;
pub use emulated::{EmulatedRoles, BOARD_TIMEOUT, TOPSIDE_GRID_US};
use firmware::node::{Node, NodeConfig};
use firmware::node_link::{Downlink, LinkDecoder, Uplink};
use firmware::sensors::dvl::{a50::VelocityGate, DvlPort, WithDvl};
use firmware::topside_link::{ImuStamp, NodeBridge, TopsideConfig, TopsideLink};
use firmware::{App, Config, Timing};
pub use ports::{ExternalPc, PlantSensors, VClock, WirePort};
use protocol::{Board, Client, Command, Mode, Telemetry};
pub use report::{Latency, LayoutReport};
pub use roles::{
    ControlView, InProcessRoles, NodePass, NodeRole, Roles, TopsideApp, TopsidePass,
    NODE_IMU_PERIOD_US, PASS_US,
};
use sim_scenario::setup::RunSetup;
use sim_scenario::Scenario;
use sim_world::clock::us;
use sim_world::sensors::DvlWire;
use sim_world::tether_wire::Duplex;

pub use sim_scenario::deployment::{told_delay_s, Control, DeploymentSpec, MAX_TOLD_DELAY_S};
use std::cell::Cell;
use std::collections::{BTreeSet, HashMap};
use std::rc::Rc;

/// The topside board's fallback control period (us): longer than the link's 20 ms, so a
/// slightly late uplink does not find a step just run by the fallback (`topside_board.rs`).
pub const FALLBACK_PERIOD_US: u32 = 25_000;

/// The PC's heartbeat period to the topside (us).
const HEARTBEAT_PERIOD_US: u64 = 50_000;

/// The topside's session on the node link (any non-zero number; a real board mixes its
/// unique id with the clock).
const LINK_SESSION: u32 = 0x2570_51DE;

/// The scenario as the topside layout flies it: the IMU at the node's 400 Hz at least, and
/// the loop's period the largest multiple of the plant step not above the node's IMU period
/// (the co-simulation step; the topside's control runs at the uplink rate on its own clock).
pub fn layout_scenario(sc: &Scenario) -> Scenario {
    let mut sc = sc.clone();
    if let Some(imu) = sc.sensors.imu.as_mut() {
        imu.rate_hz = imu.rate_hz.max(1e6 / f64::from(NODE_IMU_PERIOD_US));
    }
    let n = ((f64::from(NODE_IMU_PERIOD_US) * 1e-6) / sc.plant_dt_s + 1e-9).floor();
    sc.control_period_s = sc.plant_dt_s * n.max(1.0);
    sc
}

/// How the simulated DVL's measurements reach the topside's estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DvlPath {
    /// As the PC's `DvlFix` commands over the tether, the tether's one-way latency after
    /// the measurement (the DVL on its own cable).
    #[default]
    Tether,
    /// As the A50's `wrz` reports on the node's DVL UART: parsed and gated on the node,
    /// carried in its uplinks (the node link's DVL velocity).
    NodeUart,
}

/// The topside layout as the loop's controller endpoint.
pub struct TopsideLayout {
    /// The two MCUs: in process or emulated.
    roles: Box<dyn Roles>,
    wire: Duplex,
    // The PC's side of the tether to the topside.
    /// Tether bytes for the topside's next pass.
    pc_out: Vec<u8>,
    /// The PC's session with the topside, on the virtual clock.
    pc: Client,
    latest_telemetry: Option<Telemetry>,
    /// The PC outside the simulation (a served surface), in place of the harness's own.
    external: Option<Box<dyn ExternalPc>>,
    /// With an external PC: the estimator starts at the launch point at the start.
    external_start_nav: bool,
    next_heartbeat_us: u64,
    /// PC commands and when they are due at the topside (us).
    pending_pc: Vec<(u64, Command)>,
    /// Sequence numbers of the USBL fixes sent and not yet answered (their refusals on the
    /// estimator's gate are the summary's `usbl_fixes_rejected`).
    usbl_seqs: BTreeSet<u16>,
    /// The one-way latency of the tether (us): the vehicle's compass readings (and the
    /// DVL's, on [`DvlPath::Tether`]) reach the surface that much later.
    vehicle_fix_delay_us: u64,
    /// The DVL's path to the topside.
    dvl_path: DvlPath,
    // Setup.
    mode: Mode,
    reference: Reference,
    vehicle: controller_core::params::VehicleParams,
    onboard: OnboardConfig,
    pwm: PwmMap,
    /// The virtual time of the last pass (us).
    t_us: u64,
    cut_at_us: Option<u64>,
    // The harness's view of the node link.
    node_rx_dec: LinkDecoder<Downlink>,
    node_tx_dec: LinkDecoder<Uplink>,
    top_rx_dec: LinkDecoder<Uplink>,
    top_tx_dec: LinkDecoder<Downlink>,
    /// Uplink seq -> the node's latest IMU read when it was sent, and the one before the
    /// increments began (the previous uplink's), us.
    uplink_imu_us: HashMap<u16, (u64, u64)>,
    prev_uplink_imu_us: Option<u64>,
    /// Downlink seq -> what the topside sent and the uplink whose step made it.
    sent: HashMap<u16, (Downlink, Option<u16>)>,
    node_accepted: u16,
    /// The node's latest pass as the harness saw it.
    node_view: NodePass,
    /// The latest uplink's node counters, and the IMU intervals its uplinks carried and
    /// the time they cover (us).
    uplink_counters: Option<firmware::node_link::NodeCounters>,
    uplink_samples: u64,
    uplink_dt_us: u64,
    /// The emulated roles' pass times to come (frame arrivals, us).
    events: BTreeSet<u64>,
    report: LayoutReport,
}

/// The node as the harness saw it after its latest pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeView {
    /// Its three outputs (us).
    pub pulse_us: [u16; 3],
    /// Its status bits (`node_link::status`).
    pub status: u8,
    /// Armed.
    pub armed: bool,
}

impl NodeView {
    /// Armed.
    pub fn armed(&self) -> bool {
        self.armed
    }

    /// Its three outputs (us).
    pub fn output_us(&self) -> [u16; 3] {
        self.pulse_us
    }
}

impl TopsideLayout {
    /// Both roles booted at virtual time 0, joined by the wire of `sc`'s `[deployment]`.
    /// `sc` was checked when it was resolved, its `[deployment]` keys with it.
    pub fn for_scenario(sc: &RunSetup) -> Result<Self> {
        let d = sc.deployment;
        let clock = Rc::new(Cell::new(0u64));
        let config = Config {
            timing: Timing::FixedRate {
                control_period_us: FALLBACK_PERIOD_US,
                telemetry_period_us: 100_000,
            },
            ..Config::fixed_rate(Board::Host)
        };
        // The bridge is shared by the App's thrusters and sensors and the link for the
        // whole run, as the board's `static`: leaked (about 100 bytes a run).
        let bridge: &'static NodeBridge =
            Box::leak(Box::new(NodeBridge::new(config.pwm_period_us())));
        let mut controller = Controller::new(*sc.vehicle(), Gains::for_vehicle(sc.vehicle()))
            .map_err(|e| anyhow!("controller: {e}"))?;
        let told = (d.tell_delay || d.told_delay_s.is_some()).then(|| told_delay_s(&d));
        if let Some(t) = told {
            controller
                .set_measurement_delay_s(t as f32)
                .map_err(|e| anyhow!("deployment.tell_delay ({t} s): {e}"))?;
        }
        let app = App::with_sensors(
            bridge.thrusters(),
            SimSerial::default(),
            VClock(clock.clone()),
            controller,
            config,
            bridge.sensors(),
        )
        .map_err(|e| anyhow!("topside config: {e}"))?;
        let top_port = WirePort::default();
        let link_config = TopsideConfig {
            link_period_us: d.link_period_us(),
            imu_stamp: if d.stamp_node_time {
                ImuStamp::NodeSample
            } else {
                ImuStamp::Arrival
            },
            ..TopsideConfig::for_baud(LINK_SESSION, d.tether_baud)
        };
        let link = TopsideLink::new(bridge, top_port.clone(), link_config);
        let node_port = WirePort::default();
        let sensors = PlantSensors::default();
        let feed = sensors.shared.clone();
        let node_config = NodeConfig {
            imu_period_us: NODE_IMU_PERIOD_US,
            link_period_us: d.link_period_us(),
            ..NodeConfig::DEFAULT
        };
        // The DVL's line in memory takes no time per byte.
        let dvl_wire = DvlWire::default();
        let sensors = WithDvl {
            inner: sensors,
            dvl: DvlPort::new(dvl_wire.clone(), VelocityGate::default(), 0),
        };
        let node = Node::new(
            [SimPwm::default(), SimPwm::default(), SimPwm::default()],
            node_port.clone(),
            VClock(clock.clone()),
            sensors,
            node_config,
        )
        .map_err(|e| anyhow!("node config: {e}"))?;
        let roles = InProcessRoles {
            clock,
            app,
            link,
            bridge,
            node,
            feed,
            node_port,
            top_port,
            dvl_wire,
        };
        let mut layout = Self::with_roles(sc, Box::new(roles), told);
        layout.report.roles = layout.roles.describe().into();
        Ok(layout)
    }

    /// The two emulated images (`topside-emu`, `node-emu`), each booted in its own
    /// `qemu` (`qemu-system-arm -M netduinoplus2`), joined by the wire of `sc`'s
    /// `[deployment]`, stepped through their harness UARTs ([`EmulatedRoles`]). A delay told
    /// to the laws is refused (the tether protocol has no command for it; in process the
    /// controller is built with it).
    pub fn emulated(sc: &RunSetup, elfs: &LayoutElfs, qemu: &str) -> Result<Self> {
        let d = sc.deployment;
        if d.tell_delay || d.told_delay_s.is_some() {
            return Err(crate::checks::refused(anyhow!(
                "deployment.tell_delay / told_delay_s: the emulated topside cannot be told a \
                 delay (no tether command sets the laws' measurement delay); fly it \
                 --in-process or without the told delay"
            )));
        }
        // The images are built with the link's defaults (`NodeConfig::DEFAULT`,
        // `TopsideConfig::new`): a 20 ms period and increments stamped at arrival.
        let image_period_us = firmware::node_link::LINK_PERIOD_US;
        if d.link_period_us() != image_period_us || d.stamp_node_time {
            return Err(crate::checks::refused(anyhow!(
                "deployment.link_period_s = {} s / stamp_node_time = {}: the emulated images \
                 run the node link at {} s with increments stamped at arrival; set \
                 deployment.link_period_s = {} (and stamp_node_time = false) or fly --in-process",
                f64::from(d.link_period_us()) * 1e-6,
                d.stamp_node_time,
                f64::from(image_period_us) * 1e-6,
                f64::from(image_period_us) * 1e-6,
            )));
        }
        let roles = EmulatedRoles::start(elfs, qemu)?;
        let mut layout = Self::with_roles(sc, Box::new(roles), None);
        layout.report.roles = layout.roles.describe().into();
        Ok(layout)
    }

    /// The harness around `roles`, joined by the wire of `sc`'s `[deployment]`; `told`: the
    /// delay told to the laws (s), for the report.
    fn with_roles(sc: &RunSetup, roles: Box<dyn Roles>, told: Option<f64>) -> Self {
        let d = sc.deployment;
        Self {
            roles,
            wire: Duplex::new(d.wire(), d.tether_seed),
            pc_out: Vec::new(),
            pc: Client::default(),
            latest_telemetry: None,
            external: None,
            external_start_nav: false,
            next_heartbeat_us: 0,
            pending_pc: Vec::new(),
            usbl_seqs: BTreeSet::new(),
            vehicle_fix_delay_us: us(d.tether_latency_s),
            dvl_path: DvlPath::default(),
            mode: Mode::from(sc.mode()),
            reference: *sc.reference(),
            vehicle: sc.vehicle_params,
            onboard: onboard_config(sc),
            pwm: PwmMap::for_vehicle(sc.vehicle()),
            t_us: 0,
            cut_at_us: d.tether_cut_s.map(us),
            node_rx_dec: LinkDecoder::new(),
            node_tx_dec: LinkDecoder::new(),
            top_rx_dec: LinkDecoder::new(),
            top_tx_dec: LinkDecoder::new(),
            uplink_imu_us: HashMap::new(),
            prev_uplink_imu_us: None,
            sent: HashMap::new(),
            node_accepted: 0,
            node_view: NodePass {
                pulse_us: [1500; 3],
                ..NodePass::default()
            },
            uplink_counters: None,
            uplink_samples: 0,
            uplink_dt_us: 0,
            events: BTreeSet::new(),
            report: LayoutReport {
                baud: d.tether_baud,
                latency_s: d.tether_latency_s,
                corruption: d.tether_corruption,
                told_delay_s: told,
                ..LayoutReport::default()
            },
        }
    }

    /// The report so far (the node's and the topside's counters filled in).
    pub fn report(&self) -> LayoutReport {
        let mut r = self.report.clone();
        r.node_counters = self
            .roles
            .node_counters()
            .or(self.uplink_counters)
            .unwrap_or_default();
        r.topside_counters = self.roles.topside_counters().unwrap_or_default();
        r.down_wire = self.wire.down.counters();
        r.up_wire = self.wire.up.counters();
        r.round_trip_us = self.roles.round_trip_us();
        let l = &r.latency;
        r.latency_p50_p99_max_ms = l
            .quantile_ms(0.5)
            .zip(l.quantile_ms(0.99))
            .zip(l.quantile_ms(1.0))
            .map(|((a, b), c)| [a, b, c]);
        // In process, the node's IMU reads over the run; emulated, the IMU intervals its
        // uplinks integrated over the time they cover (the node's own count).
        let (reads, t_s) = match self.roles.node_imu_reads() {
            Some(n) => (n, self.t_us as f64 * 1e-6),
            None => (self.uplink_samples, self.uplink_dt_us as f64 * 1e-6),
        };
        r.node_imu_hz = if t_s > 0.0 { reads as f64 / t_s } else { 0.0 };
        r
    }

    /// The node as the harness saw it after its latest pass (outputs, arm state, status).
    pub fn node(&self) -> NodeView {
        NodeView {
            pulse_us: self.node_view.pulse_us,
            status: self.node_view.status,
            armed: self.node_view.armed,
        }
    }

    /// The in-process roles (the topside's App, the node itself); `None` when emulated.
    pub fn in_process(&self) -> Option<&InProcessRoles> {
        self.roles.in_process()
    }

    /// The topside's App, when it runs in this process.
    pub fn app(&self) -> Option<&TopsideApp> {
        self.roles.in_process().map(InProcessRoles::app)
    }

    /// Whether the topside is armed: its App in process, else its latest telemetry.
    pub fn topside_armed(&self) -> bool {
        match self.app() {
            Some(app) => app.autopilot().armed(),
            None => self.latest_telemetry.is_some_and(|t| t.armed),
        }
    }

    /// The topside layout's fault bits now (emulated: in the latest telemetry).
    pub fn link_faults(&self) -> u16 {
        self.roles
            .link_faults()
            .or(self.latest_telemetry.map(|t| t.faults))
            .unwrap_or(0)
    }

    /// What the roles are: "in process" or "emulated (QEMU)".
    pub fn roles(&self) -> &'static str {
        self.roles.describe()
    }

    /// The latest `Telemetry` the ground station received.
    pub fn latest_telemetry(&self) -> Option<&Telemetry> {
        self.latest_telemetry.as_ref()
    }

    /// The wire (a test cuts or restores it).
    pub fn wire_mut(&mut self) -> &mut Duplex {
        &mut self.wire
    }

    /// The DVL's path to the topside from now on.
    pub fn set_dvl_path(&mut self, path: DvlPath) {
        self.dvl_path = path;
    }

    /// A PC command sent at the next pass (a test disarms and arms again).
    pub fn queue_command(&mut self, cmd: Command) {
        self.pending_pc.push((0, cmd));
    }
}

/// The result of a topside-layout run.
#[derive(Debug, Clone, Default)]
pub struct LayoutOutput {
    /// Same as `host-sim run`.
    pub run: RunOutput,
    /// What the harness measured.
    pub report: LayoutReport,
}

/// Fly a scenario in the topside layout (`[deployment] control = "topside"`).
/// The layout changes the scenario's IMU rate and control period ([`layout_scenario`]), so
/// the changed scenario is resolved here.
pub fn run_layout(sc: &Scenario, opts: &RunOptions) -> Result<LayoutOutput> {
    run_layout_on(sc, opts, &LayoutTarget::InProcess)
}

/// Where the topside layout's two roles run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LayoutTarget {
    /// The firmware library's roles in this process ([`TopsideLayout::for_scenario`]).
    InProcess,
    /// The two emulated images, each in `qemu` ([`TopsideLayout::emulated`]).
    Emulated {
        /// The images.
        elfs: LayoutElfs,
        /// The QEMU binary (`qemu-system-arm`).
        qemu: String,
    },
}

/// [`run_layout`] with the roles on `target`.
pub fn run_layout_on(
    sc: &Scenario,
    opts: &RunOptions,
    target: &LayoutTarget,
) -> Result<LayoutOutput> {
    run_layout_dvl(sc, opts, target, DvlPath::default())
}

/// [`run_layout_on`] with the DVL on `dvl`.
pub fn run_layout_dvl(
    sc: &Scenario,
    opts: &RunOptions,
    target: &LayoutTarget,
    dvl: DvlPath,
) -> Result<LayoutOutput> {
    let sc = layout_scenario(sc).resolve()?;
    let mut endpoint = match target {
        LayoutTarget::InProcess => TopsideLayout::for_scenario(&sc)?,
        LayoutTarget::Emulated { elfs, qemu } => TopsideLayout::emulated(&sc, elfs, qemu)?,
    };
    endpoint.set_dvl_path(dvl);
    let mut nav =
        VehicleNav::for_scenario(&sc, opts.noise_seed.unwrap_or(sc.disturbance.noise_seed));
    let run = run_closed_loop(&sc, opts, &mut nav, &mut endpoint)?;
    Ok(LayoutOutput {
        run,
        report: endpoint.report(),
    })
}

/// `host-sim hil` of a scenario with `[deployment] control = "topside"`: the two roles on
/// `target` (the firmware library's in process, or the two emulated images in QEMU) over the
/// tether model, written as `host-sim run` writes (plus `layout.json`, this harness's
/// report).
pub fn hil_main(
    sc: &Scenario,
    target: &LayoutTarget,
    out: Option<std::path::PathBuf>,
    duration_s: Option<f64>,
) -> Result<LayoutOutput> {
    let opts = RunOptions {
        record: true,
        duration_s,
        ..RunOptions::default()
    };
    let o = run_layout_on(sc, &opts, target)?;
    let dir =
        out.unwrap_or_else(|| std::path::PathBuf::from("out").join(format!("hil-{}", sc.name)));
    std::fs::create_dir_all(&dir)?;
    crate::output::write_run(&dir, &o.run)?;
    std::fs::write(
        dir.join("layout.json"),
        serde_json::to_string_pretty(&o.report)? + "\n",
    )?;
    let s = &o.run.summary;
    let r = &o.report;
    println!(
        "{}: {} (topside layout {}, {} Bd, {} s one-way; RMS last 80 % {:.4} m; {:.1} s wall)",
        s.scenario,
        s.verdict,
        r.roles,
        r.baud,
        r.latency_s,
        s.rms_position_error_last80_m,
        s.wall_time_s
    );
    println!(
        "node link: {} downlinks applied, {} wrong; latency IMU sample -> pulse p50 {:.1} ms, \
         p99 {:.1} ms; node IMU {:.0} Hz; outputs in {}",
        r.downlinks_applied,
        r.wrong_commands_applied,
        r.latency.quantile_ms(0.5).unwrap_or(f64::NAN),
        r.latency.quantile_ms(0.99).unwrap_or(f64::NAN),
        r.node_imu_hz,
        dir.display()
    );
    Ok(o)
}
