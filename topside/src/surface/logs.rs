//! The topside's log files: each start writes new ones with time-stamped names and never
//! truncates an existing file. `--tlog out/dive.tlog` becomes
//! `out/dive-20261126-101500.tlog` (UTC) and the tether log beside it
//! `out/dive-20261126-101500.tether`; a second start within the same second adds `-2`,
//! `-3`, ... Both files are created with `create_new`, so an existing one is never opened.

use anyhow::{bail, Context, Result};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

/// `YYYYMMDD-HHMMSS` of a UNIX time in seconds (UTC; the civil calendar from days, Howard
/// Hinnant's algorithm).
pub fn utc_stamp(unix_s: u64) -> String {
    let days = (unix_s / 86_400) as i64;
    let secs = unix_s % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}{month:02}{day:02}-{:02}{:02}{:02}",
        secs / 3600,
        secs / 60 % 60,
        secs % 60
    )
}

/// `path` with `-STAMP` (and `-N` for the N-th try) inserted before its extension, and
/// `ext` as the extension.
fn stamped(path: &Path, stamp: &str, n: u32, ext: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(|| "topside".into(), |s| s.to_string_lossy().to_string());
    let name = if n <= 1 {
        format!("{stem}-{stamp}.{ext}")
    } else {
        format!("{stem}-{stamp}-{n}.{ext}")
    };
    path.with_file_name(name)
}

fn create_new(path: &Path) -> std::io::Result<File> {
    OpenOptions::new().write(true).create_new(true).open(path)
}

/// The logs of this start: the open `.tlog`, its path, and the tether log's path (created
/// empty, so that no other start takes it; `tether_log::LoggedPort` writes it).
pub fn open_logs(tlog: &Path, tether: Option<&Path>) -> Result<(File, PathBuf, PathBuf)> {
    for p in [Some(tlog), tether].into_iter().flatten() {
        if let Some(dir) = p.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("create {}", dir.display()))?;
        }
    }
    let unix_s = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let stamp = utc_stamp(unix_s);
    let ext = tlog
        .extension()
        .map_or_else(|| "tlog".into(), |e| e.to_string_lossy().to_string());
    for n in 1..=1000 {
        let t = stamped(tlog, &stamp, n, &ext);
        let r = match tether {
            Some(p) => stamped(p, &stamp, n, "tether"),
            None => stamped(tlog, &stamp, n, "tether"),
        };
        let file = match create_new(&t) {
            Ok(f) => f,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e).with_context(|| format!("create {}", t.display())),
        };
        match create_new(&r) {
            Ok(_) => return Ok((file, t, r)),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                // Ours, empty: give the name back and try the next.
                drop(file);
                let _ = std::fs::remove_file(&t);
            }
            Err(e) => return Err(e).with_context(|| format!("create {}", r.display())),
        }
    }
    bail!("no free log name beside {} in 1,000 tries", tlog.display())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_are_utc_calendar_times() {
        assert_eq!(utc_stamp(0), "19700101-000000");
        // 2026-11-26 10:15:00 UTC.
        assert_eq!(utc_stamp(1_795_688_100), "20261126-101500");
        // A leap day.
        assert_eq!(utc_stamp(951_782_400 + 3_661), "20000229-010101");
    }

    #[test]
    fn two_starts_in_one_second_get_two_names_and_nothing_is_truncated() {
        let dir = std::env::temp_dir().join(format!("rov-logs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let tlog = dir.join("dive.tlog");
        let (mut f1, t1, r1) = open_logs(&tlog, None).unwrap();
        use std::io::Write;
        f1.write_all(b"first").unwrap();
        let (_, t2, r2) = open_logs(&tlog, None).unwrap();
        assert_ne!(t1, t2);
        assert_ne!(r1, r2);
        assert_eq!(std::fs::read(&t1).unwrap(), b"first");
        assert!(
            t1.to_string_lossy().ends_with(".tlog") && r1.to_string_lossy().ends_with(".tether")
        );
        let _ = std::fs::remove_dir_all(dir);
    }
}
