//! Path references (line, circle, lawnmower, helix): a geometry at constant nominal speed in a
//! *virtual time* `sigma`, and a time warp `sigma(t)` that starts every path smoothly from rest.
//!
//! With `G(sigma)` the position along the path at nominal speed and `sigma(t)` the warp, the
//! chain rule gives the exact derivatives of `p(t) = G(sigma(t))`:
//! ```text
//! p_dot   = G' s1
//! p_ddot  = G'' s1^2 + G' s2
//! p_dddot = G''' s1^3 + 3 G'' s1 s2 + G' s3          (s1, s2, s3 = derivatives of sigma)
//! ```
//! The warp is `sigma_dot(t) = S(t / T_r)` with the quintic smooth-step
//! `S(x) = 10 x^3 - 15 x^4 + 6 x^5` (`S'` and `S''` vanish at both ends), so speed,
//! acceleration and jerk are continuous and the path starts at rest with zero acceleration and
//! jerk. A finite path (the lawnmower, virtual length `Sigma`) also ends at rest:
//! `sigma_dot(t) = S(t / T_r) - S((t - Sigma) / T_r)`, which integrates to exactly `Sigma`.

use super::RefSample;
use crate::math::sin_cos;

/// Ramp time `T_r` of the smooth start (and stop) of every path reference.
pub const RAMP_S: f32 = 5.0;

/// Virtual duration of one lawnmower turn per metre of spacing and per (m/s) of speed:
/// `T_turn = TURN_TIME_PER_SPACING * spacing / speed` (the turn's speed then stays within
/// 0.92..1.09 of the leg speed; its peak curvature is `2.61 / spacing`, against `2 / spacing`
/// for a semicircle).
pub const TURN_TIME_PER_SPACING: f32 = 2.0;

/// A value and three derivatives of a 3-vector.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Geo {
    /// Position.
    pub p: [f32; 3],
    /// First derivative.
    pub d1: [f32; 3],
    /// Second derivative.
    pub d2: [f32; 3],
    /// Third derivative.
    pub d3: [f32; 3],
}

/// `sigma` and its first three time derivatives.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Warp {
    /// `sigma` (s).
    pub s0: f32,
    /// `sigma_dot` (speed fraction, 0..1).
    pub s1: f32,
    /// `sigma_ddot` (1/s).
    pub s2: f32,
    /// `sigma_dddot` (1/s^2).
    pub s3: f32,
}

/// Smooth start from rest: `sigma_dot = S(t / T_r)`.
pub fn ramp(t_s: f32) -> Warp {
    let tr = RAMP_S;
    if t_s <= 0.0 {
        return Warp::default();
    }
    let x = t_s / tr;
    if x >= 1.0 {
        return Warp {
            s0: t_s - 0.5 * tr,
            s1: 1.0,
            s2: 0.0,
            s3: 0.0,
        };
    }
    let x2 = x * x;
    let x3 = x2 * x;
    let om = 1.0 - x;
    Warp {
        // integral of S: x^4 (2.5 - 3 x + x^2)
        s0: tr * x2 * x2 * (2.5 - 3.0 * x + x2),
        s1: x3 * (10.0 - 15.0 * x + 6.0 * x2),
        s2: 30.0 * x2 * om * om / tr,
        s3: 60.0 * x * om * (1.0 - 2.0 * x) / (tr * tr),
    }
}

/// Smooth start from rest and smooth stop after a virtual length `total_s`.
pub fn ramp_finite(t_s: f32, total_s: f32) -> Warp {
    let a = ramp(t_s);
    let b = ramp(t_s - total_s);
    Warp {
        s0: (a.s0 - b.s0).min(total_s),
        s1: a.s1 - b.s1,
        s2: a.s2 - b.s2,
        s3: a.s3 - b.s3,
    }
}

/// Compose a geometry with a warp (chain rule above).
pub fn compose(t_s: f32, g: &Geo, w: &Warp) -> RefSample {
    let (s1, s2, s3) = (w.s1, w.s2, w.s3);
    let mut out = RefSample {
        t_s,
        pos_m: g.p,
        ..RefSample::default()
    };
    for (((((v, a), j), d1), d2), d3) in out
        .vel_m_s
        .iter_mut()
        .zip(out.acc_m_s2.iter_mut())
        .zip(out.jerk_m_s3.iter_mut())
        .zip(g.d1.iter())
        .zip(g.d2.iter())
        .zip(g.d3.iter())
    {
        *v = d1 * s1;
        *a = d2 * s1 * s1 + d1 * s2;
        *j = d3 * s1 * s1 * s1 + 3.0 * d2 * s1 * s2 + d1 * s3;
    }
    out
}

/// Straight line at nominal speed.
pub fn line_geo(start: [f32; 3], heading_rad: f32, speed: f32, sigma: f32) -> Geo {
    let (sh, ch) = sin_cos(heading_rad);
    let [x0, y0, z0] = start;
    let d = speed * sigma;
    Geo {
        p: [x0 + d * ch, y0 + d * sh, z0],
        d1: [speed * ch, speed * sh, 0.0],
        ..Geo::default()
    }
}

/// Horizontal circle (clockwise seen from above in NED: yaw increasing), starting at
/// `center - (0, R)` heading north; with a depth rate it is a helix.
pub fn circle_geo(center: [f32; 3], radius: f32, speed: f32, depth_rate: f32, sigma: f32) -> Geo {
    let om = speed / radius;
    let phi = -core::f32::consts::FRAC_PI_2 + om * sigma;
    let (sp, cp) = sin_cos(phi);
    let [cx, cy, cz] = center;
    let vom = speed * om;
    let vom2 = vom * om;
    Geo {
        p: [cx + radius * cp, cy + radius * sp, cz + depth_rate * sigma],
        d1: [-speed * sp, speed * cp, depth_rate],
        d2: [-vom * cp, -vom * sp, 0.0],
        d3: [vom2 * sp, -vom2 * cp, 0.0],
    }
}

/// Lawnmower layout, precomputed from the variant's fields.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lawnmower {
    /// First leg start.
    pub start: [f32; 3],
    /// Unit vector along the first leg.
    pub dir: [f32; 2],
    /// Unit vector to starboard of the first leg (towards the next legs).
    pub side: [f32; 2],
    /// Leg length.
    pub leg: f32,
    /// Leg spacing.
    pub spacing: f32,
    /// Number of legs (>= 1).
    pub legs: u16,
    /// Nominal speed.
    pub speed: f32,
}

impl Lawnmower {
    /// Build the layout.
    pub fn new(
        start: [f32; 3],
        heading_rad: f32,
        leg: f32,
        spacing: f32,
        legs: u16,
        speed: f32,
    ) -> Self {
        let (sh, ch) = sin_cos(heading_rad);
        Self {
            start,
            dir: [ch, sh],
            side: [-sh, ch],
            leg,
            spacing,
            legs: legs.max(1),
            speed,
        }
    }

    /// Virtual duration of one leg.
    pub fn leg_time(&self) -> f32 {
        self.leg / self.speed
    }

    /// Virtual duration of one turn.
    pub fn turn_time(&self) -> f32 {
        TURN_TIME_PER_SPACING * self.spacing / self.speed
    }

    /// Virtual duration of the whole survey.
    pub fn total_time(&self) -> f32 {
        let n = f32::from(self.legs);
        n * self.leg_time() + (n - 1.0) * self.turn_time()
    }

    /// Geometry at virtual time `sigma` (clamped to the survey).
    ///
    /// Leg `k` runs along `+dir` (k even) or `-dir` (k odd), offset `k * spacing` to the side.
    /// Turn `k` joins leg `k` to leg `k + 1` with, in the frame (leg direction, side),
    /// `x(tau) = V T (tau - 5 tau^4 + 6 tau^5 - 2 tau^6)` and
    /// `y(tau) = spacing (35 tau^4 - 84 tau^5 + 70 tau^6 - 20 tau^7)`, `tau = (sigma - sigma_k) / T`:
    /// position, velocity, acceleration and jerk match the legs at both ends.
    pub fn geo(&self, sigma: f32) -> Geo {
        let tl = self.leg_time();
        let tt = self.turn_time();
        let period = tl + tt;
        let last = self.legs - 1;
        let sigma = sigma.clamp(0.0, self.total_time());
        // `as` saturates; the result is clamped to the last leg.
        let k = ((sigma / period) as u32).min(u32::from(last));
        let kf = k as f32;
        let local = sigma - kf * period;
        let odd = k % 2 == 1;
        let sgn = if odd { -1.0 } else { 1.0 };
        let dk = [sgn * self.dir[0], sgn * self.dir[1]];
        let [x0, y0, z0] = self.start;
        // Start of leg k.
        let off = kf * self.spacing;
        let back = if odd { self.leg } else { 0.0 };
        let bx = x0 + off * self.side[0] + back * self.dir[0];
        let by = y0 + off * self.side[1] + back * self.dir[1];
        let v = self.speed;
        if k == u32::from(last) || local <= tl {
            let s = local.min(tl) * v;
            let s = if k == u32::from(last) { local * v } else { s };
            return Geo {
                p: [bx + s * dk[0], by + s * dk[1], z0],
                d1: [v * dk[0], v * dk[1], 0.0],
                ..Geo::default()
            };
        }
        // Turn k: starts at the end of leg k.
        let ex = bx + self.leg * dk[0];
        let ey = by + self.leg * dk[1];
        let tau = ((local - tl) / tt).clamp(0.0, 1.0);
        let t2 = tau * tau;
        let t3 = t2 * tau;
        let t4 = t3 * tau;
        let a = v * tt;
        let sp = self.spacing;
        // x along dk, y along side; derivatives w.r.t. tau.
        let x0t = a * (tau - 5.0 * t4 + 6.0 * t4 * tau - 2.0 * t4 * t2);
        let x1t = a * (1.0 - 20.0 * t3 + 30.0 * t4 - 12.0 * t4 * tau);
        let x2t = a * (-60.0 * t2 + 120.0 * t3 - 60.0 * t4);
        let x3t = a * (-120.0 * tau + 360.0 * t2 - 240.0 * t3);
        let y0t = sp * t4 * (35.0 - 84.0 * tau + 70.0 * t2 - 20.0 * t3);
        let y1t = sp * t3 * (140.0 - 420.0 * tau + 420.0 * t2 - 140.0 * t3);
        let y2t = sp * t2 * (420.0 - 1680.0 * tau + 2100.0 * t2 - 840.0 * t3);
        let y3t = sp * tau * (840.0 - 5040.0 * tau + 8400.0 * t2 - 4200.0 * t3);
        let inv = 1.0 / tt;
        let inv2 = inv * inv;
        let inv3 = inv2 * inv;
        let map = |x: f32, y: f32| [x * dk[0] + y * self.side[0], x * dk[1] + y * self.side[1]];
        let p = map(x0t, y0t);
        let d1 = map(x1t * inv, y1t * inv);
        let d2 = map(x2t * inv2, y2t * inv2);
        let d3 = map(x3t * inv3, y3t * inv3);
        Geo {
            p: [ex + p[0], ey + p[1], z0],
            d1: [d1[0], d1[1], 0.0],
            d2: [d2[0], d2[1], 0.0],
            d3: [d3[0], d3[1], 0.0],
        }
    }
}
