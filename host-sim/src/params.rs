//! The ground station's parameter list (`PARAM_*`): every control-law gain, by a name of at
//! most 16 characters, read and written through the tether's `SetTrackingGains` /
//! `SetPaperGains` (the vehicle validates and refuses; nothing changes on a refusal), saved to
//! a JSON file after every accepted change and restored at the next start.
//!
//! Names: `TRK_*` the tracking laws ([`TrackingGains`]), `PXZ_*` / `PXY_*` the paper's XZ / XY
//! laws. The failsafe timeouts and the vehicle's description are not parameters yet (they are
//! compiled into the firmware; issue 13).

use anyhow::{anyhow, bail, Context, Result};
use controller_core::controller::Gains;
use std::collections::BTreeMap;
use std::path::Path;

/// One parameter: its name and how to read and write it in a gain set.
pub struct Param {
    /// MAVLink `param_id` (<= 16 characters).
    pub name: &'static str,
    /// Read it.
    pub get: fn(&Gains) -> f32,
    /// Write it.
    pub set: fn(&mut Gains, f32),
}

/// Which tether command carries a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Group {
    /// `SetTrackingGains`.
    Tracking,
    /// `SetPaperGains`.
    Paper,
}

macro_rules! params {
    ($($name:literal => $set:ident . $field:ident),* $(,)?) => {
        &[$(Param {
            name: $name,
            get: |g| g.$set.$field,
            set: |g, v| g.$set.$field = v,
        }),*]
    };
}

/// Every parameter, in the order of `PARAM_REQUEST_LIST`.
pub const PARAMS: &[Param] = params![
    "TRK_HAND_M" => tracking.hand_m,
    "TRK_XY_KP" => tracking.xy_kp,
    "TRK_XY_KD" => tracking.xy_kd,
    "TRK_XY_KI" => tracking.xy_ki,
    "TRK_XZ_KP" => tracking.xz_kp,
    "TRK_XZ_KD" => tracking.xz_kd,
    "TRK_XZ_KI" => tracking.xz_ki,
    "TRK_PITCH_KP" => tracking.pitch_kp,
    "TRK_PITCH_KD" => tracking.pitch_kd,
    "TRK_PITCH_MAX" => tracking.pitch_max_rad,
    "TRK_DEPTH_KP" => tracking.depth_kp,
    "TRK_DEPTH_KD" => tracking.depth_kd,
    "TRK_DEPTH_KI" => tracking.depth_ki,
    "TRK_YAW_KP" => tracking.yaw_kp,
    "TRK_YAW_KD" => tracking.yaw_kd,
    "TRK_ERR_LIM_M" => tracking.error_limit_m,
    "TRK_INT_LIM" => tracking.integral_limit_m_s2,
    "TRK_CUR_OBS" => tracking.current_observer_rad_s,
    "PXZ_K" => paper_xz.k,
    "PXZ_C1W" => paper_xz.c1w,
    "PXZ_C2W" => paper_xz.c2w,
    "PXZ_C1Q" => paper_xz.c1q,
    "PXZ_C2Q" => paper_xz.c2q,
    "PXZ_CQ" => paper_xz.cq,
    "PXZ_C1" => paper_xz.c1,
    "PXZ_C2" => paper_xz.c2,
    "PXY_K" => paper_xy.k,
    "PXY_C1U" => paper_xy.c1u,
    "PXY_C2U" => paper_xy.c2u,
    "PXY_C1R" => paper_xy.c1r,
    "PXY_C2R" => paper_xy.c2r,
    "PXY_CR" => paper_xy.cr,
    "PXY_C3" => paper_xy.c3,
    "PXY_C4" => paper_xy.c4,
];

/// A parameter by name, with its index.
pub fn find(name: &str) -> Option<(usize, &'static Param)> {
    PARAMS.iter().enumerate().find(|(_, p)| p.name == name)
}

/// The tether command group of a parameter.
pub fn group(p: &Param) -> Group {
    if p.name.starts_with("TRK_") {
        Group::Tracking
    } else {
        Group::Paper
    }
}

/// The gains as a name -> value map (the saved file).
pub fn to_map(g: &Gains) -> BTreeMap<String, f32> {
    PARAMS
        .iter()
        .map(|p| (p.name.to_string(), (p.get)(g)))
        .collect()
}

/// Save the gains as JSON.
pub fn save(path: &Path, g: &Gains) -> Result<()> {
    if let Some(dir) = path.parent() {
        if !dir.as_os_str().is_empty() {
            std::fs::create_dir_all(dir)?;
        }
    }
    let text = serde_json::to_string_pretty(&to_map(g))? + "\n";
    std::fs::write(path, text).with_context(|| format!("write {}", path.display()))
}

/// Load saved gains over the defaults; an unknown name, a non-finite value or a set the core
/// refuses is an error naming it.
pub fn load(path: &Path) -> Result<Gains> {
    let text = std::fs::read_to_string(path).with_context(|| format!("read {}", path.display()))?;
    let map: BTreeMap<String, f32> = serde_json::from_str(&text)
        .with_context(|| format!("{}: not a JSON object of numbers", path.display()))?;
    let mut g = Gains::default();
    for (name, v) in map {
        let (_, p) =
            find(&name).ok_or_else(|| anyhow!("{}: unknown parameter {name}", path.display()))?;
        if !v.is_finite() {
            bail!("{}: {name} is not finite", path.display());
        }
        (p.set)(&mut g, v);
    }
    g.validate()
        .map_err(|e| anyhow!("{}: the saved gains are refused: {e}", path.display()))?;
    Ok(g)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_fit_mavlink_and_are_unique() {
        for (i, p) in PARAMS.iter().enumerate() {
            assert!(p.name.len() <= 16, "{}", p.name);
            assert!(
                PARAMS[i + 1..].iter().all(|q| q.name != p.name),
                "{}",
                p.name
            );
        }
    }

    #[test]
    fn every_parameter_reads_back_what_was_written() {
        let mut g = Gains::default();
        for (i, p) in PARAMS.iter().enumerate() {
            (p.set)(&mut g, 100.0 + i as f32);
        }
        for (i, p) in PARAMS.iter().enumerate() {
            assert_eq!((p.get)(&g), 100.0 + i as f32, "{}", p.name);
        }
    }

    #[test]
    fn a_saved_file_loads_back_and_a_bad_one_is_refused_by_name() {
        let dir = std::env::temp_dir().join(format!("rov-params-{}", std::process::id()));
        let path = dir.join("p.json");
        let mut g = Gains::default();
        g.tracking.xy_kp *= 1.5;
        save(&path, &g).unwrap();
        assert_eq!(load(&path).unwrap(), g);
        std::fs::write(&path, r#"{"TRK_NOPE": 1.0}"#).unwrap();
        assert!(format!("{:#}", load(&path).unwrap_err()).contains("TRK_NOPE"));
        std::fs::write(&path, r#"{"TRK_XY_KP": -1.0}"#).unwrap();
        assert!(format!("{:#}", load(&path).unwrap_err()).contains("refused"));
        let _ = std::fs::remove_dir_all(dir);
    }
}
