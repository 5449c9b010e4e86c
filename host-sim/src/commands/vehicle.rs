//! `host-sim vehicle SCENARIO --listen tcp:HOST:PORT`: the simulator serves a vehicle, as
//! ArduPilot's SITL does (`crate::served`): the scenario's plant, its sensors and the
//! firmware library's `App` in (scaled) real time, the vehicle's tether on a TCP port for a
//! surface program (`host-sim topside --tcp HOST:PORT`), the true state to
//! `OUT/<scenario>.truth.csv`.

use crate::checks::refused;
use crate::scenario::deployment::Control;
use crate::scenario::Scenario;
use crate::served::server::{bind, check, serve, ServeOptions};
use anyhow::{anyhow, Result};
use std::net::{SocketAddr, ToSocketAddrs};
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
    /// The firmware image in QEMU instead of the library (not served yet: refused).
    #[arg(long)]
    pub qemu: bool,
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
    };
    check(&o).map_err(refused)?;
    if a.qemu {
        return Err(refused(anyhow!(
            "--qemu: the firmware image is not served yet (the library in process is); \
             `host-sim topside --sim {} --emulated` flies the image in QEMU",
            sc.name
        )));
    }
    if sc.deployment.control == Control::Topside {
        return Err(refused(anyhow!(
            "{}: deployment.control = \"topside\": the topside layout is not served yet; \
             `host-sim topside --sim {}` flies it",
            sc.name,
            sc.name
        )));
    }
    let (listener, local) = bind(o.listen)?;
    println!(
        "vehicle: {} served on tcp:{local} (firmware library in process, {}x real time), \
         truth log {}",
        sc.name,
        o.speedup,
        crate::served::server::truth_path(&o.out, &sc.name).display()
    );
    use std::io::Write;
    std::io::stdout().flush()?;
    let rep = serve(&sc, &o, &listener)?;
    println!(
        "vehicle: {:.1} s simulated in {:.1} s of wall time ({:.2}x, {}x asked); late ticks \
         {}, largest lag {:.1} ms, slip {:.1} ms; surfaces served {}; vehicle inputs refused {}",
        rep.sim_s,
        rep.wall_s,
        rep.sim_s / rep.wall_s.max(1e-9),
        o.speedup,
        rep.late_ticks,
        rep.max_lag_s * 1e3,
        rep.slip_s * 1e3,
        rep.surfaces,
        rep.own_refused
    );
    if let Some(why) = rep.stopped {
        eprintln!("vehicle: the simulation stopped: {why}");
        return Ok(std::process::ExitCode::from(super::EXIT_NOT_AS_EXPECTED));
    }
    Ok(std::process::ExitCode::SUCCESS)
}
