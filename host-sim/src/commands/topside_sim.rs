//! `host-sim topside --sim SCENARIO`: the surface program (the `topside` crate's, unchanged)
//! in front of a simulated vehicle flown in lock-step in this process, for what `host-sim
//! vehicle` does not serve yet: the firmware image in QEMU (`--emulated`) and the paper's
//! topside layout (`[deployment] control = "topside"`). Every other vehicle is flown the way
//! a real dive is: `host-sim vehicle SCENARIO --listen tcp:...` and `rov-topside --tcp ...`.
//!
//! The simulated vehicle is the one closed loop of every run ([`ClosedLoop`]) with the
//! controller of the scenario's layout as its endpoint: the firmware at the far end of the
//! tether ([`TetherEndpoint`], as `hil` drives it), or [`TopsideLayout`] (the topside MCU's
//! `App` with its node behind the node link; the surface's commands go to the topside App
//! over its PC tether). The surface program adds the ground stations' commands between the
//! steps; the true state beside what the vehicle says goes to a `.truth.csv` next to the
//! logs.

use crate::closed_loop::estimator_nav::navigation_for_vehicle;
use crate::closed_loop::{ClosedLoop, ControllerEndpoint, Navigation, RunOptions};
use crate::scenario::deployment::Control;
use crate::scenario::{RunSetup, Scenario};
use crate::tether::endpoint::{HilOptions, HilTarget, TetherEndpoint};
use crate::tether::link::Link;
use crate::tether::qemu::{
    qemu_firmware_image, qemu_layout_images, start_qemu_link, workspace_root, FirmwareImage,
    LayoutImages,
};
use crate::tether::topside_layout::{layout_scenario, TopsideLayout};
use anyhow::{anyhow, bail, Context, Result};
use protocol::{Command, NackReason, Status, Telemetry};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;
use topside::refusal::refused;
use topside::surface::params::Settings;
use topside::surface::{SurfaceOptions, Vehicle, VehicleEnd, TETHER_TIMEOUT};

/// `host-sim topside` options.
#[derive(clap::Args, Debug, Clone)]
pub struct TopsideSimArgs {
    /// The simulated vehicle: a built-in scenario or a .toml file (its plant, navigation and
    /// start; the reference is not used: the ground station commands), with `--emulated` or
    /// of the topside layout (`[deployment] control = "topside"`).
    #[arg(long)]
    pub sim: String,
    /// Run the vehicle's firmware image in QEMU (the emulated STM32F405, lock-step); with a
    /// scenario of the topside layout: its two images (topside-emu, node-emu).
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: this image (default: the workspace's `qemu` image, built if needed).
    #[arg(long, value_name = "ELF", requires = "emulated")]
    pub qemu: Option<PathBuf>,
    /// Run the simulated vehicle this many times faster than real time.
    #[arg(long, default_value_t = 1.0)]
    pub speedup: f64,
    /// The surface program's own options.
    #[command(flatten)]
    pub surface: SurfaceOptions,
}

/// The topside layout's sticks and truth rows: every this long (s), its topside's control
/// period (the node link's 50 Hz); 400 rows a second would be about 100 MB an hour.
const LAYOUT_STRIDE_S: f64 = 0.02;

/// The columns of the simulated vehicle's truth log.
pub const TRUTH_HEADER: &str = "t_s,x_m,y_m,z_m,yaw_rad,nav_x_m,nav_y_m,nav_z_m,nav_yaw_rad,armed";

/// Run the surface program in front of the scenario's vehicle until `--duration`.
pub fn main(a: TopsideSimArgs) -> Result<()> {
    // The scenario first: a scenario refused creates no log.
    let sc = match &a.surface.vehicle {
        None => Scenario::load_setup(&a.sim).map_err(refused)?,
        Some(p) => {
            let mut sc = Scenario::load(&a.sim).map_err(refused)?;
            sc.vehicle_params = crate::scenario::vehicle::load(p).map_err(refused)?;
            sc.resolve().map_err(refused)?
        }
    };
    let layout = sc.deployment.control == Control::Topside;
    if layout && a.qemu.is_some() {
        return Err(refused(anyhow!(
            "{}: deployment.control = \"topside\" with --qemu ELF: the topside layout is two \
             images (topside-emu and node-emu, built from the workspace); give --emulated \
             without --qemu",
            sc.name
        )));
    }
    if !layout && !a.emulated {
        return Err(refused(anyhow!(
            "{}: the firmware library in process is served by `host-sim vehicle {} --listen \
             tcp:127.0.0.1:5760` and flown with `rov-topside --tcp 127.0.0.1:5760`, the path of \
             a real dive; `host-sim topside --sim` is for --emulated and topside-layout scenarios",
            sc.name,
            a.sim
        )));
    }
    // The QEMU child lives as long as this guard.
    let mut qemu = None;
    let surface = a.surface.clone();
    topside::surface::start_with(&surface, a.speedup, |tether_path| {
        let truth = tether_path.with_extension("truth.csv");
        if layout {
            return layout_vehicle(&sc, &truth, a.emulated);
        }
        let elf = match a.qemu.clone() {
            Some(elf) => elf,
            None => match qemu_firmware_image(&workspace_root())? {
                FirmwareImage::Ready(elf) => elf,
                FirmwareImage::Unavailable(why) => {
                    bail!("the emulated board cannot run here: {why}")
                }
            },
        };
        let (q, port) = start_qemu_link("qemu-system-arm", &elf, None, false)?;
        qemu = Some(q);
        let port = Box::new(topside::tether_log::LoggedPort::new(port, tether_path)?);
        let mut opts = HilOptions::new(HilTarget::Qemu { elf: elf.clone() });
        // The ground stations arm and choose the modes; the surface runs until stopped.
        opts.fly_scenario = false;
        opts.record = false;
        opts.telemetry_rows = false;
        opts.wall_limit = Duration::MAX;
        let endpoint = TetherEndpoint::connect(
            Link::new(port, None),
            &sc,
            &opts,
            "topside".into(),
            Duration::from_secs(30),
            true,
        )?;
        let v = simulated(&sc, endpoint, &truth, 1)?;
        Ok((
            v,
            format!(
                "simulated vehicle {:?} ({}), firmware image {} in QEMU, truth log {}",
                sc.name,
                sc.plane.as_str(),
                elf.display(),
                truth.display()
            ),
        ))
    })
}

/// The topside layout ([`TopsideLayout`]) in the scenario's closed loop, as `host-sim run`
/// and `hil --in-process` fly it; the ground stations talk to the topside App.
fn layout_vehicle(sc: &RunSetup, truth: &Path, emulated: bool) -> Result<(Vehicle, String)> {
    let sc = layout_scenario(sc).resolve()?;
    let (mut layout, roles) = if emulated {
        let elfs = match qemu_layout_images(&workspace_root())? {
            LayoutImages::Ready(elfs) => elfs,
            LayoutImages::Unavailable(why) => {
                bail!("the emulated topside layout cannot run here: {why}")
            }
        };
        (
            TopsideLayout::emulated(&sc, &elfs, "qemu-system-arm")?,
            "the images topside-emu and node-emu, each in QEMU, on the host's clock",
        )
    } else {
        (
            TopsideLayout::for_scenario(&sc)?,
            "firmware library in process",
        )
    };
    // The layout only gets the vehicle and starts its navigation; the ground stations arm.
    layout.ground_station_commands();
    let stride = (LAYOUT_STRIDE_S / sc.control_period_s).round().max(1.0) as u64;
    let v = simulated(&sc, layout, truth, stride)?;
    let d = sc.deployment;
    let what = format!(
        "simulated vehicle {:?} ({}) in the topside layout: the topside App and its node \
         ({roles}), node link {} Bd, {} s one-way; truth log {} (the tether log stays empty: \
         the harness holds the topside's tether)",
        sc.name,
        sc.plane.as_str(),
        d.tether_baud,
        d.tether_latency_s,
        truth.display()
    );
    Ok((v, what))
}

/// The controller endpoints a simulated vehicle can have: what the surface needs of each
/// beyond the loop's [`ControllerEndpoint`].
trait SimEndpoint: ControllerEndpoint {
    /// See [`VehicleEnd::command`].
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>>;
    /// See [`VehicleEnd::send`].
    fn send(&mut self, cmd: &Command) -> Result<()>;
    /// The latest telemetry the PC received.
    fn telemetry(&self) -> Option<Telemetry>;
    /// See [`VehicleEnd::last_status`].
    fn last_status(&mut self) -> Option<Status>;
    /// See [`VehicleEnd::frames_dropped`].
    fn frames_dropped(&self) -> u64;
}

/// The onboard layout: the firmware at the far end of a tether.
impl SimEndpoint for TetherEndpoint {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.link().command(cmd, TETHER_TIMEOUT, 3, |_| {})
    }
    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.link().send(cmd).map(|_| ())
    }
    fn telemetry(&self) -> Option<Telemetry> {
        Some(*self.latest())
    }
    fn last_status(&mut self) -> Option<Status> {
        self.link().last_status
    }
    fn frames_dropped(&self) -> u64 {
        self.link_stats().frames_dropped
    }
}

/// The topside layout: the topside App's PC tether is in memory (it cannot drop a frame);
/// a command runs at once in the topside App, the sticks go at its next pass.
impl SimEndpoint for TopsideLayout {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.try_command(cmd)
    }
    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.queue_command(*cmd);
        Ok(())
    }
    fn telemetry(&self) -> Option<Telemetry> {
        self.latest_telemetry().copied()
    }
    fn last_status(&mut self) -> Option<Status> {
        self.latest_status().copied()
    }
    fn frames_dropped(&self) -> u64 {
        0
    }
}

/// A simulated vehicle: the scenario's closed loop with `E` as its controller; the true
/// state beside what the vehicle said, to `truth`, every `stride` periods.
struct Simulated<E: SimEndpoint> {
    run: ClosedLoop<Box<dyn Navigation>, E>,
    truth: BufWriter<File>,
    stride: u64,
    last: Telemetry,
}

impl<E: SimEndpoint> VehicleEnd for Simulated<E> {
    fn command(&mut self, cmd: &Command) -> Result<std::result::Result<(), NackReason>> {
        self.run.endpoint_mut().command(cmd)
    }

    fn send(&mut self, cmd: &Command) -> Result<()> {
        self.run.endpoint_mut().send(cmd)
    }

    /// One step of the closed loop (the lock-step exchange, the plant through the period
    /// with the thrust of the pulse widths), its truth logged.
    fn step(&mut self, periods: u64) -> Result<(f64, Option<Telemetry>)> {
        let run = &mut self.run;
        if !run.step()? {
            bail!("the simulated vehicle stopped: {}", run.stop_reason());
        }
        let tel = run.endpoint().telemetry();
        if let Some(t) = tel {
            self.last = t;
        }
        let every = self.stride;
        if !periods.is_multiple_of(every) {
            return Ok((run.t_s(), tel));
        }
        let s = run.sample();
        let (x, n) = (&s.state.eta, &self.last.nav);
        writeln!(
            self.truth,
            "{:.3},{:.4},{:.4},{:.4},{:.5},{:.4},{:.4},{:.4},{:.5},{}",
            s.t_s,
            x[0],
            x[1],
            x[2],
            x[5],
            n.x_m,
            n.y_m,
            n.z_m,
            n.yaw_rad,
            u8::from(self.last.armed)
        )?;
        // A killed surface loses at most a second of it.
        let per_second = (1.0 / run.period_s()).round().max(1.0) as u64;
        if (periods / every).is_multiple_of((per_second / every).max(1)) {
            self.truth.flush()?;
        }
        Ok((run.t_s(), tel))
    }

    fn period_s(&self) -> f64 {
        self.run.period_s()
    }

    fn last_status(&mut self) -> Option<Status> {
        self.run.endpoint_mut().last_status()
    }

    fn frames_dropped(&self) -> u64 {
        self.run.endpoint().frames_dropped()
    }
}

/// The scenario's closed loop with `endpoint`, its first control period run; the sticks
/// and the truth rows every `stride` periods.
fn simulated<E: SimEndpoint + 'static>(
    sc: &RunSetup,
    endpoint: E,
    truth: &Path,
    stride: u64,
) -> Result<Vehicle> {
    let run_opts = RunOptions {
        open_ended: true,
        ..RunOptions::default()
    };
    let run = ClosedLoop::new(sc, &run_opts, navigation_for_vehicle(sc), endpoint)?;
    // Beside the time-stamped logs of this start: never an existing file.
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(truth)
        .with_context(|| format!("create {}", truth.display()))?;
    let mut truth = BufWriter::new(file);
    writeln!(truth, "{TRUTH_HEADER}")?;
    let end = Simulated {
        run,
        truth,
        stride,
        last: Telemetry::default(),
    };
    // The endpoint sends the scenario's vehicle at the start.
    Vehicle::with_end(Box::new(end), Settings::new(sc.vehicle_params), stride)
}
