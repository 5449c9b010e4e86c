//! `host-sim vehicle SCENARIO --listen tcp:HOST:PORT`: the simulator serves a vehicle, as
//! ArduPilot's SITL does (`crate::served`): the scenario's plant, its sensors and the
//! firmware (the library's `App` in process, `--qemu`: the image in QEMU; a topside-layout
//! scenario: the topside MCU and its node, in process or, `--qemu`, the two images) in
//! (scaled) real time, the vehicle's tether on a TCP port for a surface program
//! (`rov-topside --tcp HOST:PORT`), the true state to `OUT/<scenario>.truth.csv`.

use crate::checks::refused;
use crate::served::endpoint::ServedEndpoint;
use crate::served::image::ServedImage;
use crate::served::layout::ServedLayout;
use crate::served::server::{bind, check, serve, ServeOptions};
use crate::served::vehicle::ServedVehicle;
use crate::tether::qemu::{
    qemu_firmware_image, qemu_layout_images, workspace_root, FirmwareImage, LayoutImages,
};
use crate::tether::topside_layout::{layout_scenario, LayoutTarget};
use anyhow::{anyhow, Result};
use sim_scenario::deployment::Control;
use sim_scenario::setup::RunSetup;
use sim_scenario::Scenario;
use std::net::{SocketAddr, TcpListener, ToSocketAddrs};
use std::path::PathBuf;

/// `host-sim vehicle` options.
#[derive(Debug, clap::Args)]
pub struct VehicleArgs {
    /// The vehicle: a built-in scenario or a .toml file (its plant, sensors, navigation and
    /// start; its reference is not flown: the surface commands).
    pub scenario: String,
    /// Where the tether is served: tcp:HOST:PORT. Port 0: a free port, printed on stdout.
    #[arg(long, default_value = "tcp:127.0.0.1:5760")]
    pub listen: String,
    /// Simulated time runs this many times faster than the wall clock (>= 1). The vehicle's
    /// failsafes run on its simulated clock: the surface's heartbeat period times this must
    /// stay below the vehicle's heartbeat timeout (0.5 s by default).
    #[arg(long, default_value_t = 1.0)]
    pub speedup: f64,
    /// Stop after this much simulated time (s), exit 0; default: run until stopped.
    #[arg(long)]
    pub duration: Option<f64>,
    /// The folder of the truth log (`<scenario>.truth.csv`: the true state every control
    /// period beside what the vehicle believes).
    #[arg(long, default_value = "out/vehicle")]
    pub out: PathBuf,
    /// With `[navigation] source = "estimator"`: the vehicle starts its own estimator at the
    /// launch point at boot (otherwise the surface starts it with `StartNav`).
    #[arg(long)]
    pub start_nav: bool,
    /// The simulated USBL at the surface sends its fixes as `$PSIMSSB` NMEA sentences to this
    /// UDP address (`HOST:PORT`, the surface program's `--usbl udpin:...`), as a real USBL
    /// does; without it the fixes go into the vehicle's own inputs. The folder of the truth
    /// log also gets what the operator knows of the dive: `<scenario>.launch` (the surface's
    /// `--launch`) and `<scenario>.nav-config.json` (its `--nav-config`).
    #[arg(long, value_name = "HOST:PORT")]
    pub usbl_to: Option<String>,
    /// The simulated clock stands at time 0 until the first surface connects, as ArduPilot's
    /// SITL waits on its first serial port (the files the surface needs, `.launch` and
    /// `.nav-config.json`, are written before): the dive starts with its surface, however
    /// long the surface took to start.
    #[arg(long)]
    pub wait_surface: bool,
    /// The firmware image in QEMU instead of the library: ELF, or without one the `qemu`
    /// image built from this workspace (as `host-sim hil` builds it). A topside-layout
    /// scenario: its two images (topside-emu, node-emu) built from the workspace (no ELF).
    #[arg(long, num_args = 0..=1, value_name = "ELF")]
    pub qemu: Option<Option<PathBuf>>,
    /// The QEMU binary.
    #[arg(long, default_value = "qemu-system-arm")]
    pub qemu_bin: String,
}

/// `tcp:HOST:PORT` as one socket address.
fn listen_addr(s: &str) -> Result<SocketAddr> {
    let hp = s
        .strip_prefix("tcp:")
        .ok_or_else(|| anyhow!("--listen {s}: give tcp:HOST:PORT"))?;
    hp.to_socket_addrs()
        .map_err(|e| anyhow!("--listen {s}: {e}"))?
        .next()
        .ok_or_else(|| anyhow!("--listen {s}: no address"))
}

/// Serve until `--duration` (or forever).
pub fn main(a: VehicleArgs) -> Result<std::process::ExitCode> {
    let sc = Scenario::load_setup(&a.scenario).map_err(refused)?;
    let listen = listen_addr(&a.listen).map_err(refused)?;
    let o = ServeOptions {
        listen,
        speedup: a.speedup,
        duration_s: a.duration,
        out: a.out.clone(),
        start_nav: a.start_nav,
        usbl_to: a.usbl_to.clone(),
        wait_surface: a.wait_surface,
    };
    check(&o).map_err(refused)?;
    let layout = sc.deployment.control == Control::Topside;
    if let (true, Some(Some(elf))) = (layout, &a.qemu) {
        return Err(refused(anyhow!(
            "{}: deployment.control = \"topside\" is two images (topside-emu, node-emu), \
             built from the workspace: give --qemu without an ELF ({} names one)",
            sc.name,
            elf.display()
        )));
    }
    if o.usbl_to.is_some() && (layout || a.qemu.is_some()) {
        return Err(refused(anyhow!(
            "--usbl-to: the USBL as NMEA is served with the firmware library in process only; \
             the image in QEMU and the topside layout take its fixes as the vehicle's inputs"
        )));
    }
    // What is served, decided (and the images found or built) before the port is taken.
    let served = match (layout, a.qemu) {
        (false, None) => Served::Library,
        (false, Some(elf)) => {
            let elf = match elf {
                Some(elf) => elf,
                None => match qemu_firmware_image(&workspace_root())? {
                    FirmwareImage::Ready(elf) => elf,
                    FirmwareImage::Unavailable(why) => {
                        return Err(refused(anyhow!(
                            "--qemu: the emulated board cannot run here: {why} (serve the \
                             library in process: leave out --qemu)"
                        )))
                    }
                },
            };
            if !elf.is_file() {
                return Err(refused(anyhow!("--qemu {}: no such file", elf.display())));
            }
            Served::Image(elf)
        }
        (true, None) => Served::Layout(LayoutTarget::InProcess),
        (true, Some(_)) => match qemu_layout_images(&workspace_root())? {
            LayoutImages::Ready(elfs) => Served::Layout(LayoutTarget::Emulated {
                elfs,
                qemu: a.qemu_bin.clone(),
            }),
            LayoutImages::Unavailable(why) => {
                return Err(refused(anyhow!(
                    "--qemu: the emulated boards cannot run here: {why} (serve the layout in \
                     process: leave out --qemu)"
                )))
            }
        },
    };
    let (listener, local) = bind(o.listen)?;
    std::fs::create_dir_all(&o.out)?;
    match served {
        Served::Library => {
            let mut vehicle = ServedVehicle::new(&sc, o.start_nav)?;
            if let Some(to) = &o.usbl_to {
                vehicle.set_usbl_out(crate::served::usbl_out::UsblOut::new(to, o.speedup)?);
            }
            run(&sc, &o, &listener, local, vehicle)
        }
        Served::Image(elf) => {
            let log = o.out.join(format!("{}.qemu-stdout.bin", sc.name));
            let image = ServedImage::start(&sc, &elf, &a.qemu_bin, Some(&log), o.start_nav)?;
            run(&sc, &o, &listener, local, image)
        }
        Served::Layout(target) => {
            let sc = layout_scenario(&sc).resolve()?;
            let layout = ServedLayout::new(&sc, &target, o.start_nav)?;
            run(&sc, &o, &listener, local, layout)
        }
    }
}

/// What `host-sim vehicle` serves.
enum Served {
    /// The firmware library's `App` in process.
    Library,
    /// The `qemu` image in QEMU.
    Image(PathBuf),
    /// The topside layout's two MCUs.
    Layout(LayoutTarget),
}

/// Serve `endpoint` on `listener` (bound to `local`); the summary on stdout.
fn run<E: ServedEndpoint>(
    sc: &RunSetup,
    o: &ServeOptions,
    listener: &TcpListener,
    local: SocketAddr,
    endpoint: E,
) -> Result<std::process::ExitCode> {
    println!(
        "vehicle: {} served on tcp:{local} ({}, {}x real time), truth log {}",
        sc.name,
        endpoint.describe(),
        o.speedup,
        crate::served::server::truth_path(&o.out, &sc.name).display()
    );
    use std::io::Write;
    std::io::stdout().flush()?;
    let rep = serve(sc, o, listener, endpoint)?;
    println!(
        "vehicle: {:.1} s simulated in {:.1} s of wall time ({:.2}x, {}x asked); late ticks \
         {}, largest lag {:.1} ms, slip {:.1} ms; waited {:.2} s for the first surface; surfaces \
         served {}; vehicle inputs refused {}",
        rep.sim_s,
        rep.wall_s,
        rep.sim_s / rep.wall_s.max(1e-9),
        o.speedup,
        rep.late_ticks,
        rep.max_lag_s * 1e3,
        rep.slip_s * 1e3,
        rep.waited_s,
        rep.surfaces,
        rep.own_refused
    );
    if let Some(why) = rep.stopped {
        eprintln!("vehicle: the simulation stopped: {why}");
        return Ok(std::process::ExitCode::from(super::EXIT_NOT_AS_EXPECTED));
    }
    Ok(std::process::ExitCode::SUCCESS)
}
