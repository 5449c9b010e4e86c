//! How the surface program starts (`rov-topside`): its arguments, the vehicle behind the
//! tether (`--serial DEV[:BAUD]` or `--tcp HOST:PORT`: the same byte stream, a real vehicle or a
//! simulated one served by `host-sim vehicle`), the ground stations, the logs and the saved
//! parameters; then `Topside::run` until the end.
//!
//! The saved parameters never stop a start: a file that cannot be read or is refused by the
//! checks is said (log and `STATUSTEXT`) and the vehicle's values stay; a group that differs
//! from what the vehicle holds is sent, and one the vehicle refuses now (a description while
//! its estimator runs or while armed) waits ([`Pending`]), tried again every second and
//! applied when the vehicle takes it, the operator told either way.

use super::commander::Commander;
use super::logs::open_logs;
use super::missions::Missions;
use super::options::{SurfaceOptions, TopsideArgs};
use super::params;
use super::params::Group;
use super::pending::Pending;
use super::topside::Topside;
use super::transport::Gcs;
use super::vehicle::Vehicle;
use crate::refusal::refused;
use anyhow::Result;
use mavlink::dialects::ardupilotmega::MavSeverity;
use protocol::ManualThrust;
use std::path::Path;
use std::time::Duration;

/// The longest a read of the vehicle's port waits for a byte: the surface's loop drains what
/// has arrived every control period, and a vehicle that talks faster than the port's usual
/// 20 ms wait (a simulated one served faster than real time) must not hold it there.
const DRAIN_POLL: Duration = Duration::from_millis(1);

/// Run the surface program until `--duration` (or forever): the vehicle on the link given.
pub fn main(a: TopsideArgs) -> Result<()> {
    // The inputs first: an input refused creates no log.
    let vehicle_file = a
        .surface
        .vehicle
        .as_deref()
        .map(crate::vehicle_file::load)
        .transpose()
        .map_err(refused)?;
    let endpoint = a.link.endpoint()?;
    if !(1..=50).contains(&a.surface.heartbeat_hz) {
        return Err(refused(anyhow::anyhow!(
            "--heartbeat-hz {} outside 1-50",
            a.surface.heartbeat_hz
        )));
    }
    let heartbeat_hz = a.surface.heartbeat_hz;
    start_with(&a.surface, 1.0, |tether_path| {
        // Short reads: each control period drains what the vehicle said and goes on.
        let port = crate::port::open_with_poll(&endpoint, DRAIN_POLL)?;
        let port = Box::new(crate::tether_log::LoggedPort::new(port, tether_path)?);
        let what = match &endpoint {
            crate::port::Endpoint::Tcp(addr) => format!("vehicle at tcp:{addr}"),
            crate::port::Endpoint::Serial { device, baud } => {
                format!("vehicle on {} at {baud} Bd", device.display())
            }
        };
        Ok((Vehicle::real(port, vehicle_file, heartbeat_hz)?, what))
    })
}

/// Open the logs and the ground stations, get the vehicle from `vehicle` (given the tether
/// log's path), restore the saved parameters and run. `speedup` paces the surface's loop
/// against the vehicle's clock: 1 for a vehicle on its own clock.
pub fn start_with(
    o: &SurfaceOptions,
    speedup: f64,
    vehicle: impl FnOnce(&Path) -> Result<(Vehicle, String)>,
) -> Result<()> {
    if !(speedup.is_finite() && speedup > 0.0) {
        return Err(refused(anyhow::anyhow!(
            "the speed-up must be > 0 (got {speedup})"
        )));
    }
    let nav = super::navigation::SurfaceNav::open(&o.nav).map_err(refused)?;
    let (tlog, tlog_path, tether_path) = open_logs(&o.tlog, o.tether_log.as_deref())?;
    let saved_id = super::params_file::saved_system_id(&o.params);
    let system_id = o.system_id.or(saved_id).unwrap_or(1);
    let gcs = Gcs::open(&o.mavlink, system_id, tlog)?;
    let (v, what) = vehicle(&tether_path)?;
    run_topside(o, speedup, gcs, v, what, &tlog_path, &tether_path, nav)
}

/// The saved parameters restored, then the topside's loop.
#[allow(clippy::too_many_arguments)]
fn run_topside(
    a: &SurfaceOptions,
    speedup: f64,
    mut gcs: Gcs,
    mut v: Vehicle,
    what: String,
    tlog_path: &Path,
    tether_path: &Path,
    nav: super::navigation::SurfaceNav,
) -> Result<()> {
    let mut pending = Pending::default();
    // The vehicle flown: `--vehicle` wins over a saved description (said), else the saved
    // file's, else the vehicle's own.
    // The files by name in the ground stations' texts (50 characters a message), by path in
    // the log.
    let name = |p: &Path| {
        p.file_name().map_or_else(
            || p.display().to_string(),
            |n| n.to_string_lossy().to_string(),
        )
    };
    let mut flown = match &a.vehicle {
        Some(path) => format!("the vehicle of {}", name(path)),
        None => "the vehicle's own description".to_string(),
    };
    let params_used;
    if a.params.exists() {
        match super::params_file::load(&a.params, v.settings) {
            Err(e) => {
                let text = format!("Saved parameters not used: {e:#}");
                eprintln!("topside: {text}");
                gcs.text(MavSeverity::MAV_SEVERITY_WARNING, &text)?;
                params_used = format!("{} (not used: refused)", name(&a.params));
            }
            Ok(saved) => {
                // Only what differs is sent; what the vehicle refuses now waits.
                let mut groups: Vec<Group> = params::GROUPS
                    .into_iter()
                    .filter(|&g| !v.settings.same_group(&saved, g))
                    .collect();
                if a.vehicle.is_some() && groups.contains(&Group::Vehicle) {
                    groups.retain(|&g| g != Group::Vehicle);
                    let text = format!(
                        "--vehicle {} is flown: the saved VEH_* of {} not restored",
                        name(a.vehicle.as_deref().unwrap_or(Path::new(""))),
                        name(&a.params)
                    );
                    eprintln!("topside: {text}");
                    gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
                }
                let saved_vehicle = groups.contains(&Group::Vehicle);
                pending.groups = groups;
                pending.saved = Some(saved);
                pending.retry(&mut v, &mut gcs)?;
                if saved_vehicle && !pending.groups.contains(&Group::Vehicle) {
                    flown = format!("the vehicle saved in {}", name(&a.params));
                }
                params_used = format!(
                    "{} (restored{})",
                    name(&a.params),
                    if pending.groups.is_empty() {
                        String::new()
                    } else {
                        format!(
                            " except {}, waiting for the vehicle",
                            params::group_names(&pending.groups)
                        )
                    }
                );
            }
        }
    } else {
        params_used = format!("{} (none saved yet: the vehicle's values)", name(&a.params));
    }
    // SYSID_THISMAV shows the system id in force (`--system-id` wins over a saved one).
    let system_id = gcs.system_id();
    if let Some(saved) =
        super::params_file::saved_system_id(&a.params).filter(|&id| id != system_id)
    {
        let text = format!("--system-id {system_id} is used, not the saved SYSID_THISMAV {saved}");
        eprintln!("topside: {text}");
        gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
    }
    v.settings.surface.sysid_thismav = f32::from(system_id);
    let mass = v.settings.vehicle.mass_kg;
    let text = format!(
        "Flying {flown} (VEH_MASS {} kg) as MAVLink system {system_id}; parameters {params_used}",
        params::show(mass)
    );
    eprintln!("topside: {text} ({})", a.params.display());
    gcs.text(MavSeverity::MAV_SEVERITY_INFO, &text)?;
    eprintln!(
        "topside: {what}, MAVLink on {}, tlog {}, tether log {}",
        a.mavlink.join(", "),
        tlog_path.display(),
        tether_path.display()
    );
    let js_gain = v.settings.joystick.start_gain();
    let mut t = Topside {
        gcs,
        v,
        commander: Commander::default(),
        missions: Missions::default(),
        manual: ManualThrust::default(),
        manual_at: None,
        guided_target: None,
        streams: Default::default(),
        last_faults: 0,
        mag_cal: None,
        params_file: a.params.clone(),
        sticks_seen_centred: false,
        pending,
        vehicle_silent: false,
        refusals_said: 0,
        nav,
        motor_test_until: None,
        ident: None,
        js_gain,
        buttons: Default::default(),
        gcs_watch: Default::default(),
        dvl_sent_us: 0,
    };
    t.run(a, speedup)
}
