//! The scenario's `[reference]`: the path to follow, as the core's [`Reference`].

use super::*;
use anyhow::{anyhow, Result};
use controller_core::error::Error as CoreError;
use controller_core::reference::{PaperPolynomial, Reference};
use serde::{Deserialize, Serialize};

/// The `[reference]` table. `kind` selects the variant; the other keys are its fields.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum ReferenceSpec {
    /// The paper's polynomial `h_r t^5 / (t^5 + (t_f - t)^5)` on x, y and z.
    Paper {
        /// Final value (m).
        #[serde(default = "d_hr")]
        h_r_m: f64,
        /// Final time (s).
        #[serde(default = "d_tf")]
        t_f_s: f64,
    },
    /// Hold a fixed point.
    Hold {
        /// The point `[x, y, z]` (m).
        #[serde(default)]
        pos_m: [f64; 3],
    },
    /// Straight line.
    Line {
        /// Start point.
        #[serde(default)]
        start_m: [f64; 3],
        /// Direction of travel (rad).
        #[serde(default)]
        heading_rad: f64,
        /// Speed (m/s).
        #[serde(default = "d_speed")]
        speed_m_s: f64,
    },
    /// Horizontal circle.
    Circle {
        /// Centre.
        #[serde(default)]
        center_m: [f64; 3],
        /// Radius (m).
        #[serde(default = "d_radius")]
        radius_m: f64,
        /// Speed along the circle (m/s).
        #[serde(default = "d_speed")]
        speed_m_s: f64,
    },
    /// Lawnmower survey.
    Lawnmower {
        /// Start point.
        #[serde(default)]
        start_m: [f64; 3],
        /// Heading of the first leg (rad).
        #[serde(default)]
        heading_rad: f64,
        /// Leg length (m).
        #[serde(default = "d_leg")]
        leg_length_m: f64,
        /// Distance between legs (m).
        #[serde(default = "d_spacing")]
        spacing_m: f64,
        /// Number of legs.
        #[serde(default = "d_legs")]
        legs: u16,
        /// Speed (m/s).
        #[serde(default = "d_speed")]
        speed_m_s: f64,
    },
    /// Descending helix.
    Helix {
        /// Centre at the start.
        #[serde(default)]
        center_m: [f64; 3],
        /// Radius (m).
        #[serde(default = "d_radius")]
        radius_m: f64,
        /// Horizontal speed (m/s).
        #[serde(default = "d_speed")]
        speed_m_s: f64,
        /// Depth rate, positive descending (m/s).
        #[serde(default = "d_depth_rate")]
        depth_rate_m_s: f64,
    },
}

impl ReferenceSpec {
    /// The name of the kind.
    pub fn kind(&self) -> &'static str {
        match self {
            ReferenceSpec::Paper { .. } => "paper",
            ReferenceSpec::Hold { .. } => "hold",
            ReferenceSpec::Line { .. } => "line",
            ReferenceSpec::Circle { .. } => "circle",
            ReferenceSpec::Lawnmower { .. } => "lawnmower",
            ReferenceSpec::Helix { .. } => "helix",
        }
    }

    /// The core's reference, checked by the core's own [`Reference::validate`]: the one check
    /// of what the core refuses (a line's speed must be > 0, as on the vehicle). Its refusal
    /// names the scenario key (`reference.<field>`), the value given and the kind.
    pub fn validate(&self) -> Result<Reference> {
        let core = self.to_core();
        core.validate().map_err(|e| self.refusal(e))?;
        Ok(core)
    }

    /// The core's refusal `e` as the scenario's: the core names the field, this the key.
    fn refusal(&self, e: CoreError) -> anyhow::Error {
        let field = match e {
            CoreError::NonFinite(f)
            | CoreError::NotPositive(f)
            | CoreError::Negative(f)
            | CoreError::OutOfRange(f) => Some(f),
            // "non-physical parameters: .." does not read as a key's refusal: said as is below.
            _ => None,
        };
        let kind = self.kind();
        let given = field.and_then(|f| self.values().into_iter().find(|(k, _)| *k == f));
        let Some((_, given)) = given else {
            return anyhow!("reference (kind = {kind:?}) refused by the core: {e}");
        };
        let shown = match given.as_slice() {
            [v] => format!("{v}"),
            vs => format!(
                "[{}]",
                vs.iter().map(f64::to_string).collect::<Vec<_>>().join(", ")
            ),
        };
        // The vehicle computes in f32: a value finite or non-zero in f64 may not be in f32.
        let lost = given.iter().any(|&v| {
            let v32 = v as f32;
            (v.is_finite() && !v32.is_finite()) || (v != 0.0 && v32 == 0.0)
        });
        let note = if lost {
            " (the vehicle computes in f32: the value is beyond its range)"
        } else {
            ""
        };
        anyhow!("reference.{e} (got {shown}; kind = {kind:?}){note}")
    }

    /// Every field of the kind with its value(s), named as the core names them.
    fn values(&self) -> Vec<(&'static str, Vec<f64>)> {
        match *self {
            ReferenceSpec::Paper { h_r_m, t_f_s } => {
                vec![("h_r_m", vec![h_r_m]), ("t_f_s", vec![t_f_s])]
            }
            ReferenceSpec::Hold { pos_m } => vec![("pos_m", pos_m.to_vec())],
            ReferenceSpec::Line {
                start_m,
                heading_rad,
                speed_m_s,
            } => vec![
                ("start_m", start_m.to_vec()),
                ("heading_rad", vec![heading_rad]),
                ("speed_m_s", vec![speed_m_s]),
            ],
            ReferenceSpec::Circle {
                center_m,
                radius_m,
                speed_m_s,
            } => vec![
                ("center_m", center_m.to_vec()),
                ("radius_m", vec![radius_m]),
                ("speed_m_s", vec![speed_m_s]),
            ],
            ReferenceSpec::Lawnmower {
                start_m,
                heading_rad,
                leg_length_m,
                spacing_m,
                legs,
                speed_m_s,
            } => vec![
                ("start_m", start_m.to_vec()),
                ("heading_rad", vec![heading_rad]),
                ("leg_length_m", vec![leg_length_m]),
                ("spacing_m", vec![spacing_m]),
                ("legs", vec![f64::from(legs)]),
                ("speed_m_s", vec![speed_m_s]),
            ],
            ReferenceSpec::Helix {
                center_m,
                radius_m,
                speed_m_s,
                depth_rate_m_s,
            } => vec![
                ("center_m", center_m.to_vec()),
                ("radius_m", vec![radius_m]),
                ("speed_m_s", vec![speed_m_s]),
                ("depth_rate_m_s", vec![depth_rate_m_s]),
            ],
        }
    }

    /// The core's reference (f32).
    pub fn to_core(&self) -> Reference {
        let v3 = |a: [f64; 3]| [a[0] as f32, a[1] as f32, a[2] as f32];
        match *self {
            ReferenceSpec::Paper { h_r_m, t_f_s } => Reference::Paper(PaperPolynomial {
                h_r_m: h_r_m as f32,
                t_f_s: t_f_s as f32,
            }),
            ReferenceSpec::Hold { pos_m } => Reference::Hold { pos_m: v3(pos_m) },
            ReferenceSpec::Line {
                start_m,
                heading_rad,
                speed_m_s,
            } => Reference::Line {
                start_m: v3(start_m),
                heading_rad: heading_rad as f32,
                speed_m_s: speed_m_s as f32,
            },
            ReferenceSpec::Circle {
                center_m,
                radius_m,
                speed_m_s,
            } => Reference::Circle {
                center_m: v3(center_m),
                radius_m: radius_m as f32,
                speed_m_s: speed_m_s as f32,
            },
            ReferenceSpec::Lawnmower {
                start_m,
                heading_rad,
                leg_length_m,
                spacing_m,
                legs,
                speed_m_s,
            } => Reference::Lawnmower {
                start_m: v3(start_m),
                heading_rad: heading_rad as f32,
                leg_length_m: leg_length_m as f32,
                spacing_m: spacing_m as f32,
                legs,
                speed_m_s: speed_m_s as f32,
            },
            ReferenceSpec::Helix {
                center_m,
                radius_m,
                speed_m_s,
                depth_rate_m_s,
            } => Reference::Helix {
                center_m: v3(center_m),
                radius_m: radius_m as f32,
                speed_m_s: speed_m_s as f32,
                depth_rate_m_s: depth_rate_m_s as f32,
            },
        }
    }
}
