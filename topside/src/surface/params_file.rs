//! The surface's parameter file: the settings saved as JSON (the project's names only) and
//! restored at the next start, checked as a `PARAM_SET` is.

use super::params::surface::SurfaceSettings;
use super::params::{find, read_only, saved, Settings, GROUPS};
use anyhow::{anyhow, bail, Context, Result};
use std::collections::BTreeMap;
use std::path::Path;

/// The settings as a name -> value map (the saved file: the project's names only).
pub fn to_map(s: &Settings) -> BTreeMap<String, f32> {
    saved().map(|p| (p.name.to_string(), (p.get)(s))).collect()
}

/// Save the settings as JSON.
pub fn save(path: &Path, g: &Settings) -> Result<()> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)?;
        }
    }
    let text = serde_json::to_string_pretty(&to_map(g))? + "\n";
    std::fs::write(path, text).with_context(|| format!("write {}", path.display()))
}

/// The system id saved as `SYSID_THISMAV` (none when there is no file, no such entry or it
/// is not 1-255): read before the ground stations open, whatever else the file holds.
pub fn saved_system_id(path: &Path) -> Option<u8> {
    let text = std::fs::read_to_string(path).ok()?;
    let map: BTreeMap<String, f32> = serde_json::from_str(&text).ok()?;
    let sysid_thismav = *map.get("SYSID_THISMAV")?;
    SurfaceSettings {
        sysid_thismav,
        ..SurfaceSettings::default()
    }
    .system_id()
}

/// Load saved values over `defaults`; an unknown name, a non-finite value or a set the
/// checks refuse is an error naming it.
pub fn load(path: &Path, defaults: Settings) -> Result<Settings> {
    let text = std::fs::read_to_string(path).with_context(|| format!("read {}", path.display()))?;
    let map: BTreeMap<String, f32> = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a JSON object of numbers", path.display()))?;
    let mut g = defaults;
    for (name, v) in map {
        let (_, p) =
            find(&name).ok_or_else(|| anyhow!("{}: unknown parameter {name}", path.display()))?;
        if !v.is_finite() {
            bail!("{}: {name} is not finite", path.display());
        }
        if read_only(&name).is_some() {
            // Shown, saved, never restored: the value in force stays.
            continue;
        }
        (p.set)(&mut g, v);
    }
    for group in GROUPS {
        g.check(group)
            .map_err(|e| anyhow!("{}: the saved values are refused: {e}", path.display()))?;
    }
    Ok(g)
}
