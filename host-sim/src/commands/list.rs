//! `host-sim list`: the built-in scenarios, one line each.

use sim_scenario::{Scenario, BUILT_IN};

/// Run `host-sim list` (a built-in that does not load is listed with its reason).
pub fn main() {
    for b in BUILT_IN {
        match Scenario::load(b.name) {
            Ok(s) => println!(
                "{:<22} {:<3} {:<9} {:>7.0} s  {}",
                b.name,
                s.plane.as_str(),
                s.controller.as_str(),
                s.duration_s,
                s.description
            ),
            Err(e) => println!("{:<22} (invalid: {e:#})", b.name),
        }
    }
}
