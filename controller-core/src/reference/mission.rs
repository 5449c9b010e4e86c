//! A mission: waypoints made into a path the vehicle can fly.
//!
//! From the point where the mission starts, straight legs run to each waypoint in turn; at
//! every waypoint between two legs the corner is cut by a horizontal circular arc of radius
//! `turn_radius_m` tangent to both legs (smaller when a leg is too short to hold it, never
//! below [`MIN_TURN_RADIUS_M`]: a mission whose corner would need less is refused). The depth
//! changes linearly along each leg; the arcs are at their waypoint's depth. The path is flown
//! at one speed in the virtual time of [`super::path`], starting from rest and stopping at the
//! last waypoint with the smooth ramps of the other paths, so position, velocity and
//! acceleration are continuous except for the step in acceleration where a leg meets an arc
//! (`v^2 / R`: 0.04 m/s^2 at 0.25 m/s and 1.5 m).
//!
//! A waypoint counts as reached when the reference passes it: the middle of its arc, or the
//! end of its leg when it has none.

use super::path::{compose, ramp_finite, Geo};
use super::RefSample;
use crate::error::{finite, positive, Error};
use crate::math::{atan2, sin_cos, sqrt};
use heapless::Vec;

/// Most waypoints in a mission.
pub const MAX_WAYPOINTS: usize = 32;
/// Smallest turn radius a corner may get (m): the Observer turns on the spot slowly, but the
/// tracking law needs some room to keep the cross-track error small.
pub const MIN_TURN_RADIUS_M: f32 = 0.5;
/// Legs shorter than this are merged away (m): two waypoints at the same place.
const MIN_LEG_M: f32 = 1.0e-3;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Segment {
    /// From `a` along the unit vector `dir` (3-D) for `len`.
    Line {
        a: [f32; 3],
        dir: [f32; 3],
        len: f32,
    },
    /// Horizontal arc around `c` (at depth `z`) of radius `r` from angle `phi0`, turning
    /// `sgn` (+1 clockwise in NED, i.e. towards +east from +north) for `len`.
    Arc {
        c: [f32; 2],
        z: f32,
        r: f32,
        phi0: f32,
        sgn: f32,
        len: f32,
    },
}

impl Segment {
    fn len(&self) -> f32 {
        match *self {
            Segment::Line { len, .. } | Segment::Arc { len, .. } => len,
        }
    }

    /// Geometry at distance `s` along the segment, derivatives with respect to the virtual
    /// time at speed `v` (`s = v sigma`).
    fn geo(&self, s: f32, v: f32) -> Geo {
        match *self {
            Segment::Line { a, dir, .. } => Geo {
                p: [a[0] + dir[0] * s, a[1] + dir[1] * s, a[2] + dir[2] * s],
                d1: dir.map(|d| d * v),
                ..Geo::default()
            },
            Segment::Arc {
                c, z, r, phi0, sgn, ..
            } => {
                let (sp, cp) = sin_cos(phi0 + sgn * s / r);
                let (v2, v3) = (v * v, v * v * v);
                Geo {
                    p: [c[0] + r * cp, c[1] + r * sp, z],
                    d1: [-sgn * v * sp, sgn * v * cp, 0.0],
                    d2: [-v2 / r * cp, -v2 / r * sp, 0.0],
                    d3: [sgn * v3 / (r * r) * sp, -sgn * v3 / (r * r) * cp, 0.0],
                }
            }
        }
    }
}

/// The path of a mission, ready to sample.
#[derive(Debug, Clone, PartialEq)]
pub struct MissionPath {
    segs: Vec<Segment, { 2 * MAX_WAYPOINTS }>,
    /// Distance along the path at which each waypoint is reached (m).
    reached_at_m: Vec<f32, MAX_WAYPOINTS>,
    speed_m_s: f32,
    total_m: f32,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn norm(a: [f32; 3]) -> f32 {
    sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
}

impl MissionPath {
    /// The path from `start_m` through `waypoints` at `speed_m_s`, corners cut with
    /// `turn_radius_m`. Refused: no waypoint or more than [`MAX_WAYPOINTS`], a non-finite
    /// value, a non-positive speed or radius, a corner that needs a radius below
    /// [`MIN_TURN_RADIUS_M`] (a leg too short for the turn, or a turn back on the same line).
    pub fn new(
        start_m: [f32; 3],
        waypoints: &[[f32; 3]],
        speed_m_s: f32,
        turn_radius_m: f32,
    ) -> Result<Self, Error> {
        positive("speed_m_s", speed_m_s)?;
        positive("turn_radius_m", turn_radius_m)?;
        if waypoints.is_empty() {
            return Err(Error::OutOfRange("waypoints: none"));
        }
        if waypoints.len() > MAX_WAYPOINTS {
            return Err(Error::OutOfRange("waypoints: more than MAX_WAYPOINTS"));
        }
        for v in start_m.iter().chain(waypoints.iter().flatten()) {
            finite("waypoint", *v)?;
        }
        // The corner points: the start, then each waypoint (repeats merged).
        let mut pts: Vec<[f32; 3], { MAX_WAYPOINTS + 1 }> = Vec::new();
        let mut owner: Vec<usize, { MAX_WAYPOINTS + 1 }> = Vec::new();
        let _ = pts.push(start_m);
        let _ = owner.push(usize::MAX);
        for (i, w) in waypoints.iter().enumerate() {
            let last = pts.last().copied().unwrap_or(start_m);
            if norm(sub(*w, last)) > MIN_LEG_M {
                let _ = pts.push(*w);
                let _ = owner.push(i);
            }
        }
        let mut path = Self {
            segs: Vec::new(),
            reached_at_m: Vec::new(),
            speed_m_s,
            total_m: 0.0,
        };
        // Where the current leg starts (after the previous arc).
        let mut from = start_m;
        let mut s = 0.0f32;
        let mut reached = [f32::NAN; MAX_WAYPOINTS];
        let n = pts.len();
        for k in 1..n {
            let (p, q) = (pts.get(k).copied(), pts.get(k - 1).copied());
            let (Some(p), Some(_q)) = (p, q) else {
                break;
            };
            let next = pts.get(k + 1).copied();
            // The arc at p, if there is a next leg and a horizontal turn.
            let arc = next.and_then(|nx| Self::fillet(from, p, nx, turn_radius_m).transpose());
            let arc = match arc {
                Some(Ok(a)) => Some(a),
                Some(Err(e)) => return Err(e),
                None => None,
            };
            let leg_end = arc.map_or(p, |(t_in, ..)| t_in);
            let d = sub(leg_end, from);
            let len = norm(d);
            if len > MIN_LEG_M {
                let dir = d.map(|x| x / len);
                path.push(Segment::Line { a: from, dir, len });
                s += len;
            }
            let w = owner.get(k).copied().unwrap_or(usize::MAX);
            match arc {
                Some((_, t_out, seg)) => {
                    let half = 0.5 * seg.len();
                    if let Some(r) = reached.get_mut(w) {
                        *r = s + half;
                    }
                    path.push(seg);
                    s += seg.len();
                    from = t_out;
                }
                None => {
                    if let Some(r) = reached.get_mut(w) {
                        *r = s;
                    }
                    from = p;
                }
            }
        }
        // A repeated waypoint is reached with the one it repeats.
        let mut last = 0.0;
        for r in reached.iter().take(waypoints.len()) {
            if r.is_finite() {
                last = *r;
            }
            let _ = path
                .reached_at_m
                .push(if r.is_finite() { *r } else { last });
        }
        path.total_m = s;
        Ok(path)
    }

    fn push(&mut self, seg: Segment) {
        // Cannot overflow: at most one line and one arc per waypoint.
        let _ = self.segs.push(seg);
    }

    /// The arc cutting the corner at `p` between the legs from `a` and to `b`: its tangent
    /// points in and out and the segment; `None` without a horizontal turn.
    #[allow(clippy::type_complexity)]
    fn fillet(
        a: [f32; 3],
        p: [f32; 3],
        b: [f32; 3],
        radius: f32,
    ) -> Result<Option<([f32; 3], [f32; 3], Segment)>, Error> {
        let (u, w) = ([p[0] - a[0], p[1] - a[1]], [b[0] - p[0], b[1] - p[1]]);
        let (lu, lw) = (
            sqrt(u[0] * u[0] + u[1] * u[1]),
            sqrt(w[0] * w[0] + w[1] * w[1]),
        );
        if lu < MIN_LEG_M || lw < MIN_LEG_M {
            return Ok(None);
        }
        let (u, w) = ([u[0] / lu, u[1] / lu], [w[0] / lw, w[1] / lw]);
        let cross = u[0] * w[1] - u[1] * w[0];
        let dot = u[0] * w[0] + u[1] * w[1];
        let turn = atan2(cross, dot);
        if turn.abs() < 1.0e-3 {
            return Ok(None);
        }
        // Tangent distance from the corner; at most half of each leg (the other half is the
        // neighbouring corner's).
        let half = 0.5 * turn.abs();
        let (sh, ch) = sin_cos(half);
        let tan_half = sh / ch;
        let room = 0.5 * lu.min(lw);
        let r = radius.min(room / tan_half);
        if r < MIN_TURN_RADIUS_M {
            return Err(Error::OutOfRange(
                "a turn at a waypoint needs a radius below MIN_TURN_RADIUS_M",
            ));
        }
        let d = r * tan_half;
        let t_in = [p[0] - u[0] * d, p[1] - u[1] * d, p[2]];
        let t_out = [p[0] + w[0] * d, p[1] + w[1] * d, p[2]];
        // The centre is to the side the path turns to.
        let sgn = if cross > 0.0 { 1.0 } else { -1.0 };
        let nrm = [-sgn * u[1], sgn * u[0]];
        let c = [t_in[0] + nrm[0] * r, t_in[1] + nrm[1] * r];
        let phi0 = atan2(t_in[1] - c[1], t_in[0] - c[0]);
        Ok(Some((
            t_in,
            t_out,
            Segment::Arc {
                c,
                z: p[2],
                r,
                phi0,
                sgn,
                len: r * turn.abs(),
            },
        )))
    }

    /// Length of the path (m).
    pub fn length_m(&self) -> f32 {
        self.total_m
    }

    /// Time the reference takes to fly it, ramps included (s).
    pub fn duration_s(&self) -> f32 {
        self.total_m / self.speed_m_s + super::path::RAMP_S
    }

    /// The reference `t_s` after the mission started.
    pub fn sample(&self, t_s: f32) -> RefSample {
        let v = self.speed_m_s;
        let w = ramp_finite(t_s, self.total_m / v);
        let mut s = w.s0 * v;
        let mut geo = None;
        for seg in &self.segs {
            if s <= seg.len() {
                geo = Some(seg.geo(s, v));
                break;
            }
            s -= seg.len();
        }
        let g = geo.or_else(|| self.segs.last().map(|seg| seg.geo(seg.len(), v)));
        let Some(mut g) = g else {
            return RefSample {
                t_s,
                ..RefSample::default()
            };
        };
        if t_s <= 0.0 {
            g.d2 = [0.0; 3];
            g.d3 = [0.0; 3];
        }
        compose(t_s, &g, &w)
    }

    /// How many waypoints the reference has passed `t_s` after the mission started.
    pub fn reached(&self, t_s: f32) -> usize {
        let v = self.speed_m_s;
        let s = ramp_finite(t_s, self.total_m / v).s0 * v;
        let done = s >= self.total_m - 1.0e-3;
        self.reached_at_m
            .iter()
            .filter(|&&r| r <= s || done)
            .count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
        norm(sub(a, b))
    }

    #[test]
    fn a_square_is_flown_through_its_corners_and_ends_at_rest_on_the_last_point() {
        let wps = [[10.0, 0.0, 2.0], [10.0, 10.0, 2.0], [0.0, 10.0, 3.0]];
        let m = MissionPath::new([0.0, 0.0, 2.0], &wps, 0.25, 1.5).unwrap();
        // Two corners of 90 degrees: 3 legs shortened by 2 x 1.5 m each corner, 2 quarter arcs.
        let quarter = 1.5 * core::f32::consts::FRAC_PI_2;
        let want = 10.0 + 10.0 + sqrt(100.0 + 1.0) - 4.0 * 1.5 + 2.0 * quarter;
        assert!(
            (m.length_m() - want).abs() < 0.05,
            "{} vs {want}",
            m.length_m()
        );
        let end = m.sample(m.duration_s() + 1.0);
        assert!(dist(end.pos_m, wps[2]) < 1e-3, "{:?}", end.pos_m);
        assert!(norm(end.vel_m_s) < 1e-6);
        assert_eq!(m.reached(m.duration_s() + 1.0), 3);
        assert_eq!(m.reached(0.0), 0);
        // The speed never above the cruise speed, the horizontal acceleration at cruise at most
        // v^2 / R.
        let mut t = 0.0;
        let mut passed = 0;
        while t < m.duration_s() {
            let r = m.sample(t);
            let sp = norm(r.vel_m_s);
            assert!(sp <= 0.25 + 1e-4, "{t}: {sp}");
            let a = sqrt(r.acc_m_s2[0] * r.acc_m_s2[0] + r.acc_m_s2[1] * r.acc_m_s2[1]);
            // Away from the start and stop ramps (whose own acceleration is up to 0.094).
            let cruise = t > super::super::path::RAMP_S && t < m.duration_s() - 2.0 * 5.0;
            if cruise {
                assert!(a <= 0.0625 / 1.5 + 1e-3, "{t}: {a}");
            }
            let now = m.reached(t);
            assert!(now >= passed);
            passed = now;
            t += 0.1;
        }
        // The first corner is cut by R (sqrt 2 - 1) = 0.62 m, no more.
        let closest = (0..2000)
            .map(|k| dist(m.sample(k as f32 * 0.1).pos_m, wps[0]))
            .fold(f32::MAX, f32::min);
        assert!(closest < 0.63, "{closest}");
    }

    #[test]
    fn velocity_is_the_derivative_of_position() {
        let wps = [[5.0, 0.0, 1.0], [5.0, 5.0, 1.0], [10.0, 5.0, 4.0]];
        let m = MissionPath::new([0.0, 0.0, 0.0], &wps, 0.3, 1.0).unwrap();
        let h = 1.0e-2;
        let mut t = 1.0;
        while t < m.duration_s() - 1.0 {
            let (a, b, c) = (m.sample(t - h), m.sample(t), m.sample(t + h));
            for i in 0..3 {
                let fd = (c.pos_m[i] - a.pos_m[i]) / (2.0 * h);
                assert!(
                    (fd - b.vel_m_s[i]).abs() < 2e-3,
                    "t {t} axis {i}: {fd} vs {}",
                    b.vel_m_s[i]
                );
            }
            t += 0.37;
        }
    }

    #[test]
    fn impossible_missions_are_refused_with_a_reason() {
        let s = [0.0; 3];
        assert!(MissionPath::new(s, &[], 0.25, 1.5).is_err());
        assert!(MissionPath::new(s, &[[1.0, f32::NAN, 0.0]], 0.25, 1.5).is_err());
        assert!(MissionPath::new(s, &[[1.0, 0.0, 0.0]], 0.0, 1.5).is_err());
        assert!(MissionPath::new(s, &[[1.0, 0.0, 0.0]; MAX_WAYPOINTS + 1], 0.25, 1.5).is_err());
        // A U-turn on the same line: no radius fits.
        let back = [[10.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
        assert!(MissionPath::new(s, &back, 0.25, 1.5).is_err());
        // Legs of 0.6 m cannot hold a 90-degree turn of 0.5 m or more.
        let tight = [[0.6, 0.0, 0.0], [0.6, 0.6, 0.0], [1.2, 0.6, 0.0]];
        assert!(MissionPath::new(s, &tight, 0.25, 1.5).is_err());
        // A single waypoint is a straight leg; repeats are merged and reached together.
        let m = MissionPath::new(s, &[[3.0, 4.0, 1.0], [3.0, 4.0, 1.0]], 0.25, 1.5).unwrap();
        assert!((m.length_m() - sqrt(26.0)).abs() < 1e-4);
        assert_eq!(m.reached(m.duration_s()), 2);
    }
}
