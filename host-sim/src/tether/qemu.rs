//! The emulated board: QEMU `netduinoplus2` (an STM32F405) running the firmware's `qemu`
//! image, its USART1 on a TCP socket of 127.0.0.1, and where that image comes from.
//!
//! Used by `host-sim hil --qemu`, `host-sim link --qemu` and the emulated-board tests. A
//! machine without `qemu-system-arm` or without the `thumbv7em-none-eabihf` target gets
//! [`FirmwareImage::Unavailable`] with the command that fixes it, never a failed build.

use crate::tether::port::{tcp_port, Port};
use anyhow::{anyhow, bail, Context, Result};
use std::io::Write;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

/// What the emulated board's clock counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum QemuClock {
    /// The host's clock. A lock-step image takes its time from the host's frames, so a
    /// flight is the same either way; TIM2's ticks, and the firmware's loop figures read
    /// from them, are then nanoseconds of emulation, not instructions.
    Host,
    /// `-icount shift=0,align=off,sleep=off`: one nanosecond of emulated time per guest
    /// instruction, so TIM2 counts instructions and the firmware's loop figures are
    /// instruction counts (`host-sim hil --count-instructions`, `scripts/mcu-cost.sh`).
    /// QEMU's accounting slows a flight (docs/testing.md, "The emulated boards' cost").
    Instructions,
}

impl QemuClock {
    /// QEMU's arguments for this clock.
    fn args(self) -> &'static [&'static str] {
        match self {
            Self::Host => &[],
            Self::Instructions => &["-icount", "shift=0,align=off,sleep=off"],
        }
    }
}

/// A QEMU child that is killed when dropped.
pub struct QemuChild {
    child: Child,
    monitor_port: Option<u16>,
}

impl Drop for QemuChild {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl QemuChild {
    /// Start QEMU with `elf`, its first serial port connecting to `port` on 127.0.0.1.
    /// With `monitor`, QEMU's monitor listens on a free port of 127.0.0.1 (for
    /// [`QemuChild::dump_ram`]).
    pub fn start(
        qemu: &str,
        elf: &Path,
        port: u16,
        log: Option<&Path>,
        monitor: bool,
        clock: QemuClock,
    ) -> Result<Self> {
        Self::start_serials(qemu, elf, &[port], log, monitor, clock)
    }

    /// Start QEMU with `elf`, its serial ports (`-serial` 0, 1, ...: USART1, USART2, ... on
    /// `netduinoplus2`) connecting to `ports` on 127.0.0.1, in that order.
    pub fn start_serials(
        qemu: &str,
        elf: &Path,
        ports: &[u16],
        log: Option<&Path>,
        monitor: bool,
        clock: QemuClock,
    ) -> Result<Self> {
        if !elf.is_file() {
            bail!("firmware image {} not found", elf.display());
        }
        let out = match log {
            Some(p) => Stdio::from(
                std::fs::File::create(p)
                    .with_context(|| format!("cannot create {}", p.display()))?,
            ),
            None => Stdio::null(),
        };
        let monitor_port = if monitor {
            // A free port now; QEMU binds it a moment later (a small race, debug use only).
            Some(TcpListener::bind("127.0.0.1:0")?.local_addr()?.port())
        } else {
            None
        };
        let monitor_arg = match monitor_port {
            Some(p) => format!("tcp:127.0.0.1:{p},server=on,wait=off"),
            None => "none".into(),
        };
        let mut cmd = std::process::Command::new(qemu);
        cmd.args(["-M", "netduinoplus2", "-nographic", "-monitor"])
            .arg(monitor_arg)
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(clock.args());
        for port in ports {
            cmd.arg("-serial")
                .arg(format!("tcp:127.0.0.1:{port},nodelay=on"));
        }
        let child = cmd
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(out)
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| format!("cannot start {qemu}"))?;
        Ok(Self {
            child,
            monitor_port,
        })
    }

    /// Save the emulated STM32F405's 128 KiB of SRAM (0x2000_0000) to `path`, through the
    /// monitor (`pmemsave`). QEMU starts with RAM zeroed, so the stack below its deepest
    /// point is still zero: `scripts/mcu-cost.sh` reads the firmware's stack high-water
    /// from this dump.
    pub fn dump_ram(&mut self, path: &Path) -> Result<()> {
        use std::io::Read;
        let port = self
            .monitor_port
            .ok_or_else(|| anyhow!("QEMU was started without a monitor"))?;
        let abs = std::path::absolute(path)?;
        let _ = std::fs::remove_file(&abs);
        let mut m = std::net::TcpStream::connect(("127.0.0.1", port))
            .context("cannot connect to the QEMU monitor")?;
        m.set_read_timeout(Some(Duration::from_millis(200)))?;
        let read_until_prompt = |m: &mut std::net::TcpStream| {
            let deadline = Instant::now() + Duration::from_secs(5);
            let mut got = Vec::new();
            let mut buf = [0u8; 512];
            while Instant::now() < deadline && !got.ends_with(b"(qemu) ") {
                if let Ok(n) = m.read(&mut buf) {
                    got.extend_from_slice(&buf[..n]);
                }
            }
        };
        read_until_prompt(&mut m);
        writeln!(m, "pmemsave 0x20000000 0x20000 \"{}\"", abs.display())?;
        read_until_prompt(&mut m);
        let deadline = Instant::now() + Duration::from_secs(5);
        while std::fs::metadata(&abs).map(|md| md.len()).unwrap_or(0) < 0x20000 {
            if Instant::now() > deadline {
                bail!("QEMU did not write {}", abs.display());
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        Ok(())
    }

    fn exited(&mut self) -> Option<String> {
        match self.child.try_wait() {
            Ok(Some(st)) => {
                let mut err = String::new();
                if let Some(mut e) = self.child.stderr.take() {
                    use std::io::Read;
                    let _ = e.read_to_string(&mut err);
                }
                Some(format!("QEMU exited ({st}): {}", err.trim()))
            }
            _ => None,
        }
    }
}

/// The thumbv7em target the firmware images are built for.
pub const FIRMWARE_TARGET: &str = "thumbv7em-none-eabihf";

/// The firmware's `qemu` image, or why it cannot be had on this machine.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FirmwareImage {
    /// The image, built and current.
    Ready(PathBuf),
    /// QEMU or the target is missing: the reason and the command that fixes it.
    Unavailable(String),
}

/// The workspace this host-sim was built from (its `Cargo.toml` is there).
pub fn workspace_root() -> PathBuf {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().unwrap_or(manifest).to_path_buf()
}

fn command_ok(cmd: &mut std::process::Command) -> bool {
    cmd.stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

/// Whether the toolchain that builds the workspace at `root` has the firmware's target
/// (the standard library for it is in the sysroot). `rust-toolchain.toml` names the target,
/// so rustup normally installs it on the first cargo call; with rustup's auto-install off,
/// offline, or on a toolchain not managed by rustup it may be missing.
pub fn firmware_target_installed(root: &Path) -> bool {
    let rustc = std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into());
    std::process::Command::new(rustc)
        .current_dir(root)
        .args(["--print", "sysroot"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| {
            Path::new(String::from_utf8_lossy(&o.stdout).trim())
                .join("lib/rustlib")
                .join(FIRMWARE_TARGET)
                .is_dir()
        })
        .unwrap_or(false)
}

/// The firmware's `qemu` image for the emulated board: the image named by
/// `HIL_FIRMWARE_ELF`, else the image built from the workspace at `root` into
/// `<target>/hil-firmware` (`target` = `CARGO_TARGET_DIR` or `root/target`), so that a run
/// never uses a stale image (cargo rebuilds only what changed). `Unavailable` when
/// `qemu-system-arm` is not installed or the toolchain lacks the thumbv7em target; `Err`
/// when the build itself fails.
pub fn qemu_firmware_image(root: &Path) -> Result<FirmwareImage> {
    if let Some(why) = qemu_missing() {
        return Ok(FirmwareImage::Unavailable(why));
    }
    if let Some(p) = std::env::var_os("HIL_FIRMWARE_ELF") {
        return Ok(FirmwareImage::Ready(PathBuf::from(p)));
    }
    if let Some(why) = target_missing(root) {
        return Ok(FirmwareImage::Unavailable(why));
    }
    build_image(root, "firmware", "qemu", &[]).map(FirmwareImage::Ready)
}

/// Why QEMU cannot run here (with the fix), if it cannot.
fn qemu_missing() -> Option<String> {
    (!command_ok(std::process::Command::new("qemu-system-arm").arg("--version")))
        .then(|| "qemu-system-arm not found; fix: apt-get install -y qemu-system-arm".into())
}

/// Why the thumbv7em images cannot be built here (with the fix), if they cannot.
fn target_missing(root: &Path) -> Option<String> {
    (!firmware_target_installed(root)).then(|| {
        format!(
            "the Rust target {FIRMWARE_TARGET} is not installed; fix: rustup target add \
             {FIRMWARE_TARGET}"
        )
    })
}

/// The cargo profile of the emulated images.
pub const IMAGE_PROFILE: &str = "hil";

/// Build `bin` of `package` (with `features`) from the workspace at `root` into
/// `<target>/hil-firmware` (`target` = `CARGO_TARGET_DIR` or `root/target`) with the `hil`
/// profile (the release profile without debug information: `Cargo.toml`); its path.
fn build_image(root: &Path, package: &str, bin: &str, features: &[&str]) -> Result<PathBuf> {
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target"));
    let dir = if target.is_absolute() {
        target.join("hil-firmware")
    } else {
        root.join(target).join("hil-firmware")
    };
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = std::process::Command::new(cargo);
    cmd.current_dir(root)
        .args(["build", "-q", "-p", package, "--bin", bin])
        .args(["--profile", IMAGE_PROFILE, "--target", FIRMWARE_TARGET])
        .arg("--target-dir")
        .arg(&dir);
    if !features.is_empty() {
        cmd.args(["--features", &features.join(",")]);
    }
    let st = cmd
        .status()
        .with_context(|| format!("running cargo build for the {bin} image"))?;
    if !st.success() {
        bail!("building the {bin} image ({package}) failed ({st})");
    }
    Ok(dir.join(FIRMWARE_TARGET).join(IMAGE_PROFILE).join(bin))
}

/// The two emulated images of the topside layout: `topside-emu` (crate
/// `firmware`, feature `topside-board`) and `node-emu` (crate `node-firmware`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutElfs {
    /// The topside image.
    pub topside: PathBuf,
    /// The node image.
    pub node: PathBuf,
}

/// The topside layout's images, or why they cannot be had here.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LayoutImages {
    /// Both images, built and current.
    Ready(LayoutElfs),
    /// QEMU or the target is missing: the reason and the command that fixes it.
    Unavailable(String),
}

/// Both images of the topside layout built from the workspace at `root` into
/// `<target>/hil-firmware` (cargo rebuilds only what changed), as
/// [`qemu_firmware_image`] builds the onboard one.
pub fn qemu_layout_images(root: &Path) -> Result<LayoutImages> {
    if let Some(why) = qemu_missing().or_else(|| target_missing(root)) {
        return Ok(LayoutImages::Unavailable(why));
    }
    Ok(LayoutImages::Ready(LayoutElfs {
        topside: build_image(root, "firmware", "topside-emu", &["topside-board"])?,
        node: build_image(root, "node-firmware", "node-emu", &[])?,
    }))
}

/// For the tests: the topside layout's images, or `None` after printing `SKIPPED: <reason>;
/// fix: <command>`; with `ROV_REQUIRE_QEMU` set (CI) a missing emulator or target fails.
pub fn layout_images_or_skip() -> Result<Option<LayoutElfs>> {
    match qemu_layout_images(&workspace_root())? {
        LayoutImages::Ready(e) => Ok(Some(e)),
        LayoutImages::Unavailable(why) => skip_or_fail(&why).map(|()| None),
    }
}

/// Print `SKIPPED: why`, or fail with it under `ROV_REQUIRE_QEMU`.
fn skip_or_fail(why: &str) -> Result<()> {
    if std::env::var_os("ROV_REQUIRE_QEMU").is_some() {
        bail!("ROV_REQUIRE_QEMU is set, but the emulated-board test cannot run: {why}");
    }
    println!("SKIPPED: {why}");
    eprintln!("SKIPPED: {why}");
    Ok(())
}

/// For the tests: the firmware image, or `None` after printing `SKIPPED: <reason>; fix:
/// <command>`. With `ROV_REQUIRE_QEMU` set (CI) a missing emulator or target fails instead.
pub fn image_or_skip() -> Result<Option<PathBuf>> {
    match qemu_firmware_image(&workspace_root())? {
        FirmwareImage::Ready(p) => Ok(Some(p)),
        FirmwareImage::Unavailable(why) => skip_or_fail(&why).map(|()| None),
    }
}

/// Start QEMU with the firmware image `elf` and accept its serial connection on a port of
/// 127.0.0.1 bound here first (no race). The child is killed when the guard is dropped.
pub fn start_qemu_link(
    qemu: &str,
    elf: &Path,
    log: Option<&Path>,
    monitor: bool,
    clock: QemuClock,
) -> Result<(QemuChild, Box<dyn Port>)> {
    let listener = TcpListener::bind("127.0.0.1:0").context("cannot bind 127.0.0.1:0")?;
    let port = listener.local_addr()?.port();
    let mut q = QemuChild::start(qemu, elf, port, log, monitor, clock)?;
    let deadline = Instant::now() + Duration::from_secs(30);
    let stream = accept_from(&mut q, &listener, port, deadline)?;
    Ok((q, Box::new(tcp_port(stream)?)))
}

/// The onboard image's three serial ports on sockets of 127.0.0.1 bound here first: the
/// tether (USART1) as a [`Port`], the DVL's UART (USART2) and the health inputs' UART
/// (USART3) as streams the host writes (`board_wires`). The child is killed when the guard
/// is dropped.
pub fn start_qemu_board(
    qemu: &str,
    elf: &Path,
    log: Option<&Path>,
    monitor: bool,
    clock: QemuClock,
) -> Result<(
    QemuChild,
    Box<dyn Port>,
    std::net::TcpStream,
    std::net::TcpStream,
)> {
    let (q, streams) = connected_serials(qemu, elf, 3, log, monitor, clock)?;
    let mut it = streams.into_iter();
    match (it.next(), it.next(), it.next()) {
        (Some(tether), Some(dvl), Some(health)) => {
            Ok((q, Box::new(tcp_port(tether)?), dvl, health))
        }
        _ => bail!("QEMU did not connect its three serial ports"),
    }
}

/// The connection QEMU makes to `listener` (on `port`), by `deadline`; an error as soon as
/// the emulator exits. The stream is blocking.
fn accept_from(
    q: &mut QemuChild,
    listener: &TcpListener,
    port: u16,
    deadline: Instant,
) -> Result<std::net::TcpStream> {
    listener.set_nonblocking(true)?;
    let stream = loop {
        match listener.accept() {
            Ok((s, _)) => break s,
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                if let Some(why) = q.exited() {
                    bail!("{why}");
                }
                if Instant::now() > deadline {
                    bail!("QEMU did not connect to 127.0.0.1:{port} within 30 s");
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e).context("accept"),
        }
    };
    stream.set_nonblocking(false)?;
    Ok(stream)
}

/// Start QEMU with `elf` and `serials` serial ports (`-serial` 0.. in order: USART1,
/// USART2, USART3 on `netduinoplus2`), each accepted on a port of 127.0.0.1 bound here
/// first; every read on them times out after `read_timeout` (a hung emulator is an error,
/// not a hang). The board runs on the host's clock (no instruction counts are read from
/// these images). The child is killed when the guard is dropped.
pub fn start_qemu_serials(
    qemu: &str,
    elf: &Path,
    serials: usize,
    log: Option<&Path>,
    read_timeout: Duration,
) -> Result<(QemuChild, Vec<std::net::TcpStream>)> {
    let (q, streams) = connected_serials(qemu, elf, serials, log, false, QemuClock::Host)?;
    for stream in &streams {
        stream.set_nodelay(true)?;
        stream.set_read_timeout(Some(read_timeout))?;
    }
    Ok((q, streams))
}

/// Start QEMU with `elf` and `count` serial ports, each on a port of 127.0.0.1 bound here
/// first, and accept QEMU's connection to each (blocking streams, in `-serial` order).
fn connected_serials(
    qemu: &str,
    elf: &Path,
    count: usize,
    log: Option<&Path>,
    monitor: bool,
    clock: QemuClock,
) -> Result<(QemuChild, Vec<std::net::TcpStream>)> {
    let listeners = (0..count)
        .map(|_| TcpListener::bind("127.0.0.1:0").context("cannot bind 127.0.0.1:0"))
        .collect::<Result<Vec<_>>>()?;
    let ports = listeners
        .iter()
        .map(|l| Ok(l.local_addr()?.port()))
        .collect::<Result<Vec<_>>>()?;
    let mut q = QemuChild::start_serials(qemu, elf, &ports, log, monitor, clock)?;
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut streams = Vec::new();
    for (l, &port) in listeners.iter().zip(&ports) {
        streams.push(accept_from(&mut q, l, port, deadline)?);
    }
    Ok((q, streams))
}
