//! The two MCUs of the topside layout behind one interface, so that one harness
//! ([`super::TopsideLayout`]: the wire, the PC, the watched bytes, the report) drives either
//! the firmware library's roles in this process ([`InProcessRoles`]) or the two emulated
//! images in QEMU ([`super::emulated::EmulatedRoles`]).
//!
//! The harness gives each MCU the bytes the wire delivered before a pass and takes what it
//! wrote in the pass; what each MCU read and wrote is returned so the harness decodes it
//! (without changing it) for the latency, wrong-command and cut figures.

use super::ports::{PlantSensors, SensorFeed, VClock, WirePort};
use crate::tether::in_process::{SimPwm, SimSerial};
use anyhow::Result;
use controller_core::nav::{DvlFix, ImuSample};
use controller_core::state::{BodyForces, NavState, TrackingErrors};
use firmware::node::Node;
use firmware::node_link::NodeCounters;
use firmware::protocol::Telemetry;
use firmware::sensors::dvl::WithDvl;
use firmware::topside_link::{LinkSensors, LinkThruster, NodeBridge, TopsideCounters, TopsideLink};
use firmware::App;
use sim_world::sensors::DvlWire;
use std::cell::{Cell, RefCell};
use std::rc::Rc;

/// One pass of each MCU's main loop every this much virtual time (us).
pub const PASS_US: u64 = 100;

/// The node's IMU period (us): the node samples at 400 Hz.
pub const NODE_IMU_PERIOD_US: u32 = 2_500;

/// The topside's App: its thrusters and sensors the node link.
pub type TopsideApp = App<LinkThruster<'static>, SimSerial, VClock, LinkSensors<'static>>;
/// The node role on the simulated PWM outputs, wire port, virtual clock, plant sensors and
/// the simulated DVL's serial line.
pub type NodeRole = Node<SimPwm, WirePort, VClock, WithDvl<PlantSensors, DvlWire>>;

/// What one pass of the node did, as the harness sees it.
#[derive(Debug, Clone, Default)]
pub struct NodePass {
    /// The node-link bytes the node read in the pass.
    pub read: Vec<u8>,
    /// The node-link bytes it wrote (onto the wire's uplink).
    pub written: Vec<u8>,
    /// Its three outputs after the pass (us).
    pub pulse_us: [u16; 3],
    /// Its status bits (`node_link::status`) after the pass.
    pub status: u8,
    /// Downlinks it has applied (its counter, wrapping).
    pub accepted: u16,
    /// Armed after the pass.
    pub armed: bool,
    /// The time of its latest IMU read (us), if one.
    pub imu_read_us: Option<u64>,
}

/// What one pass of the topside did.
#[derive(Debug, Clone, Default)]
pub struct TopsidePass {
    /// The node-link bytes the topside read.
    pub link_read: Vec<u8>,
    /// The node-link bytes it wrote (onto the wire's downlink).
    pub link_written: Vec<u8>,
    /// The tether bytes it wrote to the PC.
    pub tether_written: Vec<u8>,
    /// An accepted uplink ran a control step in the pass.
    pub stepped: bool,
}

/// The topside's latest control step, as the loop records it.
#[derive(Debug, Clone, Copy, Default)]
pub struct ControlView {
    /// Forces the law asked for.
    pub requested: BodyForces,
    /// Forces the allocated thrusts make.
    pub achieved: BodyForces,
    /// Thrusts commanded (N).
    pub thrust_n: [f32; 3],
    /// The law's tracking errors.
    pub errors: TrackingErrors,
    /// The App's fault bits.
    pub faults: u16,
    /// The estimate the laws used.
    pub nav: NavState,
    /// Its position standard deviation (m).
    pub position_std_m: [f32; 3],
}

impl ControlView {
    /// The same from the ground station's latest `Telemetry` (the emulated topside: the App
    /// is inside QEMU; its telemetry is sent every 100 ms).
    pub fn from_telemetry(t: &Telemetry) -> Self {
        Self {
            requested: t.requested,
            achieved: t.achieved,
            thrust_n: t.thrust_n,
            errors: t.errors,
            faults: t.faults,
            nav: t.nav,
            position_std_m: t.nav_pos_std_m,
        }
    }
}

/// The topside and the node as the harness drives them.
pub trait Roles {
    /// One pass of both at `t_us` (never before the previous pass): the node, `node_in`
    /// (from the wire) delivered to its node-link receiver first; the topside's loop,
    /// `tether_in` (from the PC) and `top_in` (from the wire) delivered first. Neither
    /// pass's input depends on the other's output at the same time (the wire takes time).
    fn pass(
        &mut self,
        t_us: u64,
        node_in: &[u8],
        tether_in: &[u8],
        top_in: &[u8],
    ) -> Result<(NodePass, TopsidePass)>;
    /// The PC's bytes handled at `t_us` without moving time on (the set-up's commands,
    /// answered at once); what the topside did (its tether answer; emulated, its loop may
    /// also have written to the node link).
    fn topside_tether(&mut self, t_us: u64, tether_in: &[u8]) -> Result<TopsidePass>;
    /// Run the node at the pass at `t_us` even without bytes for it (a failsafe's time);
    /// the in-process node runs at every pass anyway.
    fn wake_node_at(&mut self, _t_us: u64) {}
    /// An IMU sample of the plant (available to the node from its time stamp on).
    fn push_imu(&mut self, s: ImuSample);
    /// A pressure conversion of the plant at `t_us` (Pa).
    fn push_pressure(&mut self, t_us: u64, pressure_pa: f32);
    /// A reading of the vehicle's DVL: its A50 report on the node's DVL UART, which the
    /// node parses, gates and carries in its next uplink.
    fn push_dvl(&mut self, fix: &DvlFix);
    /// One pass of both every this much time (us), or `None`: passes at the times the
    /// harness's events need (the node's IMU times, the loop's ticks, frame arrivals).
    fn pass_period_us(&self) -> Option<u64>;
    /// The topside's latest control step, when the harness can read it directly (`None`:
    /// from the telemetry).
    fn control(&self) -> Option<ControlView>;
    /// The node's IMU reads so far, when the harness can count them (`None`: from the
    /// uplinks' sample counts).
    fn node_imu_reads(&self) -> Option<u64>;
    /// The node's counters now (`None`: the latest uplink's).
    fn node_counters(&self) -> Option<NodeCounters>;
    /// The topside link's counters, if readable.
    fn topside_counters(&self) -> Option<TopsideCounters>;
    /// The round trip the topside measured last (us), if readable.
    fn round_trip_us(&self) -> Option<u32>;
    /// The topside layout's fault bits now, if readable (`None`: from the telemetry).
    fn link_faults(&self) -> Option<u16>;
    /// The in-process roles (their App and node), if these are.
    fn in_process(&self) -> Option<&InProcessRoles> {
        None
    }
    /// What the roles are, for the reports.
    fn describe(&self) -> &'static str;
}

/// The firmware library's topside and node in this process, on one virtual clock.
pub struct InProcessRoles {
    pub(super) clock: Rc<Cell<u64>>,
    pub(super) app: TopsideApp,
    pub(super) link: TopsideLink<'static, WirePort>,
    pub(super) bridge: &'static NodeBridge,
    pub(super) node: NodeRole,
    pub(super) feed: Rc<RefCell<SensorFeed>>,
    pub(super) node_port: WirePort,
    pub(super) top_port: WirePort,
    /// The node's DVL UART (the node's `DvlPort` reads the other end).
    pub(super) dvl_wire: DvlWire,
}

impl InProcessRoles {
    /// The topside's App.
    pub fn app(&self) -> &TopsideApp {
        &self.app
    }

    /// The node.
    pub fn node(&self) -> &NodeRole {
        &self.node
    }
}

impl InProcessRoles {
    fn node_pass(&mut self, t_us: u64, link_in: &[u8]) -> NodePass {
        self.clock.set(t_us);
        self.node_port
            .rx
            .borrow_mut()
            .extend(link_in.iter().copied());
        self.node.tick();
        let read: Vec<u8> = self.node_port.read_log.borrow_mut().drain(..).collect();
        let written: Vec<u8> = self.node_port.tx.borrow_mut().drain(..).collect();
        NodePass {
            read,
            written,
            pulse_us: self.node.output_us(),
            status: self.node.status(t_us),
            accepted: self.node.counters().accepted,
            armed: self.node.armed(),
            imu_read_us: self.feed.borrow().last_imu_read_us,
        }
    }

    /// The topside board's loop: `app.tick()`, an accepted uplink runs `app.step_now()`,
    /// `link.send_if_due()`.
    fn topside_pass(&mut self, t_us: u64, tether_in: &[u8], link_in: &[u8]) -> TopsidePass {
        self.clock.set(t_us);
        self.top_port
            .rx
            .borrow_mut()
            .extend(link_in.iter().copied());
        self.app.parts_mut().1.rx.extend(tether_in.iter().copied());
        self.app.tick();
        let armed = self.app.autopilot().armed();
        let stepped = self.link.poll(t_us, armed);
        let link_read: Vec<u8> = self.top_port.read_log.borrow_mut().drain(..).collect();
        if stepped {
            self.app.step_now();
        }
        self.link.send_if_due(t_us, armed);
        let link_written: Vec<u8> = self.top_port.tx.borrow_mut().drain(..).collect();
        let tether_written: Vec<u8> = self.app.parts_mut().1.tx.drain(..).collect();
        TopsidePass {
            link_read,
            link_written,
            tether_written,
            stepped,
        }
    }
}

impl Roles for InProcessRoles {
    /// The node's pass, then the topside's.
    fn pass(
        &mut self,
        t_us: u64,
        node_in: &[u8],
        tether_in: &[u8],
        top_in: &[u8],
    ) -> Result<(NodePass, TopsidePass)> {
        let np = self.node_pass(t_us, node_in);
        let tp = self.topside_pass(t_us, tether_in, top_in);
        Ok((np, tp))
    }

    /// `app.tick()` only (the App answers the PC; the node link waits for the next pass).
    fn topside_tether(&mut self, t_us: u64, tether_in: &[u8]) -> Result<TopsidePass> {
        self.clock.set(t_us);
        self.app.parts_mut().1.rx.extend(tether_in.iter().copied());
        self.app.tick();
        Ok(TopsidePass {
            tether_written: self.app.parts_mut().1.tx.drain(..).collect(),
            ..TopsidePass::default()
        })
    }

    fn push_imu(&mut self, s: ImuSample) {
        self.feed.borrow_mut().imu.push_back(s);
    }

    fn push_pressure(&mut self, t_us: u64, pressure_pa: f32) {
        self.feed
            .borrow_mut()
            .pressure
            .push_back((t_us, pressure_pa));
    }

    fn push_dvl(&mut self, fix: &DvlFix) {
        self.dvl_wire.send_wrz(fix);
    }

    fn pass_period_us(&self) -> Option<u64> {
        Some(PASS_US)
    }

    fn control(&self) -> Option<ControlView> {
        let out = self.app.last_output();
        let std = self
            .app
            .autopilot()
            .onboard_nav()
            .map_or([0.0; 3], |o| o.position_std_m());
        Some(ControlView {
            requested: out.requested,
            achieved: out.allocation.achieved,
            thrust_n: out.allocation.thrust_n,
            errors: out.errors,
            faults: out.faults,
            nav: self.app.autopilot().nav_state(),
            position_std_m: std,
        })
    }

    fn node_imu_reads(&self) -> Option<u64> {
        Some(self.feed.borrow().imu_reads)
    }

    fn node_counters(&self) -> Option<NodeCounters> {
        Some(self.node.counters())
    }

    fn topside_counters(&self) -> Option<TopsideCounters> {
        Some(self.link.counters())
    }

    fn round_trip_us(&self) -> Option<u32> {
        self.link.round_trip_us()
    }

    fn link_faults(&self) -> Option<u16> {
        Some(self.bridge.faults())
    }

    fn in_process(&self) -> Option<&InProcessRoles> {
        Some(self)
    }

    fn describe(&self) -> &'static str {
        "in process"
    }
}
