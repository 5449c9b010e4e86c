//! `rov-topside`'s command line: where the vehicle is, and the surface's own options.

use crate::port::VehicleLink;
use std::path::PathBuf;

/// `rov-topside` options: where the vehicle is, and the surface's own.
#[derive(clap::Args, Debug, Clone)]
pub struct TopsideArgs {
    /// Where the vehicle is.
    #[command(flatten)]
    pub link: VehicleLink,
    /// The surface's own options.
    #[command(flatten)]
    pub surface: SurfaceOptions,
}

/// The surface program's options beside the vehicle's link.
#[derive(clap::Args, Debug, Clone)]
pub struct SurfaceOptions {
    /// MAVLink address: udpout:HOST:PORT (to a ground station listening, QGroundControl's
    /// default 14550), udpin:HOST:PORT, tcpin:HOST:PORT, tcpout:HOST:PORT. Give it again
    /// for more ground stations: each gets everything the vehicle says, and one at a time
    /// commands (see `commander`).
    #[arg(long, default_value = "udpout:127.0.0.1:14550")]
    pub mavlink: Vec<String>,
    /// Stop after this long (s); default: run until stopped.
    #[arg(long)]
    pub duration: Option<f64>,
    /// Where the .tlog goes: each start a new file beside this name, time-stamped
    /// (`out/topside-20261126-101500.tlog`, UTC); an existing file is never truncated.
    #[arg(long, default_value = "out/topside.tlog")]
    pub tlog: PathBuf,
    /// MAVLink system id of the vehicle (1-255). Without it, the saved `SYSID_THISMAV`
    /// (set from a ground station, taken at the next start), else 1.
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..))]
    pub system_id: Option<u8>,
    /// The parameters set from the ground station: restored from this file at start, saved
    /// to it after every accepted `PARAM_SET`.
    #[arg(long, default_value = "out/topside-params.json")]
    pub params: PathBuf,
    /// The vehicle's description (a vehicle file, `vehicles/observer.toml`'s format), sent
    /// to the vehicle at start. Without it the vehicle keeps its own.
    #[arg(long)]
    pub vehicle: Option<PathBuf>,
    /// The surface's heartbeat to the vehicle, per second (1-50): the vehicle's link failsafe
    /// trips after 0.5 s of its own time without one. A simulated vehicle served faster than
    /// real time needs it faster by as much.
    #[arg(long, default_value_t = 10)]
    pub heartbeat_hz: u32,
    /// Where the raw tether log goes (every byte both ways, time-stamped; `tether_log`).
    /// Default: the `.tlog`'s time-stamped name with the extension `.tether`; a name given
    /// here is time-stamped the same way.
    #[arg(long)]
    pub tether_log: Option<PathBuf>,
    /// The vehicle's navigation from the surface (USBL, the estimator's start).
    #[command(flatten)]
    pub nav: super::navigation::NavOptions,
}
