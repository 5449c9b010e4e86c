//! Reference trajectories for the body origin, with analytic derivatives.
//!
//! Every reference kind produces a [`RefSample`]: the inertial position of the body origin and
//! its first three time derivatives. The laws derive the consistent orientation and body
//! velocities for their plane from it.

use crate::error::{finite, positive, Error};
use serde::{Deserialize, Serialize};

pub mod feasible;
pub mod mission;
pub mod path;
mod sample;

pub use sample::{Deriv3, RefSample};

/// The paper's reference (Section IV): `h_r t^5 / (t^5 + (t_f - t)^5)`, used for
/// `x_r = y_r = z_r`. `t` is clamped to `[0, t_f]`, so the reference rests at 0 before the
/// start and at `h_r` after `t_f` (derivatives zero there). `t_f` is not given in the paper;
/// the default is 100 s (`MODEL_NOTES` section 2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PaperPolynomial {
    /// Final value `h_r`.
    pub h_r_m: f32,
    /// Final time `t_f`.
    pub t_f_s: f32,
}

impl PaperPolynomial {
    /// The paper's values: `h_r = 10 m`, `t_f = 100 s` (assumed).
    pub const PAPER: Self = Self {
        h_r_m: 10.0,
        t_f_s: 100.0,
    };

    /// Refuse non-finite values and a non-positive `t_f`.
    pub fn validate(&self) -> Result<(), Error> {
        crate::error::finite("h_r_m", self.h_r_m)?;
        positive("t_f_s", self.t_f_s)?;
        Ok(())
    }

    /// Value and three derivatives at time `t_s`.
    ///
    /// With `s = t / t_f`, `f(s) = s^5 / (s^5 + (1 - s)^5) = N / D`. Derivatives by the
    /// quotient rule on the polynomials `N` and `D`, then scaled by `h_r / t_f^k`.
    pub fn eval(&self, t_s: f32) -> Deriv3 {
        let tf = self.t_f_s;
        if t_s <= 0.0 {
            return Deriv3::default();
        }
        if t_s >= tf {
            return Deriv3 {
                p: self.h_r_m,
                ..Deriv3::default()
            };
        }
        // f(s) = 1 - f(1 - s): evaluate on the half nearer to its start, where the quotient
        // rule below has no cancellation (near s = 1, N' and f D' are both ~5 and their
        // difference is lost in f32), then mirror: the first and third derivatives are
        // symmetric about s = 1/2, the second antisymmetric.
        let s = t_s / tf;
        let mirrored = s > 0.5;
        let (f0, f1, f2, f3) = Self::shape(if mirrored { 1.0 - s } else { s });
        let (f0, f2) = if mirrored { (1.0 - f0, -f2) } else { (f0, f2) };
        let h = self.h_r_m;
        Deriv3 {
            p: h * f0,
            dp: h * f1 / tf,
            ddp: h * f2 / (tf * tf),
            dddp: h * f3 / (tf * tf * tf),
        }
    }

    /// `f(s) = s^5 / (s^5 + (1 - s)^5)` and its first three derivatives in `s`, for
    /// `s` in [0, 1/2].
    fn shape(s: f32) -> (f32, f32, f32, f32) {
        let c = 1.0 - s;
        // N = s^5 and derivatives in s.
        let s2 = s * s;
        let s3 = s2 * s;
        let s4 = s3 * s;
        let n0 = s4 * s;
        let n1 = 5.0 * s4;
        let n2 = 20.0 * s3;
        let n3 = 60.0 * s2;
        // C = (1 - s)^5.
        let c2 = c * c;
        let c3 = c2 * c;
        let c4 = c3 * c;
        let c0 = c4 * c;
        // D = N + C and derivatives.
        let d0 = n0 + c0;
        let d1 = n1 - 5.0 * c4;
        let d2 = n2 + 20.0 * c3;
        let d3 = n3 - 60.0 * c2;
        // f = N / D  =>  f D = N; differentiate: f' D + f D' = N', etc.
        let f0 = n0 / d0;
        let f1 = (n1 - f0 * d1) / d0;
        let f2 = (n2 - 2.0 * f1 * d1 - f0 * d2) / d0;
        let f3 = (n3 - 3.0 * f2 * d1 - 3.0 * f1 * d2 - f0 * d3) / d0;
        (f0, f1, f2, f3)
    }

    /// The paper's reference point: `x_r = y_r = z_r` all following the polynomial.
    pub fn sample(&self, t_s: f32) -> RefSample {
        let d = self.eval(t_s);
        RefSample {
            t_s,
            pos_m: [d.p; 3],
            vel_m_s: [d.dp; 3],
            acc_m_s2: [d.ddp; 3],
            jerk_m_s3: [d.dddp; 3],
        }
    }
}

/// Every reference the vehicle can be asked to follow.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum Reference {
    /// The paper's polynomial on all three axes.
    Paper(PaperPolynomial),
    /// Hold a fixed point.
    Hold {
        /// The point `[x, y, z]`.
        pos_m: [f32; 3],
    },
    /// Straight line from `start_m` along the horizontal heading `heading_rad` at `speed_m_s`.
    Line {
        /// Start point `[x, y, z]`.
        start_m: [f32; 3],
        /// Direction of travel (yaw of the path).
        heading_rad: f32,
        /// Cruise speed.
        speed_m_s: f32,
    },
    /// Horizontal circle around `center_m` (at its depth).
    Circle {
        /// Centre `[x, y, z]`.
        center_m: [f32; 3],
        /// Radius.
        radius_m: f32,
        /// Speed along the circle.
        speed_m_s: f32,
    },
    /// Lawnmower survey: `legs` parallel legs of `leg_length_m`, `spacing_m` apart, joined by
    /// smooth turns, starting at `start_m` along `heading_rad`.
    Lawnmower {
        /// Start point `[x, y, z]`.
        start_m: [f32; 3],
        /// Heading of the first leg.
        heading_rad: f32,
        /// Length of each leg.
        leg_length_m: f32,
        /// Distance between legs.
        spacing_m: f32,
        /// Number of legs.
        legs: u16,
        /// Speed along the path.
        speed_m_s: f32,
    },
    /// Helix: a circle around `center_m` descending at `depth_rate_m_s`.
    Helix {
        /// Centre `[x, y, z]` at the start.
        center_m: [f32; 3],
        /// Radius.
        radius_m: f32,
        /// Horizontal speed along the circle.
        speed_m_s: f32,
        /// Depth rate (positive = descending).
        depth_rate_m_s: f32,
    },
}

/// Where a reference may take the vehicle: depth between the surface and
/// `max_depth_m`, each horizontal coordinate within `max_range_m` of the origin, speeds up to
/// `max_speed_m_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Largest `|x|`, `|y|` (m).
    pub max_range_m: f32,
    /// Deepest point (m, z positive down); the shallowest is the surface, 0.
    pub max_depth_m: f32,
    /// Fastest speed along the path, and depth rate (m/s).
    pub max_speed_m_s: f32,
}

impl Bounds {
    /// The firmware's: 1 km, 100 m (the Observer's 150 m tether with room for its catenary),
    /// 1 m/s (the Observer's top speed is about 1 m/s on 20 N per thruster).
    pub const VEHICLE: Self = Self {
        max_range_m: 1_000.0,
        max_depth_m: 100.0,
        max_speed_m_s: 1.0,
    };

    fn point(&self, name: &'static str, p: &[f32; 3], margin_m: f32) -> Result<(), Error> {
        let [x, y, z] = *p;
        let r = self.max_range_m - margin_m;
        if x.abs() <= r && y.abs() <= r && (0.0..=self.max_depth_m).contains(&z) {
            Ok(())
        } else {
            Err(Error::OutOfRange(name))
        }
    }

    fn speed(&self, name: &'static str, v: f32) -> Result<(), Error> {
        if v.abs() <= self.max_speed_m_s {
            Ok(())
        } else {
            Err(Error::OutOfRange(name))
        }
    }
}

impl Reference {
    /// [`validate`](Self::validate), then every point the reference starts from or turns
    /// about within `b`, and its speeds: a circle wholly inside, a lawnmower's extent from its
    /// start, a paper polynomial's end depth (it moves all three axes to `h_r`) and its peak
    /// speed `2.5 h_r / t_f`. A line and a helix leave the bounds in time: their start and
    /// speed are checked; the surface's own limits stop them (docs/safety.md).
    pub fn check_bounds(&self, b: &Bounds) -> Result<(), Error> {
        self.validate()?;
        match self {
            Reference::Paper(p) => {
                b.point("h_r_m", &[p.h_r_m; 3], 0.0)?;
                b.speed("h_r_m / t_f_s", 2.5 * p.h_r_m / p.t_f_s)
            }
            Reference::Hold { pos_m } => b.point("pos_m", pos_m, 0.0),
            Reference::Line {
                start_m, speed_m_s, ..
            } => {
                b.point("start_m", start_m, 0.0)?;
                b.speed("speed_m_s", *speed_m_s)
            }
            Reference::Circle {
                center_m,
                radius_m,
                speed_m_s,
            } => {
                b.point("center_m", center_m, *radius_m)?;
                b.speed("speed_m_s", *speed_m_s)
            }
            Reference::Lawnmower {
                start_m,
                leg_length_m,
                spacing_m,
                legs,
                speed_m_s,
                ..
            } => {
                let extent = leg_length_m + spacing_m * f32::from(*legs);
                b.point("start_m", start_m, extent)?;
                b.speed("speed_m_s", *speed_m_s)
            }
            Reference::Helix {
                center_m,
                radius_m,
                speed_m_s,
                depth_rate_m_s,
            } => {
                b.point("center_m", center_m, *radius_m)?;
                b.speed("speed_m_s", *speed_m_s)?;
                b.speed("depth_rate_m_s", *depth_rate_m_s)
            }
        }
    }

    /// Refuse non-finite or non-physical settings.
    pub fn validate(&self) -> Result<(), Error> {
        match self {
            Reference::Paper(p) => p.validate(),
            Reference::Hold { pos_m } => {
                for v in pos_m {
                    crate::error::finite("pos_m", *v)?;
                }
                Ok(())
            }
            Reference::Line {
                start_m,
                heading_rad,
                speed_m_s,
            } => {
                for v in start_m {
                    finite("start_m", *v)?;
                }
                finite("heading_rad", *heading_rad)?;
                positive("speed_m_s", *speed_m_s)?;
                Ok(())
            }
            Reference::Circle {
                center_m,
                radius_m,
                speed_m_s,
            } => {
                for v in center_m {
                    finite("center_m", *v)?;
                }
                positive("radius_m", *radius_m)?;
                positive("speed_m_s", *speed_m_s)?;
                Ok(())
            }
            Reference::Lawnmower {
                start_m,
                heading_rad,
                leg_length_m,
                spacing_m,
                legs,
                speed_m_s,
            } => {
                for v in start_m {
                    finite("start_m", *v)?;
                }
                finite("heading_rad", *heading_rad)?;
                positive("leg_length_m", *leg_length_m)?;
                positive("spacing_m", *spacing_m)?;
                positive("speed_m_s", *speed_m_s)?;
                if *legs == 0 {
                    return Err(Error::NotPositive("legs"));
                }
                Ok(())
            }
            Reference::Helix {
                center_m,
                radius_m,
                speed_m_s,
                depth_rate_m_s,
            } => {
                for v in center_m {
                    finite("center_m", *v)?;
                }
                positive("radius_m", *radius_m)?;
                positive("speed_m_s", *speed_m_s)?;
                finite("depth_rate_m_s", *depth_rate_m_s)?;
                Ok(())
            }
        }
    }

    /// Sample the reference at `t_s` (seconds since the reference started).
    pub fn sample(&self, t_s: f32) -> RefSample {
        match self {
            Reference::Paper(p) => p.sample(t_s),
            Reference::Hold { pos_m } => RefSample {
                t_s,
                pos_m: *pos_m,
                ..RefSample::default()
            },
            Reference::Line {
                start_m,
                heading_rad,
                speed_m_s,
            } => {
                let w = path::ramp(t_s);
                let g = path::line_geo(*start_m, *heading_rad, *speed_m_s, w.s0);
                path::compose(t_s, &g, &w)
            }
            Reference::Circle {
                center_m,
                radius_m,
                speed_m_s,
            } => {
                let w = path::ramp(t_s);
                let g = path::circle_geo(*center_m, *radius_m, *speed_m_s, 0.0, w.s0);
                path::compose(t_s, &g, &w)
            }
            Reference::Helix {
                center_m,
                radius_m,
                speed_m_s,
                depth_rate_m_s,
            } => {
                let w = path::ramp(t_s);
                let g = path::circle_geo(*center_m, *radius_m, *speed_m_s, *depth_rate_m_s, w.s0);
                path::compose(t_s, &g, &w)
            }
            Reference::Lawnmower {
                start_m,
                heading_rad,
                leg_length_m,
                spacing_m,
                legs,
                speed_m_s,
            } => {
                let l = path::Lawnmower::new(
                    *start_m,
                    *heading_rad,
                    *leg_length_m,
                    *spacing_m,
                    *legs,
                    *speed_m_s,
                );
                let w = path::ramp_finite(t_s, l.total_time());
                let g = l.geo(w.s0);
                path::compose(t_s, &g, &w)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_check(r: &PaperPolynomial, t: f32) {
        let h = 1e-3f64;
        // f64 finite differences of the f32 evaluation at scaled times keep round-off small.
        let e = |t: f64| r.eval(t as f32);
        let t = t as f64;
        let d = e(t);
        let dp = (e(t + h).p as f64 - e(t - h).p as f64) / (2.0 * h);
        let ddp = (e(t + h).dp as f64 - e(t - h).dp as f64) / (2.0 * h);
        let dddp = (e(t + h).ddp as f64 - e(t - h).ddp as f64) / (2.0 * h);
        assert!(
            (dp - d.dp as f64).abs() < 2e-3 * (1.0 + d.dp.abs() as f64),
            "dp at {t}"
        );
        assert!(
            (ddp - d.ddp as f64).abs() < 2e-4 + 2e-3 * d.ddp.abs() as f64,
            "ddp at {t}"
        );
        assert!(
            (dddp - d.dddp as f64).abs() < 2e-5 + 5e-3 * d.dddp.abs() as f64,
            "dddp at {t}"
        );
    }

    #[test]
    fn derivatives_match_finite_differences() {
        let r = PaperPolynomial::PAPER;
        for i in 1..100 {
            fd_check(&r, i as f32 + 0.37);
        }
    }

    #[test]
    fn velocity_accurate_near_the_end() {
        // f'(s) = 5 s^4 (1 - s)^4 / D^2 in closed form, evaluated in f64.
        let r = PaperPolynomial::PAPER;
        for i in 0..=2000 {
            let t = i as f64 * 0.05;
            let s = t / 100.0;
            let d = s.powi(5) + (1.0 - s).powi(5);
            let v = 10.0 * 5.0 * s.powi(4) * (1.0 - s).powi(4) / (d * d) / 100.0;
            let got = r.eval(t as f32).dp as f64;
            assert!((got - v).abs() < 1e-6 + 1e-4 * v, "t = {t}: {got} vs {v}");
        }
    }

    #[test]
    fn clamped_outside_range() {
        let r = PaperPolynomial::PAPER;
        assert_eq!(r.eval(-5.0), Deriv3::default());
        let d = r.eval(150.0);
        assert_eq!(d.p, 10.0);
        assert_eq!(d.dp, 0.0);
        assert!((r.eval(50.0).p - 5.0).abs() < 1e-5);
    }
}
