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

use super::sample::RefSample;
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
        let sigma = crate::math::clamp(sigma, 0.0, self.total_time());
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
            // (sigma is clamped to the survey, so the last leg ends at its length.)
            let s = local.min(tl) * v;
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
        let a = v * tt;
        let sp = self.spacing;
        // x along dk, y along side; derivatives w.r.t. tau, in factored forms (the expanded
        // polynomials cancel badly in f32 near the ends of the turn). x is symmetric about
        // tau = 1/2 and y antisymmetric (y(tau) = 1 - y(1 - tau) for spacing 1), so the
        // position is evaluated on the nearer half.
        let om = 1.0 - tau;
        let (m, mirrored) = if tau > 0.5 { (om, true) } else { (tau, false) };
        let m2 = m * m;
        let m4 = m2 * m2;
        let xm = a * (m - 5.0 * m4 + 6.0 * m4 * m - 2.0 * m4 * m2);
        let ym = sp * m4 * (35.0 - 84.0 * m + 70.0 * m2 - 20.0 * m2 * m);
        let x0t = xm;
        let y0t = if mirrored { sp - ym } else { ym };
        let x1t = a
            * (1.0 - 2.0 * tau)
            * (1.0 + 2.0 * tau + 4.0 * tau * tau - 12.0 * tau * tau * tau
                + 6.0 * tau * tau * tau * tau);
        let x1t = if mirrored {
            let mm = m;
            -a * (1.0 - 2.0 * mm)
                * (1.0 + 2.0 * mm + 4.0 * mm * mm - 12.0 * mm * mm * mm + 6.0 * mm * mm * mm * mm)
        } else {
            x1t
        };
        let tom = tau * om;
        let x2t = -60.0 * a * tom * tom;
        let x3t = -120.0 * a * tom * (1.0 - 2.0 * tau);
        let y1t = 140.0 * sp * tom * tom * tom;
        let y2t = 420.0 * sp * tom * tom * (1.0 - 2.0 * tau);
        let y3t = 840.0 * sp * tom * (1.0 - 5.0 * tau + 5.0 * tau * tau);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::Reference;

    fn refs() -> [Reference; 4] {
        [
            Reference::Line {
                start_m: [1.0, -2.0, 3.0],
                heading_rad: 0.7,
                speed_m_s: 0.4,
            },
            Reference::Circle {
                center_m: [0.0, 5.0, 2.0],
                radius_m: 5.0,
                speed_m_s: 0.25,
            },
            Reference::Lawnmower {
                start_m: [0.0, 0.0, 3.0],
                heading_rad: 0.3,
                leg_length_m: 15.0,
                spacing_m: 5.0,
                legs: 3,
                speed_m_s: 0.25,
            },
            Reference::Helix {
                center_m: [0.0, 5.0, 1.0],
                radius_m: 5.0,
                speed_m_s: 0.25,
                depth_rate_m_s: 0.05,
            },
        ]
    }

    /// Central differences (in f64 of the f32 samples) of each derivative against the next.
    #[test]
    fn derivatives_match_finite_differences() {
        let h = 1e-2f32;
        for r in refs() {
            r.validate().unwrap();
            let mut t = 0.05f32;
            while t < 260.0 {
                let s = r.sample(t);
                let (ta, tb) = (t - h, t + h);
                let a = r.sample(ta);
                let b = r.sample(tb);
                // The f32 times are not exactly t -+ h: divide by the real spacing.
                let span = f64::from(tb) - f64::from(ta);
                for k in 0..3 {
                    let fd = |x: f32, y: f32| (f64::from(y) - f64::from(x)) / span;
                    let v = fd(a.pos_m[k], b.pos_m[k]);
                    let acc = fd(a.vel_m_s[k], b.vel_m_s[k]);
                    let j = fd(a.acc_m_s2[k], b.acc_m_s2[k]);
                    // Position is O(10 m) in f32: its difference quotient carries ~1e-3 m/s
                    // round-off; the higher derivatives are small numbers and match tighter.
                    assert!(
                        (v - f64::from(s.vel_m_s[k])).abs() < 3e-3,
                        "{r:?} vel t={t}"
                    );
                    assert!(
                        (acc - f64::from(s.acc_m_s2[k])).abs() < 2e-4,
                        "{r:?} acc t={t}: {acc} vs {}",
                        s.acc_m_s2[k]
                    );
                    assert!(
                        (j - f64::from(s.jerk_m_s3[k])).abs() < 1e-4,
                        "{r:?} jerk t={t}"
                    );
                }
                t += 0.731;
            }
        }
    }

    /// Position, velocity, acceleration and jerk are continuous at the lawnmower joints and at
    /// the ends of the ramps.
    #[test]
    fn continuous_at_joints() {
        let l = Lawnmower::new([0.0, 0.0, 3.0], 0.3, 15.0, 5.0, 3, 0.25);
        let tl = l.leg_time();
        let tt = l.turn_time();
        let mut joints = vec![];
        for k in 0..2 {
            let base = k as f32 * (tl + tt);
            joints.push(base + tl);
            joints.push(base + tl + tt);
        }
        let e = 1e-3;
        for sj in joints {
            let a = l.geo(sj - e);
            let b = l.geo(sj + e);
            for k in 0..3 {
                assert!((a.p[k] - b.p[k]).abs() < 2e-3, "pos at {sj}");
                assert!((a.d1[k] - b.d1[k]).abs() < 1e-4, "vel at {sj}");
                assert!((a.d2[k] - b.d2[k]).abs() < 1e-4, "acc at {sj}");
                assert!((a.d3[k] - b.d3[k]).abs() < 1e-4, "jerk at {sj}");
            }
        }
        for t in [0.0, RAMP_S] {
            let a = ramp(t - 1e-4);
            let b = ramp(t + 1e-4);
            assert!((a.s1 - b.s1).abs() < 1e-3 && (a.s2 - b.s2).abs() < 1e-3);
            assert!((a.s3 - b.s3).abs() < 1e-2);
        }
    }

    #[test]
    fn starts_at_rest_and_lawnmower_ends_at_rest() {
        for r in refs() {
            let s = r.sample(0.0);
            assert_eq!(s.vel_m_s, [0.0; 3]);
            assert_eq!(s.acc_m_s2, [0.0; 3]);
            assert_eq!(s.jerk_m_s3, [0.0; 3]);
        }
        let l = Lawnmower::new([0.0, 0.0, 3.0], 0.0, 15.0, 5.0, 3, 0.25);
        let r = Reference::Lawnmower {
            start_m: [0.0, 0.0, 3.0],
            heading_rad: 0.0,
            leg_length_m: 15.0,
            spacing_m: 5.0,
            legs: 3,
            speed_m_s: 0.25,
        };
        let end = r.sample(l.total_time() + 2.0 * RAMP_S);
        assert_eq!(end.vel_m_s, [0.0; 3]);
        // Third leg ends back at the start side, two spacings to starboard.
        assert!((end.pos_m[0] - 15.0).abs() < 1e-3, "{end:?}");
        assert!((end.pos_m[1] - 10.0).abs() < 1e-3, "{end:?}");
    }

    #[test]
    fn cruise_speed_and_circle_geometry() {
        let r = Reference::Circle {
            center_m: [0.0, 5.0, 2.0],
            radius_m: 5.0,
            speed_m_s: 0.25,
        };
        for t in [10.0f32, 50.0, 123.4] {
            let s = r.sample(t);
            let [x, y, z] = s.pos_m;
            assert!(((x * x + (y - 5.0) * (y - 5.0)).sqrt() - 5.0).abs() < 1e-4);
            assert_eq!(z, 2.0);
            let v = (s.vel_m_s[0].powi(2) + s.vel_m_s[1].powi(2)).sqrt();
            assert!((v - 0.25).abs() < 1e-5);
        }
    }

    #[test]
    fn validate_rejects_bad_values() {
        let bad = [
            Reference::Line {
                start_m: [f32::NAN, 0.0, 0.0],
                heading_rad: 0.0,
                speed_m_s: 1.0,
            },
            Reference::Circle {
                center_m: [0.0; 3],
                radius_m: 0.0,
                speed_m_s: 1.0,
            },
            Reference::Lawnmower {
                start_m: [0.0; 3],
                heading_rad: 0.0,
                leg_length_m: 10.0,
                spacing_m: 2.0,
                legs: 0,
                speed_m_s: 0.3,
            },
            Reference::Helix {
                center_m: [0.0; 3],
                radius_m: 2.0,
                speed_m_s: -0.1,
                depth_rate_m_s: 0.0,
            },
            Reference::Helix {
                center_m: [0.0; 3],
                radius_m: 2.0,
                speed_m_s: 0.1,
                depth_rate_m_s: f32::INFINITY,
            },
        ];
        for r in bad {
            assert!(r.validate().is_err(), "{r:?}");
        }
    }
}
