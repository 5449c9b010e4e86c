//! Vehicle files: a vehicle's description (mass, inertias, added masses, drag, thruster
//! positions and limits, the ESCs' pulse curve) as TOML, one key per field of
//! [`VehicleParams`]. The Observer's (`vehicles/observer.toml`) is the default and is built
//! into the binary; `host-sim run` takes another through the scenario key `vehicle`, and
//! `host-sim topside --vehicle FILE` sends one to the vehicle (`SetVehicle`).

use anyhow::{anyhow, Context, Result};
use controller_core::params::{Vehicle, VehicleParams};
use std::path::Path;

/// The Observer's vehicle file (the paper's Table I and the documented assumptions).
pub const OBSERVER_TOML: &str = include_str!("../../vehicles/observer.toml");

/// Parse a vehicle file's text, then check it as the firmware will: the core's validation
/// (finite, physical) and [`Vehicle::check_flyable`] (the laws stay safe on it).
pub fn parse(text: &str, origin: &str) -> Result<VehicleParams> {
    let p: VehicleParams = toml::from_str(text)
        .map_err(|e| anyhow!("vehicle {origin}: {}", e.to_string().trim_end()))?;
    check(&p).with_context(|| format!("vehicle {origin}"))?;
    Ok(p)
}

/// Read and check a vehicle file.
pub fn load(path: &Path) -> Result<VehicleParams> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read vehicle file {}", path.display()))?;
    parse(&text, &path.display().to_string())
}

/// The core's validation and the flyability check, as one error naming the field.
pub fn check(p: &VehicleParams) -> Result<Vehicle> {
    let v = p.validate().map_err(|e| anyhow!("{e}"))?;
    v.check_flyable()
        .map_err(|e| anyhow!("not safe to fly: {e}"))?;
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_observer_file_is_the_observer() {
        assert_eq!(
            parse(OBSERVER_TOML, "observer.toml").unwrap(),
            VehicleParams::OBSERVER
        );
    }

    #[test]
    fn a_bad_file_names_the_field() {
        let heavy_float =
            OBSERVER_TOML.replace("buoyancy_offset_n = 0.0", "buoyancy_offset_n = 9.0");
        let e = format!("{:#}", parse(&heavy_float, "f").unwrap_err());
        assert!(e.contains("buoyancy_offset_n"), "{e}");
        let negative = OBSERVER_TOML.replace("mass_kg = 10.84", "mass_kg = -1.0");
        let e = format!("{:#}", parse(&negative, "f").unwrap_err());
        assert!(e.contains("mass_kg must be > 0"), "{e}");
        let unknown = format!("{OBSERVER_TOML}\nmass_lb = 3.0\n");
        assert!(parse(&unknown, "f").is_err());
        let pulse = OBSERVER_TOML.replace("deadband_us = 25.0", "deadband_us = 450.0");
        let e = format!("{:#}", parse(&pulse, "f").unwrap_err());
        assert!(e.contains("pulse"), "{e}");
    }
}
