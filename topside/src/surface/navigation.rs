//! The vehicle's navigation, from the surface: its estimator started from here, restarted on
//! the operator's word, and fed the fixes of the surface's own instrument, the USBL.
//!
//! The USBL (or underwater GPS) is read as its vendor sends it: NMEA 0183 over UDP or a
//! serial port (`--usbl udpin:HOST:PORT` or `--usbl serial:DEV[:BAUD]`), Kongsberg's
//! `$PSIMSSB` (relative Cartesian, north up: x east, y north, with the measurement's own time
//! of day and its expected accuracy) or `GGA` (latitude and longitude, minus the depth as the
//! altitude, as Water Linked's Underwater GPS gives them; converted to north and east metres
//! from the dive's origin). Every sentence is checked by `sensor_drivers::usbl` (checksum,
//! fields); a bad one, a head-up position (it needs the vessel's heading, not read here) and
//! one older than [`MAX_FIX_AGE`] are counted and dropped. Nothing the USBL sends ends the
//! surface program.
//!
//! Each fix keeps its time of validity: its time of day (UTC) is mapped to the vehicle's
//! clock by [`VehicleClock`], the line fitted through the vehicle's telemetry stamps against
//! their arrival, so the vehicle's estimator judges the fix at the moment it was measured
//! (the acoustic latency is known, not assumed). A sentence without a time is stamped at its
//! arrival.
//!
//! The estimator is started when the vehicle says it is not running (`Status`: no IMU sample
//! integrated) and a launch point is known: `--launch N,E,D,HEADING_DEG`, or else the first
//! USBL fix (north, east and depth; the heading from the vehicle, with the start's heading
//! uncertainty widened to 90 deg). A surface restarted mid-dive finds the estimator running
//! and leaves it. `MAV_CMD_USER_1` with param1 = 1 from a ground station restarts it: at the
//! latest fix when the estimate disagrees with it (beyond three standard deviations), known
//! to the fix's accuracy, else at the estimate's own position, known as well as the estimate
//! knew it (its depth and heading the vehicle's estimate; an EKF's position reset), with the
//! settings of
//! `--nav-config FILE` (the vehicle's instruments' figures as JSON, `OnboardConfig`) or the
//! defaults.

use crate::surface::vehicle::Vehicle;
use anyhow::{anyhow, bail, Context, Result};
use controller_core::nav::onboard::OnboardConfig;
use controller_core::nav::PositionFix;
use controller_core::state::NavState;
use protocol::Command;
use sensor_drivers::usbl::{parse, LocalOrigin, Orientation, Sentence};
use std::io::Read;
use std::net::UdpSocket;
use std::path::Path;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// A fix older than this (by its own time) when it arrives is dropped.
pub const MAX_FIX_AGE: Duration = Duration::from_secs(10);

/// The accuracy given to a fix whose sentence states none (m): the simulated and typical
/// USBL's 0.3 m.
const DEFAULT_FIX_STD_M: f32 = 0.3;

/// Heading uncertainty of a start whose heading is the vehicle's own guess (rad).
const UNKNOWN_HEADING_STD_RAD: f32 = std::f32::consts::FRAC_PI_2;

/// The surface's navigation options.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct NavOptions {
    /// The USBL or underwater GPS: `udpin:HOST:PORT` (NMEA 0183 datagrams) or
    /// `serial:DEV[:BAUD]` (default 4800 Bd); `$PSIMSSB` and `GGA` are read.
    #[arg(long, value_name = "SOURCE")]
    pub usbl: Option<String>,
    /// The dive's origin for GGA positions, `LAT,LON` (degrees); default: the first GGA fix.
    #[arg(long, value_name = "LAT,LON", allow_hyphen_values = true)]
    pub usbl_origin: Option<String>,
    /// The launch point the vehicle's estimator starts from: `N,E,D,HEADING_DEG` (local NED,
    /// metres and degrees); default: the first USBL fix.
    #[arg(long, value_name = "N,E,D,HEADING_DEG", allow_hyphen_values = true)]
    pub launch: Option<String>,
    /// The estimator's settings (JSON of `OnboardConfig`: the instruments' noise, the launch
    /// point's uncertainty, pressure to depth); default: the built-in defaults.
    #[arg(long, value_name = "FILE")]
    pub nav_config: Option<std::path::PathBuf>,
}

/// What the USBL input did, for the log at the end.
#[derive(Debug, Default, Clone, Copy)]
pub struct UsblStats {
    /// Sentences read.
    pub sentences: u64,
    /// Fixes relayed to the vehicle.
    pub relayed: u64,
    /// Sentences dropped: checksum, fields, a kind not read.
    pub bad: u64,
    /// Head-up positions dropped (no vessel heading here).
    pub head_up: u64,
    /// Fixes dropped before the vehicle's clock was known, or too old.
    pub untimed: u64,
}

/// The vehicle's clock against this machine's: a line through its telemetry stamps.
#[derive(Debug, Default, Clone, Copy)]
pub struct VehicleClock {
    first: Option<(u64, SystemTime)>,
    last: Option<(u64, SystemTime)>,
}

impl VehicleClock {
    /// The vehicle said `t_us` (its clock), heard at `at`.
    pub fn heard(&mut self, t_us: u64, at: SystemTime) {
        if self.last.is_some_and(|(t, _)| t_us <= t) {
            return;
        }
        if self.first.is_none() {
            self.first = Some((t_us, at));
        }
        self.last = Some((t_us, at));
    }

    /// Vehicle microseconds per wall microsecond: 1 for a vehicle on its own clock, the
    /// speed-up for a simulated one; 1 until a second has been seen.
    fn rate(&self) -> f64 {
        match (self.first, self.last) {
            (Some((t0, w0)), Some((t1, w1))) => {
                let wall_us = w1.duration_since(w0).map_or(0.0, |d| d.as_secs_f64() * 1e6);
                if wall_us >= 1e6 {
                    (t1 - t0) as f64 / wall_us
                } else {
                    1.0
                }
            }
            _ => 1.0,
        }
    }

    /// The vehicle's time at `at`, when its clock is known.
    pub fn vehicle_us(&self, at: SystemTime) -> Option<u64> {
        let (t1, w1) = self.last?;
        let dt_s = match at.duration_since(w1) {
            Ok(d) => d.as_secs_f64(),
            Err(e) => -e.duration().as_secs_f64(),
        };
        let t = t1 as f64 + dt_s * 1e6 * self.rate();
        (t >= 0.0).then_some(t as u64)
    }
}

/// The UTC instant of `time_of_day_s` (s since midnight) nearest to `now`.
pub fn utc_of_time_of_day(time_of_day_s: f64, now: SystemTime) -> SystemTime {
    let now_s = now
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    let midnight = (now_s / 86_400.0).floor() * 86_400.0;
    let mut t = midnight + time_of_day_s;
    // A time of day just before midnight heard just after it was yesterday's, and the other
    // way round.
    if t - now_s > 43_200.0 {
        t -= 86_400.0;
    } else if now_s - t > 43_200.0 {
        t += 86_400.0;
    }
    UNIX_EPOCH + Duration::from_secs_f64(t.max(0.0))
}

/// A USBL fix at the surface: north, east, depth (m) from the origin, its accuracy and when
/// it was valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceFix {
    /// North, east, depth (m).
    pub ned_m: [f32; 3],
    /// Horizontal accuracy (m).
    pub std_m: f32,
    /// When it was valid (UTC), or its arrival when the sentence has no time.
    pub valid_at: SystemTime,
}

/// The fix a checked sentence gives, or why it gives none.
pub fn fix_of(
    s: &Sentence,
    origin: &mut Option<LocalOrigin>,
    now: SystemTime,
) -> std::result::Result<SurfaceFix, &'static str> {
    match s {
        Sentence::Ssb(f) => {
            if f.orientation == Orientation::HeadUp {
                return Err("head up");
            }
            Ok(SurfaceFix {
                ned_m: [f.y_m, f.x_m, f.depth_m],
                std_m: f
                    .accuracy_m
                    .filter(|a| *a > 0.0)
                    .unwrap_or(DEFAULT_FIX_STD_M),
                valid_at: utc_of_time_of_day(f.time_of_day_s, now),
            })
        }
        Sentence::Gga(g) => {
            let o = *origin.get_or_insert(LocalOrigin {
                latitude_deg: g.latitude_deg,
                longitude_deg: g.longitude_deg,
            });
            let [n, e] = o.north_east_m(g.latitude_deg, g.longitude_deg);
            Ok(SurfaceFix {
                ned_m: [n as f32, e as f32, -g.altitude_m.unwrap_or(0.0)],
                std_m: DEFAULT_FIX_STD_M,
                valid_at: g.time_of_day_s.map_or(now, |t| utc_of_time_of_day(t, now)),
            })
        }
    }
}

/// Where the USBL's sentences come from.
enum UsblSource {
    Udp(UdpSocket),
    Serial(Box<dyn crate::port::Port>),
}

/// The surface's navigation: the USBL input, the estimator's start and restarts.
pub struct SurfaceNav {
    source: Option<UsblSource>,
    line: Vec<u8>,
    origin: Option<LocalOrigin>,
    launch: Option<NavState>,
    config: OnboardConfig,
    clock: VehicleClock,
    latest_fix: Option<SurfaceFix>,
    /// The start was asked for and refused: said once, tried again every second.
    start_refused_at: Option<Instant>,
    /// What the USBL input did.
    pub stats: UsblStats,
    /// Estimator starts sent and taken.
    pub starts: u32,
    /// When the vehicle last took a start of ours: its new estimator counts no IMU sample
    /// until its next one, so a `Status` of that instant does not mean it stopped.
    started_at: Option<Instant>,
}

/// How long after a start the surface does not take "no IMU sample yet" for an estimator
/// that stopped (wall clock): a new estimator integrates its first sample within a control
/// period; a `Status` answered between the start and that sample says zero.
const START_SETTLE: Duration = Duration::from_secs(2);

/// `N,E,D,HEADING_DEG` as the launch point.
fn parse_launch(s: &str) -> Result<NavState> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| anyhow!("--launch {s}: four numbers N,E,D,HEADING_DEG"))?;
    let [n, e, d, h] = v[..] else {
        bail!("--launch {s}: four numbers N,E,D,HEADING_DEG");
    };
    if !v.iter().all(|x| x.is_finite()) || n.hypot(e) > 1_000.0 || !(-1.0..=1_000.0).contains(&d) {
        bail!("--launch {s}: within 1 km of the origin, depth -1..1000 m");
    }
    Ok(NavState {
        x_m: n,
        y_m: e,
        z_m: d,
        yaw_rad: h.to_radians(),
        ..NavState::default()
    })
}

/// The smallest position uncertainty a restart starts from (m): a fresh estimate's 1 cm at
/// least, so that the fixes after it still move it.
const RESTART_MIN_STD_M: f32 = 0.01;

/// A restart's position uncertainty: its source's `std_m` (the estimate's or the fix's),
/// within [`RESTART_MIN_STD_M`] and the configured start's `configured_m`; the configured one
/// when the source's is not a number.
fn restart_std_m(std_m: f32, configured_m: f32) -> f32 {
    if std_m.is_finite() && std_m > 0.0 {
        std_m.clamp(RESTART_MIN_STD_M.min(configured_m), configured_m)
    } else {
        configured_m
    }
}

/// Does `fix` agree with the vehicle's estimate `nav` (within three standard deviations of the
/// fix and the start's position uncertainty)?
fn agrees_with_estimate(fix: &SurfaceFix, nav: &NavState, config: &OnboardConfig) -> bool {
    let sigma = fix.std_m.hypot(config.nav.initial_position_std_m);
    let off = (fix.ned_m[0] - nav.x_m).hypot(fix.ned_m[1] - nav.y_m);
    off.is_finite() && off <= 3.0 * sigma
}

impl SurfaceNav {
    /// The options checked and the USBL source opened; every refusal says why.
    pub fn open(o: &NavOptions) -> Result<Self> {
        let source = match o.usbl.as_deref() {
            None => None,
            Some(s) if s.starts_with("udpin:") => {
                let addr = &s["udpin:".len()..];
                let sock = UdpSocket::bind(addr)
                    .with_context(|| format!("--usbl {s}: cannot listen on {addr}"))?;
                sock.set_nonblocking(true)?;
                Some(UsblSource::Udp(sock))
            }
            Some(s) if s.starts_with("serial:") => {
                let rest = &s["serial:".len()..];
                let (dev, baud) = match rest.rsplit_once(':') {
                    Some((d, b)) if b.chars().all(|c| c.is_ascii_digit()) && !b.is_empty() => {
                        (d, b.parse().unwrap_or(4800))
                    }
                    _ => (rest, 4800),
                };
                let port = crate::port::serial_port_with_poll(
                    Path::new(dev),
                    baud,
                    Duration::from_millis(1),
                )?;
                Some(UsblSource::Serial(port))
            }
            Some(s) => bail!("--usbl {s}: give udpin:HOST:PORT or serial:DEV[:BAUD]"),
        };
        let origin = match o.usbl_origin.as_deref() {
            None => None,
            Some(s) => {
                let v: Vec<f64> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
                match v[..] {
                    [lat, lon] if lat.abs() <= 90.0 && lon.abs() <= 180.0 => Some(LocalOrigin {
                        latitude_deg: lat,
                        longitude_deg: lon,
                    }),
                    _ => bail!("--usbl-origin {s}: LAT,LON in degrees"),
                }
            }
        };
        let config = match &o.nav_config {
            None => OnboardConfig::default(),
            Some(p) => {
                let text = std::fs::read_to_string(p)
                    .with_context(|| format!("--nav-config {}", p.display()))?;
                serde_json::from_str(&text).with_context(|| {
                    format!("--nav-config {}: not an estimator's settings", p.display())
                })?
            }
        };
        Ok(Self {
            source,
            line: Vec::new(),
            origin,
            launch: o.launch.as_deref().map(parse_launch).transpose()?,
            config,
            clock: VehicleClock::default(),
            latest_fix: None,
            start_refused_at: None,
            stats: UsblStats::default(),
            starts: 0,
            started_at: None,
        })
    }

    /// The sentences that arrived since the last call, at most 64.
    fn read_sentences(&mut self) -> Vec<Vec<u8>> {
        let mut out = Vec::new();
        let mut buf = [0u8; 2048];
        for _ in 0..64 {
            let n = match self.source.as_mut() {
                None => return out,
                Some(UsblSource::Udp(s)) => match s.recv(&mut buf) {
                    Ok(n) => n,
                    Err(_) => break,
                },
                Some(UsblSource::Serial(p)) => match p.read(&mut buf) {
                    Ok(n) if n > 0 => n,
                    _ => break,
                },
            };
            for &b in buf.get(..n).unwrap_or(&[]) {
                if b == b'\n' || b == b'\r' {
                    if !self.line.is_empty() {
                        out.push(std::mem::take(&mut self.line));
                    }
                } else if self.line.len() < 256 {
                    self.line.push(b);
                } else {
                    // Longer than any sentence: not one.
                    self.line.clear();
                    self.stats.bad += 1;
                }
            }
            // A datagram is whole sentences; its last may lack the line end.
            if matches!(self.source, Some(UsblSource::Udp(_))) && !self.line.is_empty() {
                out.push(std::mem::take(&mut self.line));
            }
        }
        out
    }

    /// Every control period: the vehicle's clock from its latest telemetry, the USBL's
    /// sentences relayed, the estimator started when it is not running.
    pub fn tick(&mut self, v: &mut Vehicle) -> Result<Vec<String>> {
        let mut said = Vec::new();
        if v.tel.t_us > 0 {
            let heard = SystemTime::now()
                .checked_sub(v.heard_at().elapsed())
                .unwrap_or(UNIX_EPOCH);
            self.clock.heard(v.tel.t_us, heard);
        }
        let now = SystemTime::now();
        for line in self.read_sentences() {
            self.stats.sentences += 1;
            let s = match parse(&line) {
                Ok(s) => s,
                Err(_) => {
                    self.stats.bad += 1;
                    continue;
                }
            };
            let fix = match fix_of(&s, &mut self.origin, now) {
                Ok(f) => f,
                Err(_) => {
                    self.stats.head_up += 1;
                    continue;
                }
            };
            let age = now.duration_since(fix.valid_at).unwrap_or_default();
            let Some(t_us) = self
                .clock
                .vehicle_us(fix.valid_at)
                .filter(|_| age <= MAX_FIX_AGE)
            else {
                self.stats.untimed += 1;
                continue;
            };
            self.latest_fix = Some(fix);
            if self.running(v) {
                v.send(&Command::UsblFix(PositionFix {
                    t_us,
                    north_m: fix.ned_m[0],
                    east_m: fix.ned_m[1],
                    std_m: fix.std_m,
                }))?;
                self.stats.relayed += 1;
            }
        }
        if !self.running(v)
            && self
                .start_refused_at
                .is_none_or(|t| t.elapsed() >= Duration::from_secs(1))
            && self.started_at.is_none_or(|t| t.elapsed() >= START_SETTLE)
        {
            if let Some(text) = self.start(v, false)? {
                said.push(text);
            }
        }
        Ok(said)
    }

    /// Is the vehicle's estimator running (its `Status` counts IMU samples)?
    fn running(&self, v: &mut Vehicle) -> bool {
        v.last_status()
            .is_some_and(|s| s.nav_health.imu_samples > 0)
    }

    /// Start (or with `restart`, restart at the latest fix) the vehicle's estimator; what to
    /// tell the operator, if anything.
    pub fn start(&mut self, v: &mut Vehicle, restart: bool) -> Result<Option<String>> {
        let mut config = self.config;
        let initial = match (restart, self.launch, self.latest_fix) {
            (false, Some(l), _) => l,
            (true, _, Some(f)) if agrees_with_estimate(&f, &v.state, &config) => {
                // The estimate agrees with the fixes: the restart keeps its position (a
                // single fix carries the USBL's 0.3 m), known as well as the estimate knew
                // it (an EKF's position reset takes its source's accuracy), and the vehicle
                // keeps what its estimator learned of the instruments and the water.
                let [sx, sy, _] = v.tel.nav_pos_std_m;
                config.nav.initial_position_std_m =
                    restart_std_m(sx.max(sy), config.nav.initial_position_std_m);
                v.state
            }
            (_, _, Some(f)) => {
                let (depth_m, yaw_rad) = if restart {
                    // At the fix, known as well as the fix is.
                    config.nav.initial_position_std_m =
                        restart_std_m(f.std_m, config.nav.initial_position_std_m);
                    (v.state.z_m, v.state.yaw_rad)
                } else {
                    config.nav.initial_heading_std_rad = config
                        .nav
                        .initial_heading_std_rad
                        .max(UNKNOWN_HEADING_STD_RAD);
                    (f.ned_m[2], v.state.yaw_rad)
                };
                NavState {
                    x_m: f.ned_m[0],
                    y_m: f.ned_m[1],
                    z_m: depth_m,
                    yaw_rad,
                    ..NavState::default()
                }
            }
            (true, _, None) => {
                return Ok(Some("Navigation restart refused: no USBL fix yet".into()))
            }
            (false, None, None) => return Ok(None),
        };
        let Some(t_us) = self.clock.vehicle_us(SystemTime::now()) else {
            return Ok(None);
        };
        match v.command(&Command::StartNav {
            t_us,
            initial,
            config,
        })? {
            Ok(()) => {
                self.starts += 1;
                self.started_at = Some(Instant::now());
                self.start_refused_at = None;
                Ok(Some(format!(
                    "Navigation {} at N {:.2} E {:.2} D {:.2} m",
                    if restart { "restarted" } else { "started" },
                    initial.x_m,
                    initial.y_m,
                    initial.z_m
                )))
            }
            Err(why) => {
                let first = self.start_refused_at.is_none();
                self.start_refused_at = Some(Instant::now());
                Ok(first.then(|| format!("Navigation start refused by the vehicle: {why}")))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_vehicle_clock_follows_a_faster_simulated_one() {
        let mut c = VehicleClock::default();
        let w0 = UNIX_EPOCH + Duration::from_secs(1_000_000);
        // A vehicle at 4x: 4 s of its time per second of ours.
        for k in 0..=20u64 {
            c.heard(k * 400_000, w0 + Duration::from_millis(100 * k));
        }
        let t = c.vehicle_us(w0 + Duration::from_millis(1500)).unwrap();
        assert!((t as i64 - 6_000_000).abs() < 1_000, "{t}");
        // Earlier than the last telemetry: counted back at the same rate.
        let t = c.vehicle_us(w0 + Duration::from_millis(1900)).unwrap();
        assert!((t as i64 - 7_600_000).abs() < 1_000, "{t}");
    }

    #[test]
    fn a_time_of_day_maps_to_the_nearest_day() {
        let now = UNIX_EPOCH + Duration::from_secs(86_400 * 10 + 10);
        let t = utc_of_time_of_day(86_395.0, now);
        assert_eq!(t, UNIX_EPOCH + Duration::from_secs(86_400 * 10 - 5));
    }

    #[test]
    fn psimssb_north_up_gives_north_east_depth_and_head_up_is_refused() {
        let now = SystemTime::now();
        let n =
            parse(b"$PSIMSSB,180554.432,M44,A,,C,N,M,-61.300,39.017,34.026,0.072,T,0.050576,*47")
                .unwrap();
        let f = fix_of(&n, &mut None, now).unwrap();
        assert_eq!(f.ned_m, [39.017, -61.3, 34.026]);
        assert_eq!(f.std_m, 0.072);
        let h = parse(b"$PSIMSSB,085405.61,B42,A,,C,H,M,134.5,114.5,120.0,,,,*0C").unwrap();
        assert_eq!(fix_of(&h, &mut None, now), Err("head up"));
    }

    #[test]
    fn a_launch_point_is_four_finite_numbers_near_the_origin() {
        let l = parse_launch("1.5,-2,3,90").unwrap();
        assert_eq!((l.x_m, l.y_m, l.z_m), (1.5, -2.0, 3.0));
        assert!((l.yaw_rad - std::f32::consts::FRAC_PI_2).abs() < 1e-6);
        for bad in ["1,2,3", "1,2,3,nan", "5000,0,0,0", "a,b,c,d"] {
            assert!(parse_launch(bad).is_err(), "{bad}");
        }
    }
}
