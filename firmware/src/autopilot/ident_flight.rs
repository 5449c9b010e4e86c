//! The identification manoeuvre, flown in `Hold` like the compass calibration turn: a fixed
//! schedule of force steps, each axis in turn, from which `host-sim identify` fits the
//! vehicle's model (docs/identification.md).
//!
//! Six cycles of doublets (ahead then astern) at rising and mixed levels, each cycle a surge
//! doublet (heading held, depth held by the law), a yaw doublet and a heave doublet (both
//! with the along-heading drift from the start pushed back by the surge), then two turns
//! under way (surge with yaw either way: the sway the vehicle has no thruster for). The
//! levels are fractions of the thrust the vehicle description gives, so a stronger or
//! weaker vehicle is driven to a similar share of its capacity. It lasts
//! [`IDENT_DURATION_S`] and ends in `Hold` at its start point.
//!
//! It stops (`Aborted`) on any stick off centre, a change of mode, a disarm, a fault of
//! the step (a failsafe), stale navigation, or the vehicle leaving its room: the radius
//! around the start point or the depth band around the start depth.
//!
//! `no_std`, `f32`, no allocation, no panic path.

use controller_core::math::{sin_cos, wrap_angle};
use controller_core::params::Vehicle;
use controller_core::state::NavState;

/// What one step of the schedule drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drive {
    /// Surge force, heading and depth held.
    Surge,
    /// Yaw moment, depth held.
    Yaw,
    /// Heave force, heading held.
    Heave,
    /// Surge ahead at a fixed share with a yaw moment (a turn under way).
    Turn,
}

/// Length of one half of a doublet (s): several of the vehicle's time constants.
const HALF_S: f32 = 3.0;
/// Length of a turn under way (s).
const TURN_S: f32 = 8.0;
/// Levels of the eight cycles, as fractions of the axis's thrust either way: low ones for
/// the linear drag, high ones for the quadratic, mixed so that each held-out block of the
/// fit's validation sees a spread.
const LEVELS: [f32; 8] = [0.1, 0.3, 0.55, 0.8, 0.2, 0.45, 0.7, 0.35];
/// Heave levels are this share of the surge ones.
const HEAVE_SHARE: f32 = 1.0;
/// Share of the depth band at which a heave step that pushes farther out turns round (the
/// vehicle stays in its band whatever its speed).
const HEAVE_TURN_BAND: f32 = 0.6;
/// Surge share and yaw share of the turns under way.
const TURN_SURGE: f32 = 0.3;
const TURN_YAW: f32 = 0.35;
/// Heading hold during surge and heave steps: `m33 (K_P e - K_D r)` (1/s^2, 1/s).
const HEADING_KP: f32 = 2.0;
const HEADING_KD: f32 = 2.5;
/// Surge per metre of along-heading drift from the start during yaw and heave steps (N/m,
/// as a share of the surge thrust per metre), and its largest share.
const RETURN_SHARE_PER_M: f32 = 0.02;
const RETURN_MAX_SHARE: f32 = 0.15;

/// The schedule's length (s): eight cycles of three doublets, then two turns.
pub const IDENT_DURATION_S: f32 = LEVELS.len() as f32 * 6.0 * HALF_S + 2.0 * TURN_S;
// The manoeuvre lasts at most three minutes.
const _: () = assert!(IDENT_DURATION_S <= 180.0);

/// Accepted room: radius around the start (m) and depth band either side of the start
/// depth (m).
pub const IDENT_RADIUS_M: (f32, f32) = (3.0, 100.0);
/// See [`IDENT_RADIUS_M`].
pub const IDENT_DEPTH_BAND_M: (f32, f32) = (0.5, 20.0);

pub use crate::protocol::{IdentAbort, IdentOutcome};

/// The step of the schedule at `t_s`: what it drives and its signed level; `None` past the
/// end.
fn schedule(t_s: f32) -> Option<(Drive, f32)> {
    if t_s.is_nan() || t_s < 0.0 {
        return None;
    }
    let cycle_s = 6.0 * HALF_S;
    let cycles_s = LEVELS.len() as f32 * cycle_s;
    if t_s < cycles_s {
        let cycle = (t_s / cycle_s) as usize;
        let level = LEVELS.get(cycle).copied()?;
        let within = t_s - cycle as f32 * cycle_s;
        let half = (within / HALF_S) as usize;
        let sign = if half.is_multiple_of(2) { 1.0 } else { -1.0 };
        let drive = match half / 2 {
            0 => Drive::Surge,
            1 => Drive::Yaw,
            _ => Drive::Heave,
        };
        return Some((drive, sign * level));
    }
    let turn = t_s - cycles_s;
    if turn < TURN_S {
        Some((Drive::Turn, TURN_YAW))
    } else if turn < 2.0 * TURN_S {
        Some((Drive::Turn, -TURN_YAW))
    } else {
        None
    }
}

/// The share `level` of a thrust that is `ahead_n` one way and `astern_n` the other.
fn share(level: f32, ahead_n: f32, astern_n: f32) -> f32 {
    if level >= 0.0 {
        level * ahead_n
    } else {
        level * astern_n
    }
}

/// A manoeuvre in flight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentFlight {
    /// Start point (held horizontally after the end) and its depth.
    pub(super) start_m: [f32; 3],
    start_yaw_rad: f32,
    radius_m: f32,
    depth_band_m: f32,
    elapsed_s: f32,
}

impl IdentFlight {
    /// From `nav`, in a room of `radius_m` and `depth_band_m`; `None` when those are out
    /// of range or the start is shallower than the band (no room above).
    pub fn new(nav: &NavState, radius_m: f32, depth_band_m: f32) -> Option<Self> {
        let ok = (IDENT_RADIUS_M.0..=IDENT_RADIUS_M.1).contains(&radius_m)
            && (IDENT_DEPTH_BAND_M.0..=IDENT_DEPTH_BAND_M.1).contains(&depth_band_m)
            && nav.z_m > depth_band_m;
        ok.then_some(Self {
            start_m: [nav.x_m, nav.y_m, nav.z_m],
            start_yaw_rad: nav.yaw_rad,
            radius_m,
            depth_band_m,
            elapsed_s: 0.0,
        })
    }

    /// Time flown (s).
    pub fn elapsed_s(&self) -> f32 {
        self.elapsed_s
    }

    /// One step of `dt_s` on `nav`: `Ok(Some((surge_n, yaw_n_m, heave_n)))`, `heave_n`
    /// `None` where the law holds the depth; `Ok(None)` at the end; `Err` when the vehicle
    /// left its room.
    pub fn step(
        &mut self,
        vehicle: &Vehicle,
        nav: &NavState,
        dt_s: f32,
    ) -> Result<Option<(f32, f32, Option<f32>)>, IdentAbort> {
        let dx = nav.x_m - self.start_m[0];
        let dy = nav.y_m - self.start_m[1];
        if dx * dx + dy * dy > self.radius_m * self.radius_m {
            return Err(IdentAbort::Radius);
        }
        if (nav.z_m - self.start_m[2]).abs() > self.depth_band_m {
            return Err(IdentAbort::DepthBand);
        }
        let Some((drive, level)) = schedule(self.elapsed_s) else {
            return Ok(None);
        };
        self.elapsed_s += dt_s;
        let p = vehicle.params();
        let (fwd, rev, l) = (
            p.thrust_max_forward_n,
            p.thrust_max_reverse_n,
            p.thruster_lever_arm_m,
        );
        let m33 = vehicle.xy.m33;
        let heading = m33
            * (HEADING_KP * wrap_angle(self.start_yaw_rad - nav.yaw_rad)
                - HEADING_KD * nav.r_rad_s);
        let (s, c) = sin_cos(nav.yaw_rad);
        let along_m = -(dx * c + dy * s);
        let back = (RETURN_SHARE_PER_M * along_m).clamp(-RETURN_MAX_SHARE, RETURN_MAX_SHARE);
        let back_n = share(back, 2.0 * fwd, 2.0 * rev);
        let yaw_cap = 2.0 * l * fwd.min(rev);
        let out = match drive {
            Drive::Surge => (share(level, 2.0 * fwd, 2.0 * rev), heading, None),
            Drive::Yaw => (back_n, level * yaw_cap, None),
            Drive::Heave => {
                // Positive heave pushes down; the net buoyancy is balanced first. A push
                // farther out than the turn-round share of the band is reversed.
                let dz = nav.z_m - self.start_m[2];
                let turn = HEAVE_TURN_BAND * self.depth_band_m;
                let level = if (level > 0.0 && dz > turn) || (level < 0.0 && dz < -turn) {
                    -level
                } else {
                    level
                };
                let trim = p.buoyancy_offset_n;
                (
                    back_n,
                    heading,
                    Some(trim + share(level * HEAVE_SHARE, fwd, rev)),
                )
            }
            Drive::Turn => (
                share(TURN_SURGE, 2.0 * fwd, 2.0 * rev),
                level * yaw_cap,
                None,
            ),
        };
        Ok(Some(out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schedule_ends_at_its_duration_and_drives_every_axis_both_ways() {
        let mut seen = [[false; 2]; 4];
        let mut t = 0.0;
        while let Some((d, level)) = schedule(t) {
            let i = match d {
                Drive::Surge => 0,
                Drive::Yaw => 1,
                Drive::Heave => 2,
                Drive::Turn => 3,
            };
            seen[i][usize::from(level < 0.0)] = true;
            t += 0.01;
        }
        assert!((t - IDENT_DURATION_S).abs() < 0.02, "{t}");
        assert!(seen.iter().all(|s| s[0] && s[1]), "{seen:?}");
    }

    #[test]
    fn out_of_room_stops_and_a_bad_room_is_refused() {
        let v = Vehicle::observer();
        let nav = NavState {
            z_m: 5.0,
            ..NavState::default()
        };
        assert!(IdentFlight::new(&nav, 1.0, 2.0).is_none());
        assert!(IdentFlight::new(&nav, 10.0, 6.0).is_none());
        let mut f = IdentFlight::new(&nav, 10.0, 2.0).unwrap();
        assert!(matches!(f.step(&v, &nav, 0.01), Ok(Some(_))));
        let far = NavState { x_m: 11.0, ..nav };
        assert_eq!(f.step(&v, &far, 0.01), Err(IdentAbort::Radius));
        let deep = NavState { z_m: 7.5, ..nav };
        assert_eq!(f.step(&v, &deep, 0.01), Err(IdentAbort::DepthBand));
    }
}
