//! The gains' ranges: a gain that makes a law bang-bang at its control period, or that
//! switches a law off, is refused, and the refusal names the range.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use controller_core::controller::Gains;
use controller_core::law::tracking::TrackingGains;

type Setter = fn(&mut TrackingGains, f32);

fn velocity_gains() -> [(&'static str, Setter); 2] {
    [
        ("xy_kd", |g, v| g.xy_kd = v),
        ("depth_kd", |g, v| g.depth_kd = v),
    ]
}

#[test]
fn a_velocity_gain_of_999_or_1e_30_is_refused_naming_its_range() {
    for (name, set) in velocity_gains() {
        for v in [999.0, 1.0e-30] {
            let mut g = Gains::default();
            set(&mut g.tracking, v);
            let e = g.validate().expect_err(name);
            let text = e.to_string();
            assert!(text.contains(name), "{name} = {v}: {text}");
            assert!(text.contains("..="), "{name} = {v}: the range in {text}");
        }
    }
}
