//! The identified model as a vehicle file (`vehicles/observer.toml`'s format): the prior's
//! values where the fit says nothing (dry mass, rigid inertias, pitch, the pulse curve),
//! the identified sums written as added masses (`X_udot = m - m_11`), drags and net
//! buoyancy, the thrust limits scaled, sway scaled from surge (the prior's ratios), each
//! with its interval in a comment.

use super::physical::{Anchor, Identified, MODEL_NAMES};
use super::regression::Z_95;
use super::sway::{Sway, SwayModel, SWAY_NAMES};
use controller_core::params::VehicleParams;

/// Relative uncertainty stated for the sway terms taken from the prior's ratios (no sway
/// thruster: the record does not measure them).
pub const SWAY_PRIOR_REL_UNCERTAINTY: f64 = 0.5;

/// The identified vehicle's parameters; sway from `sway` when the turns determined it, else
/// the prior's ratios to the identified surge.
pub fn identified_params(
    id: &Identified,
    prior: &VehicleParams,
    sway: Option<&SwayModel>,
) -> VehicleParams {
    let m = &id.model;
    let mut p = *prior;
    let f = |v: f64| v as f32;
    let p_m11 = f64::from(prior.mass_kg - prior.x_udot_kg);
    let p_m22 = f64::from(prior.mass_kg - prior.y_vdot_kg);
    let mass = f64::from(prior.mass_kg);
    p.x_udot_kg = f(mass - m.m11_kg);
    p.z_wdot_kg = f(mass - m.mz_kg);
    p.n_rdot_kg_m2 = f(f64::from(prior.i_z_kg_m2) - m.m33_kg_m2);
    // Sway: the prior's m22/m11 and drag ratios carried over to the identified surge.
    let m22 = m.m11_kg * p_m22 / p_m11;
    p.y_vdot_kg = f(mass - m22);
    let ratio = |num: f32, den: f32, v: f64| {
        if den > 0.0 {
            v * f64::from(num) / f64::from(den)
        } else {
            f64::from(num)
        }
    };
    p.y_v = f(ratio(prior.y_v, prior.x_u, m.x_u).max(0.0));
    p.y_vv = f(ratio(prior.y_vv, prior.x_uu, m.x_uu).max(0.0));
    if let Some(s) = sway {
        p.y_vdot_kg = f(mass - s.m22_kg);
        if s.drags_not_determined.is_none() {
            p.y_v = f(s.y_v.max(0.0));
            p.y_vv = f(s.y_vv.max(0.0));
        }
    }
    // Drags are magnitudes: a slightly negative estimate (noise about zero) is written 0.
    p.x_u = f(m.x_u.max(0.0));
    p.x_uu = f(m.x_uu.max(0.0));
    p.n_r = f(m.n_r.max(0.0));
    p.n_rr = f(m.n_rr.max(0.0));
    p.z_w = f(m.z_w.max(0.0));
    p.z_ww = f(m.z_ww.max(0.0));
    p.buoyancy_offset_n = f(m.net_buoyancy_n);
    if id.thruster_time_constant_s.is_finite() {
        p.thruster_time_constant_s = f(id.thruster_time_constant_s);
    }
    p.thrust_max_forward_n = f(f64::from(prior.thrust_max_forward_n) * m.thrust_scale_ahead);
    p.thrust_max_reverse_n = f(f64::from(prior.thrust_max_reverse_n) * m.thrust_scale_astern);
    p
}

/// The vehicle file's text: a header with the fit's intervals, then every field.
pub fn to_toml(
    params: &VehicleParams,
    id: &Identified,
    sway: &Sway,
    source: &str,
) -> anyhow::Result<String> {
    let mut head = String::new();
    head.push_str(&format!(
        "# Identified by `host-sim identify` from {source} (docs/identification.md).\n\
         # The fitted sums and their 95 % intervals:\n"
    ));
    for (((name, unit), v), (lo, hi)) in MODEL_NAMES
        .iter()
        .zip(id.model.values())
        .zip(id.lo.iter().zip(id.hi.iter()))
    {
        head.push_str(&format!(
            "#   {name:<22} {v:>10.4} [{lo:.4}, {hi:.4}] {unit}\n"
        ));
    }
    head.push_str(&format!("# Force scale: {}.\n", anchor_text(id.anchor)));
    match sway {
        Sway::Fitted(s) => {
            head.push_str("# Sway, from the turns (the DVL's sway velocity):\n");
            for (((name, unit), v), (lo, hi)) in SWAY_NAMES
                .iter()
                .zip(s.values())
                .zip(s.lo.iter().zip(s.hi.iter()))
            {
                head.push_str(&format!(
                    "#   {name:<22} {v:>10.4} [{lo:.4}, {hi:.4}] {unit}\n"
                ));
            }
            if let Some(why) = &s.drags_not_determined {
                head.push_str(&format!(
                    "# y_v, y_vv: the prior's ratios to surge, +-{:.0} % ({why}).\n",
                    SWAY_PRIOR_REL_UNCERTAINTY * 100.0
                ));
            }
        }
        Sway::Prior { reason } => head.push_str(&format!(
            "# Sway (y_vdot_kg, y_v, y_vv): the prior's ratios to surge, +-{:.0} % (not \
             measured: {reason}).\n",
            SWAY_PRIOR_REL_UNCERTAINTY * 100.0
        )),
    }
    head.push_str(
        "# Dry mass, rigid inertias, pitch terms, lever arm and pulse curve: the prior's.\n\n",
    );
    let body = toml::to_string(params)?;
    Ok(head + &body)
}

/// What gave the force scale, in words.
pub fn anchor_text(a: Anchor) -> String {
    match a {
        Anchor::ThrustCurve { rel_std } if rel_std > 0.0 => format!(
            "the installed thrusters' curve ahead, +-{:.1} % (95 %)",
            rel_std * Z_95 * 100.0
        ),
        Anchor::ThrustCurve { .. } => {
            "the prior's thrust curve ahead, taken as exact (its error scales every force)"
                .to_string()
        }
        Anchor::NetBuoyancy { value_n, std_n } => {
            format!("the weighed net buoyancy {value_n} N (std {std_n} N)")
        }
        Anchor::Both {
            curve_rel_std,
            value_n,
            std_n,
        } => format!(
            "the installed thrusters' curve ahead (+-{:.1} %, 95 %) and the weighed net \
             buoyancy {value_n} N (std {std_n} N), combined by their variances",
            curve_rel_std * Z_95 * 100.0
        ),
    }
}
