//! The served vehicle's controller end in the topside layout (`[deployment] control =
//! "topside"`, the paper's layout): the topside MCU's App and its node behind the node link
//! as [`TopsideLayout`] models them (in process, or the two images in QEMU), the topside's
//! PC tether the surface's byte stream through the [`TetherBridge`].
//!
//! In this layout the surface program is the PC next to the topside box: its frames reach
//! the topside App as a real PC's would, and the App answers them. The instruments' readings
//! that reach the topside over that tether in the layout (the compass, the DVL, the USBL)
//! are the vehicle's own inputs of the bridge, in the same session, as for the onboard App.
//! The node's faults (link lost, node not armed) are in the topside's `Status` and
//! `Telemetry`, as on the boards.

use super::bridge::TetherBridge;
use super::endpoint::{Believed, ServedEndpoint};
use crate::closed_loop::{ControllerEndpoint, StepReply};
use crate::tether::topside_layout::{ExternalPc, LayoutTarget, TopsideLayout};
use anyhow::Result;
use controller_core::reference::RefSample;
use controller_core::state::NavState;
use firmware::protocol::Command;
use sim_scenario::setup::RunSetup;
use sim_world::sensors::Measurement;
use std::cell::RefCell;
use std::rc::Rc;

/// A truth row every this long (s): the topside's control period (the node link's 50 Hz);
/// the layout's loop runs at the node's 400 Hz.
const TRUTH_ROW_S: f64 = 0.02;

/// The topside's PC tether as the served loop and the layout share it.
#[derive(Debug, Default)]
struct SurfacePc {
    bridge: TetherBridge,
    surface_in: Vec<u8>,
    surface_out: Vec<u8>,
}

/// The layout's end of [`SurfacePc`].
struct SharedPc(Rc<RefCell<SurfacePc>>);

impl ExternalPc for SharedPc {
    /// The instruments' inputs held while the bridge's session opened, those due now, then
    /// the surface's bytes.
    fn to_topside(&mut self, _t_us: u64, inputs: &[Command]) -> Result<Vec<u8>> {
        let mut pc = self.0.borrow_mut();
        let mut out = pc.bridge.held()?;
        out.extend(pc.bridge.own_inputs(inputs)?);
        let from_surface = std::mem::take(&mut pc.surface_in);
        out.extend(pc.bridge.from_surface(&from_surface)?);
        Ok(out)
    }

    fn topside_wrote(&mut self, bytes: &[u8]) -> Result<()> {
        let mut pc = self.0.borrow_mut();
        let out = pc.bridge.from_app(bytes)?;
        pc.surface_out.extend(out);
        Ok(())
    }
}

/// The topside layout as the served loop's controller end.
pub struct ServedLayout {
    layout: TopsideLayout,
    pc: Rc<RefCell<SurfacePc>>,
    stride: u64,
    what: &'static str,
}

impl ServedLayout {
    /// The layout of `sc` (the scenario as the layout flies it:
    /// `topside_layout::layout_scenario`) with its roles on `target`; `start_nav`: the
    /// topside starts its estimator at the launch point (else the surface starts it).
    pub fn new(sc: &RunSetup, target: &LayoutTarget, start_nav: bool) -> Result<Self> {
        let (layout, what) = match target {
            LayoutTarget::InProcess => (
                TopsideLayout::for_scenario(sc)?,
                "topside layout: the topside App and its node in process",
            ),
            LayoutTarget::Emulated { elfs, qemu } => (
                TopsideLayout::emulated(sc, elfs, qemu)?,
                "topside layout: topside-emu and node-emu, each in QEMU netduinoplus2",
            ),
        };
        let pc = Rc::new(RefCell::new(SurfacePc::default()));
        let layout = layout.with_external_pc(Box::new(SharedPc(pc.clone())), start_nav);
        let stride = (TRUTH_ROW_S / sc.control_period_s).round().max(1.0) as u64;
        Ok(Self {
            layout,
            pc,
            stride,
            what,
        })
    }

    /// The layout (its report, the node as the harness sees it).
    pub fn layout(&self) -> &TopsideLayout {
        &self.layout
    }
}

impl ControllerEndpoint for ServedLayout {
    fn start(&mut self, nav0: &NavState) -> Result<()> {
        self.layout.start(nav0)
    }

    fn step(&mut self, t_s: f64, nav: &NavState, reference: &RefSample) -> Result<StepReply> {
        self.layout.step(t_s, nav, reference)
    }

    fn usbl_fixes_rejected(&self) -> Option<u64> {
        self.layout.usbl_fixes_rejected()
    }

    fn forward(&mut self, measurements: &[Measurement]) -> Result<()> {
        self.layout.forward(measurements)
    }
}

impl ServedEndpoint for ServedLayout {
    fn describe(&self) -> String {
        self.what.into()
    }

    fn surface_sent(&mut self, bytes: &[u8]) {
        self.pc.borrow_mut().surface_in.extend_from_slice(bytes);
    }

    fn take_surface_out(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.pc.borrow_mut().surface_out)
    }

    /// In process, the topside App's own state; emulated, its latest telemetry.
    fn believed(&self) -> Believed {
        let shown = self.pc.borrow().bridge.shown();
        if let Some(app) = self.layout.app() {
            let ap = app.autopilot();
            return Believed {
                nav: ap.nav_state(),
                armed: ap.armed(),
                mode: Believed::mode_name(&ap.mode()),
                shown,
            };
        }
        self.layout
            .latest_telemetry()
            .map(|t| Believed {
                nav: t.nav,
                armed: t.armed,
                mode: Believed::mode_name(&t.mode),
                shown,
            })
            .unwrap_or_default()
    }

    fn own_refused(&self) -> u64 {
        self.pc.borrow().bridge.own_refused
    }

    fn truth_stride(&self) -> u64 {
        self.stride
    }
}
