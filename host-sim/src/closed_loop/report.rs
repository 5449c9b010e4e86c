//! What a run reports: the summary (`summary.json`), its targets (`[expect]`), the rules
//! that judged it and its verdict.

use serde::Serialize;
use sim_scenario::ExpectSpec;

/// Figures of the navigation stage for `summary.json` (the truth path leaves them empty).
#[derive(Debug, Clone, Default, Serialize)]
pub struct NavReport {
    /// `truth` or `estimator`.
    pub source: String,
    /// Share of control ticks whose position NEES lies inside the 95 % chi-square bound.
    pub nees_in_bounds_fraction: Option<f64>,
    /// USBL fixes replaced by multipath outliers and delivered to the estimator (an outlier
    /// drawn in the run's last latency window never arrives and is not counted).
    pub usbl_outliers_injected: u64,
    /// USBL fixes the estimator rejected on its innovation gate.
    pub usbl_fixes_rejected: u64,
    /// The navigation floor: the smoother's RMS on the same measurements and the ratio
    /// (estimator runs in process only).
    pub floor: Option<super::floor::NavFloor>,
}

/// The per-run summary, written as `summary.json`.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// `xz`, `xy` or `3d`.
    pub plane: String,
    /// `paper` or `tracking`.
    pub controller: String,
    /// Reference kind.
    pub reference: String,
    /// Thruster limits applied.
    pub saturate: bool,
    /// Requested simulated time (s).
    pub duration_s: f64,
    /// Simulated time reached (s).
    pub simulated_s: f64,
    /// Position error at the end (m).
    pub final_position_error_m: f64,
    /// Largest position error (m).
    pub max_position_error_m: f64,
    /// Largest position error after the first 10 s (m).
    pub max_position_error_after_10s_m: f64,
    /// RMS position error over the whole run (m).
    pub rms_position_error_m: f64,
    /// RMS position error over the last 20 % of the run (m).
    pub rms_position_error_tail_m: f64,
    /// RMS position error over the last 80 % of the run (m).
    pub rms_position_error_last80_m: f64,
    /// Final position error per axis `[x, y, z]` (m).
    pub final_position_error_xyz_m: [f64; 3],
    /// Angle error at the end, as the law reports it (rad).
    pub final_angle_error_rad: f64,
    /// Largest |angle error| after the first 10 s (rad).
    pub max_angle_error_after_10s_rad: f64,
    /// Largest |thruster command| (N).
    pub max_abs_thruster_force_n: f64,
    /// Largest |requested generalized force| `[tau_1 (N), tau_2 (N m), tau_3 (N)]`.
    pub max_abs_requested_force: [f64; 3],
    /// Share of control ticks with saturated thrusters.
    pub saturated_fraction: f64,
    /// RMS of the navigation position (what the controller saw) against the true position,
    /// on the plane's axes, after the first 10 s (m).
    pub rms_estimation_error_m: f64,
    /// The navigation stage's own figures.
    pub navigation: NavReport,
    /// Largest position error after the `[expect]` table's `settle_s` (10 s without it) (m).
    pub max_position_error_after_settle_m: f64,
    /// The vehicle's net yaw rotation minus the path's, largest over the run (turns; XY and
    /// 3-D only, 0 otherwise).
    pub max_turns_off_path: f64,
    /// The run diverged: a state or force beyond the physical (the run stopped), or, judged
    /// at the end of a run that misses its tracking figures, control lost (`lost_control`).
    pub diverged: bool,
    /// Control lost, judged on the true state of a run that misses its tracking figures
    /// ([`meets_tracking_figures`]): depth (the depth error at the end larger than all of the
    /// first half and over 1 m), heading (over 2 turns more than the path), or position (the
    /// same growth rule on the position error, or over 1 m off after the settle time).
    pub lost_control: Option<String>,
    /// The rule that decided the verdict and the figure that fired it: the divergence or
    /// loss of control, else the first `[expect]` target missed; none when nothing fired.
    pub rule: Option<Rule>,
    /// A NaN or infinity appeared.
    pub nan_detected: bool,
    /// Why the run stopped.
    pub stop_reason: String,
    /// The run against its scenario's `[expect]` table (absent without one).
    pub targets: Option<Targets>,
    /// One-line verdict: against the targets when the scenario declares them, else the
    /// figures (final error, last-20 % RMS) and no judgement; a divergence is named.
    pub verdict: String,
    /// Plant RK4 steps done.
    pub sim_steps: u64,
    /// Control steps done.
    pub control_steps: u64,
    /// Wall-clock time of the simulation (s).
    pub wall_time_s: f64,
    /// Final plant state `[x, y, z, roll, pitch, yaw, u, v, w, p, q, r]`.
    pub final_state: Vec<f64>,
    /// The first time the vehicle met the surface or the seabed (`[water]`), if it did:
    /// "hit the seabed at t = 12.340 s".
    pub boundary_contact: Option<String>,
}

/// A rule that fired: its name (the rules of `docs/scenarios.md`), the figure it judged
/// and the threshold the figure crossed, in the unit given, and the judgement in words.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Rule {
    /// The rule: `non_finite`, `position_beyond`, `velocity_beyond`, `rate_beyond`,
    /// `thrust_beyond` (the run stopped), `depth_growing`, `heading_turns`,
    /// `position_growing`, `runaway` (control lost, judged at the end), or the `[expect]`
    /// target missed (`expect.<key>`, e.g. `expect.rms_last80_m`).
    pub name: String,
    /// The figure the rule judged.
    pub figure: f64,
    /// The threshold it crossed.
    pub threshold: f64,
    /// The unit of both: `m`, `m/s`, `rad/s`, `N`, `turns`, `s`, or `-`.
    pub unit: &'static str,
    /// The judgement in words.
    pub text: String,
}

impl Rule {
    /// The rule and its figure, short, for a table: `runaway 2.21 > 1 m`.
    pub fn short(&self) -> String {
        let num = |v: f64| {
            if v == 0.0 || (1e-3..1e5).contains(&v.abs()) {
                format!("{}", (v * 1e3).round() / 1e3)
            } else {
                format!("{v:.2e}")
            }
        };
        let op = match self.figure.partial_cmp(&self.threshold) {
            Some(std::cmp::Ordering::Less) => "<",
            Some(std::cmp::Ordering::Equal) => "=",
            _ => ">",
        };
        let unit = if self.unit == "-" { "" } else { self.unit };
        format!(
            "{} {} {op} {} {unit}",
            self.name,
            num(self.figure),
            num(self.threshold)
        )
        .trim_end()
        .to_string()
    }
}

/// Whether the run meets its tracking figures: the position bounds of its `[expect]`
/// (`final_m`, `max_m`, `rms_m`, `rms_last80_m`, `tail_rms_m`) when it declares any, else
/// the project's tracking figure (the last-20 % RMS under [`TRACKING_M`]). A run that meets
/// them is never judged to have lost control: the rules of loss apply only to the others.
pub fn meets_tracking_figures(expect: Option<&ExpectSpec>, s: &Summary) -> bool {
    let bounds: Vec<(&str, f64)> = expect
        .map(|e| {
            e.bounds()
                .into_iter()
                .filter(|(k, _)| *k != "estimation_rms_m")
                .collect()
        })
        .unwrap_or_default();
    if bounds.is_empty() {
        return s.rms_position_error_tail_m < TRACKING_M;
    }
    bounds.iter().all(|(k, b)| bound_figure(k, s) <= *b)
}

/// The tracking figure of the project: a run tracks when its errors are under 10 cm (m).
pub const TRACKING_M: f64 = 0.1;

/// The figure of the summary an `[expect]` bound is compared with.
fn bound_figure(key: &str, s: &Summary) -> f64 {
    match key {
        "final_m" => s.final_position_error_m,
        "max_m" => s.max_position_error_after_settle_m,
        "rms_m" => s.rms_position_error_m,
        "rms_last80_m" => s.rms_position_error_last80_m,
        "tail_rms_m" => s.rms_position_error_tail_m,
        _ => s.rms_estimation_error_m,
    }
}

/// The first target of `t` missed, as a rule: its key, figure and bound.
fn first_missed(expect: &ExpectSpec, s: &Summary, t: &Targets) -> Option<Rule> {
    let missed = t.checks.iter().find(|c| !c.met)?;
    let key = missed.key;
    let (figure, threshold, unit) = match key {
        "diverges" | "tracks" | "no_divergence" => (
            f64::from(u8::from(s.diverged || s.nan_detected)),
            f64::from(u8::from(expect.diverges)),
            "-",
        ),
        "outliers_rejected" => (
            s.navigation.usbl_fixes_rejected as f64,
            s.navigation.usbl_outliers_injected as f64,
            "-",
        ),
        k => (
            bound_figure(k, s),
            expect
                .bounds()
                .into_iter()
                .find(|(b, _)| *b == k)
                .map_or(f64::NAN, |(_, v)| v),
            "m",
        ),
    };
    let (figure, threshold) = if key == "tracks" {
        (
            s.final_position_error_m.max(s.rms_position_error_tail_m),
            TRACKING_M,
        )
    } else {
        (figure, threshold)
    };
    Some(Rule {
        name: format!("expect.{key}"),
        figure,
        threshold,
        unit: if key == "tracks" { "m" } else { unit },
        text: format!("{}: {}", missed.target, missed.measured),
    })
}

/// One target of `[expect]` against the run.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TargetCheck {
    /// The `[expect]` key (`no_divergence` for the check every run without `diverges` or
    /// `tracks` gets).
    #[serde(skip)]
    pub key: &'static str,
    /// What was expected, e.g. `RMS last 80 % <= 2.0 cm`.
    pub target: String,
    /// What the run did (the figure, or a word).
    pub measured: String,
    /// Met.
    pub met: bool,
}

/// A run against its scenario's `[expect]` table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Targets {
    /// Every target met.
    pub met: bool,
    /// Each target.
    pub checks: Vec<TargetCheck>,
}

/// The verdict for a table: against the targets `meets` / `MISSES`; without targets `-`,
/// or `DIVERGED` / `NaN`; then the rule that fired and its figure, if one did
/// (`DIVERGED runaway 5.84 > 1 m`).
pub fn verdict_word(s: &Summary) -> String {
    let word = match &s.targets {
        Some(t) if t.met => "meets",
        Some(_) => "MISSES",
        None if s.nan_detected => "NaN",
        None if s.diverged => "DIVERGED",
        None => "-",
    };
    match &s.rule {
        Some(r) => format!("{word} {}", r.short()),
        None => word.to_string(),
    }
}

/// The figures of a run in words: a divergence or loss of control named, else the final
/// error and the last-20 % RMS.
pub fn figures(s: &Summary) -> String {
    if s.nan_detected || s.diverged {
        let mut why = s
            .lost_control
            .clone()
            .unwrap_or_else(|| s.stop_reason.clone());
        if s.lost_control.is_some() && s.stop_reason != "completed" {
            why = format!("{}; {why}", s.stop_reason);
        }
        return why;
    }
    let (f, t) = (s.final_position_error_m, s.rms_position_error_tail_m);
    let worst = f.max(t);
    if worst < 0.01 {
        format!(
            "final error {:.3} mm, last-20 % RMS {:.3} mm",
            1e3 * f,
            1e3 * t
        )
    } else if worst < 0.1 {
        format!(
            "final error {:.1} cm, last-20 % RMS {:.1} cm",
            1e2 * f,
            1e2 * t
        )
    } else {
        format!("final error {f:.2} m, last-20 % RMS {t:.2} m")
    }
}

/// A length in words for the verdict: mm under 1 cm, cm under 1 m, m above.
/// `part / whole`, 0 for nothing counted: a share of the control steps, or a mean per step.
/// One rule for the loop's figures and the firmware's.
pub fn ratio(part: u64, whole: u64) -> f64 {
    if whole > 0 {
        part as f64 / whole as f64
    } else {
        0.0
    }
}

pub(super) fn len(m: f64) -> String {
    if !m.is_finite() {
        format!("{m}")
    } else if m < 0.01 {
        format!("{:.3} mm", 1e3 * m)
    } else if m < 1.0 {
        format!("{:.1} cm", 1e2 * m)
    } else {
        format!("{m:.2} m")
    }
}

/// The run `s` against `expect` (see [`ExpectSpec`]).
pub fn judge(expect: &ExpectSpec, s: &Summary) -> Targets {
    let mut checks = Vec::new();
    let lost = s.diverged || s.nan_detected;
    if expect.diverges {
        checks.push(TargetCheck {
            key: "diverges",
            target: "diverges".into(),
            measured: if lost {
                figures(s)
            } else {
                "did not diverge".into()
            },
            met: lost,
        });
    }
    if let Some(tracks) = expect.tracks {
        let worst = s.final_position_error_m.max(s.rms_position_error_tail_m);
        let tracked = !lost && worst < 0.1;
        checks.push(TargetCheck {
            key: "tracks",
            target: if tracks {
                "tracks (final and last-20 % RMS < 10 cm)".into()
            } else {
                "does not track (final or last-20 % RMS >= 10 cm, or diverges)".into()
            },
            measured: if lost { figures(s) } else { len(worst) },
            met: tracked == tracks,
        });
    }
    if !expect.diverges && lost && expect.tracks.is_none() {
        checks.push(TargetCheck {
            key: "no_divergence",
            target: "no divergence".into(),
            measured: figures(s),
            met: false,
        });
    }
    for (key, bound) in expect.bounds() {
        let v = bound_figure(key, s);
        let name = match key {
            "final_m" => "final".to_string(),
            "max_m" => format!("max after {} s", expect.settle_s),
            "rms_m" => "RMS".into(),
            "rms_last80_m" => "RMS last 80 %".into(),
            "tail_rms_m" => "RMS last 20 %".into(),
            _ => "estimation RMS".into(),
        };
        checks.push(TargetCheck {
            key,
            target: format!("{name} <= {}", len(bound)),
            measured: len(v),
            // A NaN (no estimate, an empty window) does not meet a bound.
            met: !lost && v <= bound,
        });
    }
    if expect.outliers_rejected {
        let n = &s.navigation;
        checks.push(TargetCheck {
            key: "outliers_rejected",
            target: "every outlier received rejected".into(),
            measured: format!(
                "{} of {} rejected",
                n.usbl_fixes_rejected, n.usbl_outliers_injected
            ),
            met: n.usbl_fixes_rejected >= n.usbl_outliers_injected,
        });
    }
    Targets {
        met: checks.iter().all(|c| c.met),
        checks,
    }
}

/// The rule of `s`'s verdict when no divergence or loss fired: the first of its targets
/// missed, if any.
pub fn missed_rule(expect: &ExpectSpec, s: &Summary) -> Option<Rule> {
    s.targets.as_ref().and_then(|t| first_missed(expect, s, t))
}

/// The one-line verdict of a summary: against its targets when it has them (`meets its
/// targets: ...`, `MISSES its targets: ...`), else the figures.
pub fn verdict(s: &Summary) -> String {
    match &s.targets {
        None => format!("no targets declared: {}", figures(s)),
        Some(t) => {
            let list = |met: bool| {
                t.checks
                    .iter()
                    .filter(|c| c.met == met)
                    .map(|c| format!("{}: {}", c.target, c.measured))
                    .collect::<Vec<_>>()
                    .join("; ")
            };
            if t.met {
                format!("meets its targets: {}", list(true))
            } else {
                format!("MISSES its targets: {}", list(false))
            }
        }
    }
}
