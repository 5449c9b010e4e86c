//! The served vehicle's main loop: the closed loop with a [`ServedEndpoint`] as its
//! controller (the firmware library in process, the image in QEMU, the topside layout),
//! paced to the wall clock, its tether on a TCP port for one surface at a time, the true
//! state to a CSV.
//!
//! Pacing: simulated time runs `speedup` times the wall clock, never faster. When the
//! machine cannot keep up, the simulated clock waits for the wall clock, never the reverse:
//! a tick that starts more than a control period (of wall time, at least [`LATE_MIN`]) late
//! is counted, its lag is added to the slip, and the schedule restarts from it (no longer
//! burst to catch up, which would run the vehicle's failsafe timers fast against the
//! surface's heartbeats).
//!
//! The tether: one surface at a time; another that connects meanwhile is closed at once.
//! A surface that disconnects is a cut tether: the vehicle's bytes are lost until the next
//! one connects, and its own failsafes act meanwhile (heartbeat lost: neutral, then
//! disarmed).

use super::endpoint::ServedEndpoint;
use crate::closed_loop::estimator_nav::navigation_for_vehicle;
use crate::closed_loop::{ClosedLoop, Navigation, RunOptions};
use anyhow::{bail, Context, Result};
use sim_scenario::setup::RunSetup;
use std::fs::File;
use std::io::{BufWriter, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The columns of the truth log, one row per control period.
pub const TRUTH_HEADER: &str = "t_s,wall_s,x_m,y_m,z_m,roll_rad,pitch_rad,yaw_rad,\
nav_x_m,nav_y_m,nav_z_m,nav_yaw_rad,armed,mode,surface,shown_t_s,shown_x_m,shown_y_m,shown_z_m";

/// The lag is noted on stderr at most this often while the machine cannot keep up.
const LAG_NOTE_EVERY: Duration = Duration::from_secs(10);

/// A tick is late (counted, and the schedule restarts from it) when it starts more than a
/// control period of wall time late, and never at less than this: a loop finer than the
/// machine's sleep granularity (the topside layout's 2.5 ms) catches up a few ticks at once,
/// a burst far inside the failsafes' timeouts.
const LATE_MIN: Duration = Duration::from_millis(10);

/// How often the listener is polled while the clock waits for the first surface.
const WAIT_POLL: Duration = Duration::from_millis(2);

/// Bytes for a surface that does not read, at most: past this it is disconnected.
const MAX_UNSENT: usize = 1 << 20;

/// How the vehicle is served.
#[derive(Debug, Clone)]
pub struct ServeOptions {
    /// The address to listen on (port 0: any free one).
    pub listen: SocketAddr,
    /// Simulated time per wall time (>= 1).
    pub speedup: f64,
    /// Stop after this much simulated time (s); `None`: until stopped.
    pub duration_s: Option<f64>,
    /// The truth log's folder.
    pub out: PathBuf,
    /// The vehicle starts its own estimator at the launch point.
    pub start_nav: bool,
    /// The simulated USBL's NMEA to this UDP address (`HOST:PORT`), for the surface program;
    /// `None`: its fixes go into the vehicle's inputs.
    pub usbl_to: Option<String>,
    /// The simulated clock stands at its first tick until the first surface connects (as
    /// ArduPilot's SITL waits on its first serial port): a dive starts with its surface,
    /// however long the surface took to start.
    pub wait_surface: bool,
}

/// What a served run did.
#[derive(Debug, Clone, Default)]
pub struct ServeReport {
    /// Simulated time (s).
    pub sim_s: f64,
    /// Wall time (s).
    pub wall_s: f64,
    /// Ticks that started more than a control period of wall time late.
    pub late_ticks: u64,
    /// The largest lag of a tick (s of wall time).
    pub max_lag_s: f64,
    /// The wall time the schedule slipped by, in all (s).
    pub slip_s: f64,
    /// The wall time the clock stood at its first tick waiting for the first surface (s).
    pub waited_s: f64,
    /// Surfaces that connected.
    pub surfaces: u64,
    /// The vehicle's own inputs the App refused.
    pub own_refused: u64,
    /// The truth log.
    pub truth: PathBuf,
    /// Why the loop stopped before its duration (the plant left the physical), if it did.
    pub stopped: Option<String>,
}

/// The one surface's connection: its stream and what it has not taken yet.
struct Surface {
    stream: TcpStream,
    peer: SocketAddr,
    unsent: Vec<u8>,
}

/// The listener, bound (the address, with the port the system chose for port 0).
pub fn bind(addr: SocketAddr) -> Result<(TcpListener, SocketAddr)> {
    let l = TcpListener::bind(addr).with_context(|| format!("cannot listen on tcp:{addr}"))?;
    l.set_nonblocking(true)?;
    let local = l.local_addr()?;
    Ok((l, local))
}

/// Serve `endpoint`, the vehicle of `sc`, on `listener` until `duration_s` (or forever).
pub fn serve<E: ServedEndpoint>(
    sc: &RunSetup,
    o: &ServeOptions,
    listener: &TcpListener,
    endpoint: E,
) -> Result<ServeReport> {
    let truth_path = truth_path(&o.out, &sc.name);
    std::fs::create_dir_all(&o.out).with_context(|| format!("create {}", o.out.display()))?;
    let mut truth = BufWriter::new(
        File::create(&truth_path).with_context(|| format!("create {}", truth_path.display()))?,
    );
    writeln!(truth, "{TRUTH_HEADER}")?;
    let run_opts = RunOptions {
        open_ended: true,
        ..RunOptions::default()
    };
    // What the operator knows of this dive: the estimator's settings for its instruments.
    if let Some(c) = endpoint.onboard_config() {
        let path = o.out.join(format!("{}.nav-config.json", sc.name));
        std::fs::write(&path, serde_json::to_string_pretty(&c)?)
            .with_context(|| format!("write {}", path.display()))?;
    }
    let mut run = ClosedLoop::new(sc, &run_opts, navigation_for_vehicle(sc), endpoint)?;
    let period_s = run.period_s();
    let late_after = Duration::from_secs_f64(period_s / o.speedup).max(LATE_MIN);
    let mut rep = ServeReport {
        truth: truth_path,
        ..ServeReport::default()
    };
    let mut surface: Option<Surface> = None;
    let wall0 = Instant::now();
    let (mut anchor_wall, mut anchor_t) = (wall0, 0.0);
    let stride = run.endpoint().truth_stride().max(1);
    let rows_per_flush = (1.0 / period_s).round().max(1.0) as u64;
    let mut ticks = 0u64;
    let mut next_lag_note = wall0;
    let mut launch_written = false;
    loop {
        if o.duration_s
            .is_some_and(|d| run.t_s() >= d - 0.5 * period_s)
        {
            break;
        }
        // The surface's bytes (and its end, if it closed) first, then a waiting connection:
        // a surface restarted after a kill finds the old one's end read, not "one surface at
        // a time", however late this tick runs.
        if let Some(s) = surface.as_mut() {
            let mut bytes = Vec::new();
            let open = read_surface(s, &mut bytes);
            run.endpoint_mut().surface_sent(&bytes);
            if !open {
                eprintln!("vehicle: surface {} disconnected (tether cut)", s.peer);
                surface = None;
            }
        }
        accept(listener, &mut surface, &mut rep.surfaces);
        if !run.step()? {
            rep.stopped = Some(run.stop_reason().to_string());
            break;
        }
        if !launch_written {
            if let Some(l) = run.endpoint().launch() {
                // Where the vehicle was put in the water, as the operator knows it: the
                // surface's `--launch` (north, east, depth in m, heading in degrees).
                let path = o.out.join(format!("{}.launch", sc.name));
                let text = format!("{},{},{},{}\n", l.x_m, l.y_m, l.z_m, l.yaw_rad.to_degrees());
                std::fs::write(&path, text).with_context(|| format!("write {}", path.display()))?;
                launch_written = true;
            }
        }
        if o.wait_surface && rep.surfaces == 0 {
            rep.waited_s = wait_for_surface(listener, &mut surface, &mut rep.surfaces);
            (anchor_wall, anchor_t) = (Instant::now(), run.t_s());
        }
        let out = run.endpoint_mut().take_surface_out();
        if let Some(s) = surface.as_mut() {
            s.unsent.extend(out);
            if !write_surface(s) {
                eprintln!("vehicle: surface {} lost (tether cut)", s.peer);
                surface = None;
            }
        }
        if ticks.is_multiple_of(stride) {
            truth_row(&mut truth, &run, wall0, surface.is_some())?;
        }
        ticks += 1;
        if ticks.is_multiple_of(rows_per_flush) {
            truth.flush()?;
        }
        // Pace: the next tick is due `period / speedup` after this one's schedule.
        let due = anchor_wall + Duration::from_secs_f64((run.t_s() - anchor_t) / o.speedup);
        let now = Instant::now();
        match due.checked_duration_since(now) {
            Some(wait) => std::thread::sleep(wait),
            None => {
                let lag = now.duration_since(due);
                rep.max_lag_s = rep.max_lag_s.max(lag.as_secs_f64());
                if lag > late_after {
                    rep.late_ticks += 1;
                    rep.slip_s += lag.as_secs_f64();
                    (anchor_wall, anchor_t) = (now, run.t_s());
                    if now >= next_lag_note {
                        next_lag_note = now + LAG_NOTE_EVERY;
                        eprintln!(
                            "vehicle: behind the wall clock at {:.1} s: {} late ticks, largest \
                             lag {:.1} ms, slip {:.1} ms",
                            run.t_s(),
                            rep.late_ticks,
                            rep.max_lag_s * 1e3,
                            rep.slip_s * 1e3
                        );
                    }
                }
            }
        }
    }
    truth.flush()?;
    rep.sim_s = run.t_s();
    rep.wall_s = wall0.elapsed().as_secs_f64();
    rep.own_refused = run.endpoint().own_refused();
    Ok(rep)
}

/// Take a waiting connection: the surface, or, while one is served, closed at once.
fn accept(listener: &TcpListener, surface: &mut Option<Surface>, count: &mut u64) {
    while let Ok((stream, peer)) = listener.accept() {
        if surface.is_some() {
            eprintln!("vehicle: {peer} refused: one surface at a time");
            drop(stream);
            continue;
        }
        if stream.set_nonblocking(true).is_err() {
            continue;
        }
        let _ = stream.set_nodelay(true);
        eprintln!("vehicle: surface {peer} connected");
        *count += 1;
        *surface = Some(Surface {
            stream,
            peer,
            unsent: Vec::new(),
        });
    }
}

/// Block until the first surface connects (polling the listener); the wall time waited (s).
fn wait_for_surface(listener: &TcpListener, surface: &mut Option<Surface>, count: &mut u64) -> f64 {
    let t0 = Instant::now();
    eprintln!("vehicle: the clock waits for a surface");
    while surface.is_none() {
        accept(listener, surface, count);
        if surface.is_none() {
            std::thread::sleep(WAIT_POLL);
        }
    }
    t0.elapsed().as_secs_f64()
}

/// Everything the surface sent, into `into`; false when it disconnected.
fn read_surface(s: &mut Surface, into: &mut Vec<u8>) -> bool {
    let mut buf = [0u8; 4096];
    loop {
        match s.stream.read(&mut buf) {
            Ok(0) => return false,
            Ok(n) => into.extend_from_slice(buf.get(..n).unwrap_or_default()),
            Err(e) if e.kind() == ErrorKind::WouldBlock => return true,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => return false,
        }
    }
}

/// What the surface takes now; false when it is gone or has not read for too long.
fn write_surface(s: &mut Surface) -> bool {
    while !s.unsent.is_empty() {
        match s.stream.write(&s.unsent) {
            Ok(0) => return false,
            Ok(n) => {
                s.unsent.drain(..n.min(s.unsent.len()));
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => break,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => return false,
        }
    }
    s.unsent.len() <= MAX_UNSENT
}

/// One row of the truth log: the true state after the tick, what the vehicle believes, the
/// position its latest telemetry frame to the surface carried.
fn truth_row<E: ServedEndpoint>(
    w: &mut impl Write,
    run: &ClosedLoop<Box<dyn Navigation>, E>,
    wall0: Instant,
    connected: bool,
) -> Result<()> {
    let s = run.sample();
    let x = &s.state.eta;
    let b = run.endpoint().believed();
    let (n, mode) = (&b.nav, &b.mode);
    write!(
        w,
        "{:.3},{:.3},{:.4},{:.4},{:.4},{:.5},{:.5},{:.5},{:.4},{:.4},{:.4},{:.5},{},{mode},{}",
        s.t_s,
        wall0.elapsed().as_secs_f64(),
        x[0],
        x[1],
        x[2],
        x[3],
        x[4],
        x[5],
        n.x_m,
        n.y_m,
        n.z_m,
        n.yaw_rad,
        u8::from(b.armed),
        u8::from(connected)
    )?;
    // The latest telemetry frame sent to the surface (empty before the first).
    match b.shown {
        Some((t_us, p)) => writeln!(
            w,
            ",{:.3},{:.4},{:.4},{:.4}",
            t_us as f64 * 1e-6,
            p.x_m,
            p.y_m,
            p.z_m
        )?,
        None => writeln!(w, ",,,,")?,
    }
    Ok(())
}

/// The truth log's path for a scenario in `out`.
pub fn truth_path(out: &Path, scenario: &str) -> PathBuf {
    out.join(format!("{scenario}.truth.csv"))
}

/// Refuse what is not served: speedup below 1, a duration not > 0.
pub fn check(o: &ServeOptions) -> Result<()> {
    if !(o.speedup.is_finite() && o.speedup >= 1.0) {
        bail!("--speedup must be >= 1 (got {})", o.speedup);
    }
    if let Some(d) = o.duration_s {
        sim_world::checks::pos("--duration", d)?;
    }
    Ok(())
}
