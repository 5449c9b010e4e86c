//! Sway from the manoeuvre's turns: `m22`, `Y_v`, `Y_vv` fitted from the sway velocity
//! (the CSV's plant `v` with the DVL's noise, or the DVL's reports in the tether log)
//! against the truth, on both simulated vehicles.

use super::*;
use identify::sway::{Sway, SwayModel, SWAY_NAMES};

/// The truth's sway values in `SWAY_NAMES`' order.
pub(super) fn sway_truth(t: &VehicleParams) -> [f64; 3] {
    [
        f64::from(t.mass_kg - t.y_vdot_kg),
        f64::from(t.y_v),
        f64::from(t.y_vv),
    ]
}

/// Print the sway model against the truth; the errors (%) and whether each interval holds it.
pub(super) fn report_sway(tag: &str, s: &SwayModel, truth: &[f64; 3]) -> ([f64; 3], [bool; 3]) {
    let v = s.values();
    let err: [f64; 3] = std::array::from_fn(|i| (v[i] / truth[i] - 1.0) * 100.0);
    let inside: [bool; 3] = std::array::from_fn(|i| (s.lo[i]..=s.hi[i]).contains(&truth[i]));
    for i in 0..3 {
        eprintln!(
            "{tag}: {:<18} {:>9.4} [{:.4}, {:.4}] truth {:.4} {}: {:+.1} % {}",
            SWAY_NAMES[i].0,
            v[i],
            s.lo[i],
            s.hi[i],
            truth[i],
            SWAY_NAMES[i].1,
            err[i],
            if inside[i] { "in" } else { "OUT" }
        );
    }
    eprintln!("{tag}: m z_g {:.4} kg m", s.m_zg_kg_m);
    eprintln!(
        "{tag}: sway held-out RMS {:.4} m/s (the prior's ratios {:.4})",
        s.held_out_rms_m_s, s.ratios_held_out_rms_m_s
    );
    (err, inside)
}

pub(super) fn fitted(tag: &str, out: &Outcome) -> SwayModel {
    match &out.sway {
        Sway::Fitted(s) => s.clone(),
        Sway::Prior { reason } => panic!("{tag}: sway not fitted: {reason}"),
    }
}

/// Both vehicles (seed 1, the CSV with the DVL's noise, weighed anchor): `m22` and `Y_vv`
/// within 10 % of the truth, their intervals holding it; the identified file carries them.
#[test]
fn sway_mass_and_drag_from_the_turns_within_10_percent() {
    for file in ["heavy-slow.toml", "light.toml"] {
        let truth = vehicle_file(file);
        let tag = format!("sway-{}-1", file.trim_end_matches(".toml"));
        let rec = fly(&truth, 1, &tag);
        let out = identify(&rec, &VehicleParams::OBSERVER, buoyancy_anchor(&truth)).unwrap();
        let s = fitted(&tag, &out);
        let (err, inside) = report_sway(&tag, &s, &sway_truth(&truth));
        assert_eq!(s.drags_not_determined, None, "{tag}");
        for i in [0, 2] {
            assert!(
                err[i].abs() <= 10.0,
                "{tag}: {} {:+.1} %",
                SWAY_NAMES[i].0,
                err[i]
            );
            assert!(inside[i], "{tag}: {} interval", SWAY_NAMES[i].0);
        }
        assert!(s.held_out_rms_m_s < s.ratios_held_out_rms_m_s);
        let m22_file = f64::from(out.params.mass_kg) - f64::from(out.params.y_vdot_kg);
        assert!(
            (m22_file / s.m22_kg - 1.0).abs() < 1e-5,
            "file's m22 {m22_file}"
        );
        assert!((f64::from(out.params.y_vv) / s.y_vv - 1.0).abs() < 1e-5);
    }
}

/// A record without the turns (the yaw rate and the sway it drives removed) keeps the
/// prior's ratios and says why.
#[test]
fn a_record_without_turns_keeps_the_prior_ratios_and_says_why() {
    let truth = vehicle_file("heavy-slow.toml");
    let mut rec = fly(&truth, 2, "sway-no-turns");
    for s in &mut rec.samples {
        s.vel_m_s[1] *= 0.01;
    }
    let out = identify(&rec, &VehicleParams::OBSERVER, buoyancy_anchor(&truth)).unwrap();
    match &out.sway {
        Sway::Prior { reason } => {
            eprintln!("no turns: {reason}");
            assert!(reason.contains("sway"), "{reason}");
        }
        Sway::Fitted(s) => panic!("fitted without turns: {:?}", s.values()),
    }
}
