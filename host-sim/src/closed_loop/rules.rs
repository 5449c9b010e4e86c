//! The rules that judge a run (`docs/scenarios.md`): the physical bounds beyond which it
//! stops ([`divergence`]), and the rules of control lost judged at its end
//! ([`lost_control`]: the depth or position error still growing, the turns beyond the
//! path's, the runaway), which apply only to a run that misses its tracking figures; the
//! NEES of an endpoint's own estimate.

use super::estimator_nav::CHI2_95;
use super::report::{len, ratio, Rule, Summary};
use sim_world::plant::PlantState;

/// The control lost, judged at the end of a run that completed: `first_half` is the largest
/// error of the first half, `tail_min` the smallest of the last 20 %. The error still
/// growing: the whole end larger than anything of the first half, and over 1 m.
pub fn still_growing(first_half: f64, tail_min: f64) -> bool {
    tail_min > 1.0 && tail_min > first_half
}

/// The physical bounds of the plant's state and of a thrust command: beyond them the run
/// stops (the figures after would mean nothing). `(rule, threshold, unit, in words)`.
const PHYSICAL: [(&str, f64, &str, &str); 4] = [
    ("position_beyond", 1.0e4, "m", "|position| > 10 km"),
    ("velocity_beyond", 100.0, "m/s", "|velocity| > 100 m/s"),
    ("rate_beyond", 100.0, "rad/s", "|angular rate| > 100 rad/s"),
    ("thrust_beyond", 1.0e4, "N", "thrust command > 10 kN"),
];

/// Why a run left the physical, if it did: the rule of [`PHYSICAL`] and the figure. A
/// vehicle that drifts off is judged at the end ([`still_growing`], the runaway rule), not
/// here.
pub(super) fn divergence(truth: &PlantState, cmd: &[f64; 3], t: f64) -> Option<Rule> {
    let max_abs = |v: &[f64]| v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    let figures = [
        max_abs(&truth.eta[..3]),
        max_abs(&truth.nu[..3]),
        max_abs(&truth.nu[3..]),
        max_abs(cmd),
    ];
    PHYSICAL
        .iter()
        .zip(figures)
        .find(|((_, limit, _, _), v)| v > limit)
        .map(|((name, limit, unit, what), v)| Rule {
            name: (*name).into(),
            figure: v,
            threshold: *limit,
            unit,
            text: format!("diverged at t = {t:.3} s: {what}"),
        })
}

/// The run's error beyond which, after the settle time, a run that misses its tracking
/// figures has run away (m): ten times the tracking figure, the floor of the growth rule.
pub const RUNAWAY_M: f64 = 1.0;

/// Turns of the vehicle beyond the path's: over this the heading control is lost.
pub const MAX_TURNS_OFF_PATH: f64 = 2.0;

/// The vehicle's yaw and the path's direction, unwrapped, for the turns one made more than
/// the other.
#[derive(Debug, Default)]
pub(super) struct Turns {
    yaw: Option<(f64, f64)>,
    path: Option<(f64, f64)>,
    offset: Option<f64>,
    off: f64,
}

impl Turns {
    /// Unwrap `(last, total)` by the new angle `a`.
    fn unwrap(acc: &mut Option<(f64, f64)>, a: f64) -> f64 {
        let (last, total) = acc.unwrap_or((a, a));
        let mut d = (a - last) % std::f64::consts::TAU;
        if d > std::f64::consts::PI {
            d -= std::f64::consts::TAU;
        } else if d < -std::f64::consts::PI {
            d += std::f64::consts::TAU;
        }
        *acc = Some((a, total + d));
        total + d
    }

    /// One tick: the vehicle's yaw, the path's direction when it moves (it keeps the last
    /// one while the reference holds a point).
    pub(super) fn update(&mut self, yaw_rad: f64, path_rad: Option<f64>) {
        let y = Self::unwrap(&mut self.yaw, yaw_rad);
        if let Some(p) = path_rad {
            if self.path.is_none() {
                // The path starts moving: count from here.
                self.offset = None;
            }
            Self::unwrap(&mut self.path, p);
        }
        let p = self.path.map_or(0.0, |(_, total)| total);
        let diff = y - p;
        let offset = *self.offset.get_or_insert(diff);
        self.off = (diff - offset).abs() / std::f64::consts::TAU;
    }

    pub(super) fn off_path_turns(&self) -> f64 {
        self.off
    }
}

/// The position NEES of an estimate whose standard deviations are known per axis (the
/// firmware reports no cross terms): `sum (e_i / std_i)^2` on the plane's axes against the
/// 95 % chi-square bound of as many degrees of freedom, as the host's estimator stage does
/// with its full covariance.
#[derive(Debug, Default)]
pub(super) struct DiagonalNees {
    inside: u64,
    n: u64,
}

impl DiagonalNees {
    pub(super) fn add(&mut self, err_m: [f64; 3], std_m: [f64; 3], axes: [bool; 3]) {
        let (mut q, mut dof) = (0.0, 0usize);
        for ((e, sd), on) in err_m.iter().zip(std_m).zip(axes) {
            if on {
                if !(sd > 0.0 && sd.is_finite()) {
                    return;
                }
                q += (e / sd) * (e / sd);
                dof += 1;
            }
        }
        let Some(bound) = dof.checked_sub(1).and_then(|i| CHI2_95.get(i)) else {
            return;
        };
        self.n += 1;
        self.inside += u64::from(q <= *bound);
    }

    pub(super) fn fraction(&self) -> Option<f64> {
        (self.n > 0).then(|| ratio(self.inside, self.n))
    }
}

/// The figures of a completed run the rules of control lost judge, besides its summary.
#[derive(Debug, Clone, Copy)]
pub(super) struct EndFigures {
    /// The depth is judged (not in the horizontal plane).
    pub depth_judged: bool,
    /// Largest position error and depth error of the first half (m).
    pub first_half_max_m: f64,
    pub first_half_depth_max_m: f64,
    /// Smallest position error and depth error of the last 20 % (m).
    pub tail_min_m: f64,
    pub tail_depth_min_m: f64,
    /// The start transient the runaway rule leaves out (s).
    pub settle_s: f64,
    /// Depth minus the reference depth at the end (m, positive below).
    pub depth_off_end_m: f64,
}

/// The rules of control lost, judged at the end on the true state of a run that completed
/// and misses its tracking figures, in this order: the depth error still growing, the
/// vehicle turned over [`MAX_TURNS_OFF_PATH`] more than its path, the position error still
/// growing, the position error over [`RUNAWAY_M`] after the settle time.
pub(super) fn lost_control(s: &Summary, m: &EndFigures) -> Option<Rule> {
    let rule = |name: &str, figure: f64, threshold: f64, unit, text: String| Rule {
        name: name.into(),
        figure,
        threshold,
        unit,
        text,
    };
    if m.depth_judged && still_growing(m.first_half_depth_max_m, m.tail_depth_min_m) {
        let z = m.depth_off_end_m;
        return Some(rule(
            "depth_growing",
            m.tail_depth_min_m,
            m.first_half_depth_max_m.max(1.0),
            "m",
            format!(
                "lost depth control: {:.1} m {} its reference depth at the end, and still going",
                z.abs(),
                if z > 0.0 { "below" } else { "above" }
            ),
        ));
    }
    if s.max_turns_off_path > MAX_TURNS_OFF_PATH {
        return Some(rule(
            "heading_turns",
            s.max_turns_off_path,
            MAX_TURNS_OFF_PATH,
            "turns",
            format!(
                "lost heading control: turned {:.1} turns more than the path",
                s.max_turns_off_path
            ),
        ));
    }
    if still_growing(m.first_half_max_m, m.tail_min_m) {
        return Some(rule(
            "position_growing",
            m.tail_min_m,
            m.first_half_max_m.max(1.0),
            "m",
            format!(
                "lost position control: the error grows ({} at the end, at most {} in the first half)",
                len(s.final_position_error_m),
                len(m.first_half_max_m)
            ),
        ));
    }
    let worst = s.max_position_error_after_settle_m;
    (worst > RUNAWAY_M).then(|| {
        rule(
            "runaway",
            worst,
            RUNAWAY_M,
            "m",
            format!(
                "lost position control: {} off its reference after the first {} s (over {})",
                len(worst),
                m.settle_s,
                len(RUNAWAY_M)
            ),
        )
    })
}

/// How far an identification run went from its start: the manoeuvre is flown in `Hold`
/// around the start point, not along the scenario's reference, so such a run is judged by
/// the room the manoeuvre was given (`[identification] radius_m`, `depth_band_m`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentRoom {
    /// Start position `[x, y, z]` (m).
    pub start_m: [f64; 3],
    /// The room's radius (m).
    pub radius_m: f64,
    /// The half-height of the room's depth band (m).
    pub depth_band_m: f64,
    /// Farthest horizontal distance from the start seen (m).
    pub max_horizontal_m: f64,
    /// Largest depth offset from the start seen (m).
    pub max_depth_off_m: f64,
}

impl IdentRoom {
    /// Take the vehicle's pose `eta` (`[x, y, z, roll, pitch, yaw]`) into the extremes seen.
    pub fn update(&mut self, eta: &[f64; 6]) {
        let [x0, y0, z0] = self.start_m;
        self.max_horizontal_m = self.max_horizontal_m.max((eta[0] - x0).hypot(eta[1] - y0));
        self.max_depth_off_m = self.max_depth_off_m.max((eta[2] - z0).abs());
    }

    /// The rule an identification run broke: it left its room (horizontally or in depth).
    pub fn left(&self) -> Option<Rule> {
        let rule = |name: &str, figure: f64, threshold: f64, what: &str| Rule {
            name: name.into(),
            figure,
            threshold,
            unit: "m",
            text: format!(
                "lost control in the identification manoeuvre: {} from the start, over its \
                 room of {}",
                len(figure),
                what
            ),
        };
        if self.max_horizontal_m > self.radius_m {
            return Some(rule(
                "ident_room",
                self.max_horizontal_m,
                self.radius_m,
                &format!("{} radius", len(self.radius_m)),
            ));
        }
        (self.max_depth_off_m > self.depth_band_m).then(|| {
            rule(
                "ident_depth_band",
                self.max_depth_off_m,
                self.depth_band_m,
                &format!("{} in depth", len(self.depth_band_m)),
            )
        })
    }
}
