//! How the topside starts (`host-sim topside`): its arguments, the vehicle behind the tether
//! (`--sim`: the scenario's closed loop with the firmware library in process, or with
//! `--emulated` the firmware image in QEMU; `--serial`: a real vehicle), the ground stations,
//! the logs and the saved parameters; then `Topside::run` until the end.
//!
//! The saved parameters never stop a start: a file that cannot be read or is refused by the
//! checks is said (log and `STATUSTEXT`) and the vehicle's values stay; a group that differs
//! from what the vehicle holds is sent, and one the vehicle refuses now (a description while
//! its estimator runs or while armed) waits ([`Pending`]), tried again every second and
//! applied when the vehicle takes it, the operator told either way.

use super::commander::Commander;
use super::missions::Missions;
use super::params::{Group, Settings};
use super::transport::Gcs;
use super::vehicle::SimVehicle;
use super::{open_logs, params, Topside};
use crate::scenario::deployment::Control;
use crate::scenario::{RunSetup, Scenario};
use crate::tether::endpoint::HilTarget;
use crate::tether::in_process::InProcessFirmware;
use crate::tether::qemu::{
    qemu_firmware_image, qemu_layout_images, start_qemu_link, workspace_root, FirmwareImage,
    LayoutImages,
};
use crate::tether::topside_layout::{layout_scenario, TopsideLayout};
use crate::world::sensors::NavSource;
use anyhow::{anyhow, bail, Result};
use firmware::protocol::ManualThrust;
use mavlink::dialects::ardupilotmega::MavSeverity;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Saved parameters waiting for the vehicle to take them, said again this often.
const PENDING_REMINDER: Duration = Duration::from_secs(30);

/// Saved parameter groups the vehicle refused at start: the saved values and the groups
/// still to apply.
#[derive(Debug, Default)]
pub(super) struct Pending {
    saved: Option<Settings>,
    groups: Vec<Group>,
    said_at: Option<Instant>,
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
    pub(super) fn retry(&mut self, v: &mut SimVehicle, gcs: &mut Gcs) -> Result<()> {
        let Some(saved) = self.saved else {
            return Ok(());
        };
        let mut waiting = Vec::new();
        let mut last_why = None;
        for g in std::mem::take(&mut self.groups) {
            match v.apply(saved, g)? {
                Ok(()) => {
                    let text = format!("Saved {g:?} parameters applied");
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
                    "Saved {:?} parameters wait: the vehicle refuses them now ({why:?}); \
                     applied when it takes them",
                    self.groups
                );
                eprintln!("topside: {text}");
                gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
            }
        }
        Ok(())
    }
}

/// `host-sim topside` options.
#[derive(clap::Args, Debug, Clone)]
pub struct TopsideArgs {
    /// The simulated vehicle: a built-in scenario or a .toml file (its plant, navigation and
    /// start; the reference is not used: the ground station commands). Its `[deployment]
    /// control` chooses the layout: `"topside"` flies the topside MCU's App and its node.
    #[arg(long, required_unless_present_any = ["serial", "tcp"], conflicts_with_all = ["serial", "tcp"])]
    pub sim: Option<String>,
    /// A real vehicle on this serial device (`/dev/ttyUSB0`): it runs on its own clock and
    /// navigates itself; the topside sends it heartbeats and the ground stations' commands.
    #[arg(long, value_name = "DEV", conflicts_with_all = ["emulated", "speedup"])]
    pub serial: Option<PathBuf>,
    /// A vehicle at HOST:PORT (`host-sim vehicle --listen`, a serial-to-TCP bridge): the
    /// same byte stream as --serial.
    #[arg(long, value_name = "HOST:PORT", conflicts_with_all = ["serial", "emulated"])]
    pub tcp: Option<String>,
    /// With --serial: the baud rate.
    #[arg(long, default_value_t = 115_200, requires = "serial")]
    pub baud: u32,
    /// MAVLink address: udpout:HOST:PORT (to a ground station listening, QGroundControl's
    /// default 14550), udpin:HOST:PORT, tcpin:HOST:PORT, tcpout:HOST:PORT. Give it again
    /// for more ground stations: each gets everything the vehicle says, and one at a time
    /// commands (see `commander`).
    #[arg(long, default_value = "udpout:127.0.0.1:14550")]
    pub mavlink: Vec<String>,
    /// Run the simulated vehicle this many times faster than real time.
    #[arg(long, default_value_t = 1.0)]
    pub speedup: f64,
    /// Stop after this much simulated time (s); default: run until stopped.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Where the .tlog goes: each start a new file beside this name, time-stamped
    /// (`out/topside-20261126-101500.tlog`, UTC); an existing file is never truncated.
    #[arg(long, default_value = "out/topside.tlog")]
    pub tlog: PathBuf,
    /// MAVLink system id of the vehicle.
    #[arg(long, default_value_t = 1)]
    pub system_id: u8,
    /// Run the vehicle's firmware image in QEMU (the emulated STM32F405, lock-step) instead of
    /// the firmware library in process; the plant stays simulated here. With a scenario of
    /// the topside layout: its two images (topside-emu, node-emu), each in QEMU.
    #[arg(long)]
    pub emulated: bool,
    /// With --emulated: this image (default: the workspace's `qemu` image, built if needed).
    #[arg(long, value_name = "ELF", requires = "emulated")]
    pub qemu: Option<PathBuf>,
    /// The parameters set from the ground station: restored from this file at start, saved
    /// to it after every accepted `PARAM_SET`.
    #[arg(long, default_value = "out/topside-params.json")]
    pub params: PathBuf,
    /// The vehicle's description (a vehicle file, `vehicles/observer.toml`'s format): sent
    /// to the vehicle at start, and the simulated vehicle's body. Default: the scenario's.
    #[arg(long)]
    pub vehicle: Option<PathBuf>,
    /// Where the raw tether log goes (every byte both ways, time-stamped; `tether_log`).
    /// Default: the `.tlog`'s time-stamped name with the extension `.tether`; a name given
    /// here is time-stamped the same way.
    #[arg(long)]
    pub tether_log: Option<PathBuf>,
}

/// Run the topside until `--duration` (or forever).
pub fn main(a: TopsideArgs) -> Result<()> {
    let vehicle_file = a
        .vehicle
        .as_deref()
        .map(crate::scenario::vehicle::load)
        .transpose()?;
    if !(a.speedup.is_finite() && a.speedup > 0.0) {
        bail!("--speedup must be > 0 (got {})", a.speedup);
    }
    // The scenario first: a scenario refused creates no log.
    let scenario = match &a.sim {
        None => None,
        // Checked once; with --vehicle, the scenario file, then the set-up with that vehicle.
        Some(sim) => Some(match vehicle_file {
            None => Scenario::load_setup(sim)?,
            Some(p) => {
                let mut sc = Scenario::load(sim)?;
                sc.vehicle_params = p;
                sc.resolve()?
            }
        }),
    };
    if let Some(sc) = &scenario {
        if sc.deployment.control == Control::Topside && a.qemu.is_some() {
            return Err(crate::checks::refused(anyhow!(
                "{}: deployment.control = \"topside\" with --qemu ELF: the topside layout is two \
                 images (topside-emu and node-emu, built from the workspace); give --emulated \
                 without --qemu",
                sc.name
            )));
        }
    }
    let (tlog, tlog_path, tether_path) = open_logs(&a.tlog, a.tether_log.as_deref())?;
    let gcs = Gcs::open(&a.mavlink, a.system_id, tlog)?;
    // The QEMU child lives as long as this guard.
    let mut _qemu = None;
    let (v, what) = if let Some(addr) = &a.tcp {
        let port = crate::tether::port::open(&crate::tether::port::Endpoint::Tcp(addr.clone()))?;
        let port = Box::new(crate::tether::tether_log::LoggedPort::new(
            port,
            &tether_path,
        )?);
        (
            SimVehicle::real(port, vehicle_file)?,
            format!("vehicle at tcp:{addr}"),
        )
    } else if let Some(device) = &a.serial {
        let port = crate::tether::port::serial_port(device, a.baud)?;
        let port = Box::new(crate::tether::tether_log::LoggedPort::new(
            port,
            &tether_path,
        )?);
        let v = SimVehicle::real(port, vehicle_file)?;
        (
            v,
            format!("vehicle on {} at {} Bd", device.display(), a.baud),
        )
    } else {
        let Some(sc) = scenario else {
            bail!("--sim SCENARIO or --serial DEV");
        };
        if sc.deployment.control == Control::Topside {
            let (v, what) = topside_layout_vehicle(&sc, &tether_path, a.emulated)?;
            return run_topside(&a, gcs, v, what, &tlog_path, &tether_path);
        }
        let (port, target, hello_wait, firmware): (Box<dyn crate::tether::port::Port>, _, _, _) =
            if a.emulated {
                let elf = match a.qemu.clone() {
                    Some(elf) => elf,
                    None => match qemu_firmware_image(&workspace_root())? {
                        FirmwareImage::Ready(elf) => elf,
                        FirmwareImage::Unavailable(why) => {
                            bail!("the emulated board cannot run here: {why}")
                        }
                    },
                };
                let (q, p) = start_qemu_link("qemu-system-arm", &elf, None, false)?;
                _qemu = Some(q);
                (
                    p,
                    HilTarget::Qemu { elf: elf.clone() },
                    Duration::from_secs(30),
                    format!("firmware image {} in QEMU", elf.display()),
                )
            } else {
                (
                    Box::new(InProcessFirmware::new()?),
                    HilTarget::InProcess,
                    Duration::from_secs(2),
                    "firmware library in process".to_string(),
                )
            };
        let port = Box::new(crate::tether::tether_log::LoggedPort::new(
            port,
            &tether_path,
        )?);
        let truth = tether_path.with_extension("truth.csv");
        let v = SimVehicle::new(&sc, port, target, hello_wait, &truth)?;
        let what = format!(
            "simulated vehicle {:?} ({}, navigation: {}), {firmware}, truth log {}",
            sc.name,
            sc.plane.as_str(),
            if sc.navigation.source == NavSource::Estimator {
                "its own estimator on the simulated sensors"
            } else {
                "the true state sent"
            },
            truth.display()
        );
        (v, what)
    };
    run_topside(&a, gcs, v, what, &tlog_path, &tether_path)
}

/// The simulated vehicle of a scenario with `[deployment] control = "topside"`: the topside
/// layout ([`TopsideLayout`]) in the scenario's closed loop, as `host-sim run` and `hil
/// --in-process` fly it (`layout_scenario`: the node's 400 Hz IMU, the loop at its period).
/// The ground stations talk to the topside App, as they would to the topside board.
fn topside_layout_vehicle(
    sc: &RunSetup,
    tether_path: &Path,
    emulated: bool,
) -> Result<(SimVehicle, String)> {
    let sc = layout_scenario(sc).resolve()?;
    let (layout, roles) = if emulated {
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
    let truth = tether_path.with_extension("truth.csv");
    let v = SimVehicle::topside_layout(&sc, layout, &truth)?;
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

/// The saved parameters restored, then the topside's loop.
fn run_topside(
    a: &TopsideArgs,
    mut gcs: Gcs,
    mut v: SimVehicle,
    what: String,
    tlog_path: &Path,
    tether_path: &Path,
) -> Result<()> {
    let mut pending = Pending::default();
    if a.params.exists() {
        match params::load(&a.params, v.settings) {
            Err(e) => {
                let text = format!("Saved parameters not used: {e:#}");
                eprintln!("topside: {text}");
                gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
            }
            Ok(saved) => {
                // Only what differs is sent; what the vehicle refuses now waits.
                pending.groups = params::GROUPS
                    .into_iter()
                    .filter(|&g| !v.settings.same_group(&saved, g))
                    .collect();
                pending.saved = Some(saved);
                pending.retry(&mut v, &mut gcs)?;
                eprintln!(
                    "topside: parameters restored from {}{}",
                    a.params.display(),
                    if pending.groups.is_empty() {
                        String::new()
                    } else {
                        format!(" except {:?} (waiting for the vehicle)", pending.groups)
                    }
                );
            }
        }
    }
    eprintln!(
        "topside: {what}, MAVLink on {}, tlog {}, tether log {}",
        a.mavlink.join(", "),
        tlog_path.display(),
        tether_path.display()
    );
    let mut t = Topside {
        gcs,
        v,
        commander: Commander::default(),
        missions: Missions::default(),
        manual: ManualThrust::default(),
        manual_at: None,
        guided: false,
        last_faults: 0,
        mag_cal: None,
        params_file: a.params.clone(),
        sticks_seen_centred: false,
        pending,
        vehicle_silent: false,
        refusals_said: 0,
    };
    t.run(a)
}
