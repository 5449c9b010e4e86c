//! The long runs (minutes each on 2 cores: the emulated-board runs in QEMU, and the in-process
//! firmware's longest flights) run where `ROV_LONG` is set; elsewhere each prints a `SKIPPED`
//! line that says how to run it, so that the README's `cargo test --workspace` stays a few
//! minutes. Two tiers, so that CI stays within its half hour: `ROV_LONG=1` (CI, `.ci/run`)
//! runs the long tests of up to [`CI_WALL_S`] each; `ROV_LONG=all` runs every one (the
//! whole-scenario QEMU flights of two to four minutes each: before a release, or after a
//! change to the firmware's navigation). The quick emulated-board tests (the firmware's link
//! failsafes, the estimator on the board over a short run, the topside layout's cut node
//! link) run everywhere.

// Each test binary that includes this module uses part of it.
#![allow(dead_code)]

use std::io::Write;

/// The longest long test CI runs (s of wall time on 2 cores); longer ones need `ROV_LONG=all`.
pub const CI_WALL_S: u32 = 100;

/// `ROV_LONG` is set (to anything but `0`): the long emulated runs are wanted.
pub fn long_runs_wanted() -> bool {
    std::env::var_os("ROV_LONG").is_some_and(|v| v != "0")
}

/// Whether the long test `name` of the test module `module` (about `wall_s` of wall time on
/// 2 cores) runs here: with `ROV_LONG=all` it does, with another `ROV_LONG` when `wall_s` is
/// at most [`CI_WALL_S`]; otherwise it writes `SKIPPED <name> (long test, ~N s; run with
/// ROV_LONG=... cargo test -p host-sim --test it <module>::<name>)` straight to the terminal
/// (not captured by the test harness) and does not.
pub fn long_test(module: &str, name: &str, wall_s: u32) -> bool {
    long_test_of("it", &format!("{module}::{name}"), wall_s)
}

/// A long test that runs only with `ROV_LONG=all`, whatever its length: a second draw of a
/// comparison CI already flies once (CI's half hour has no room for both).
pub fn long_test_all(module: &str, name: &str, wall_s: u32) -> bool {
    if std::env::var_os("ROV_LONG").is_some_and(|v| v == "all") {
        return true;
    }
    skipped("it", &format!("{module}::{name}"), wall_s, "all");
    false
}

/// [`long_test`] for a test of another test binary of host-sim (`binary`), `path` its name
/// in that binary.
pub fn long_test_of(binary: &str, path: &str, wall_s: u32) -> bool {
    let all = std::env::var_os("ROV_LONG").is_some_and(|v| v == "all");
    if all || (long_runs_wanted() && wall_s <= CI_WALL_S) {
        return true;
    }
    let tier = if wall_s <= CI_WALL_S { "1" } else { "all" };
    skipped(binary, path, wall_s, tier);
    false
}

/// The `SKIPPED` line of the long test `path` of `binary`, with the `ROV_LONG` `tier` that
/// runs it, written to the stream itself (the harness captures only `print!` / `eprint!`).
fn skipped(binary: &str, path: &str, wall_s: u32, tier: &str) {
    let name = path.rsplit("::").next().unwrap_or(path);
    let _ = writeln!(
        std::io::stderr(),
        "SKIPPED {name} (long test, ~{wall_s} s on 2 cores; run with ROV_LONG={tier} cargo test \
         -p host-sim --test {binary} {path})"
    );
}

/// The number of draws of the statistical campaign `name` (a Monte Carlo, a sweep) of the
/// test module `module`: `full` where `ROV_LONG` is set (CI), otherwise `quick`, said on the
/// terminal. The quick campaign asserts the same bounds on its first `quick` draws (the
/// same seeds), so it fails where the full one would on those; the full campaign, which
/// holds the figure in docs/results.md, runs in CI.
pub fn campaign_runs(module: &str, name: &str, full: usize, quick: usize) -> usize {
    if long_runs_wanted() {
        return full;
    }
    let _ = writeln!(
        std::io::stderr(),
        "QUICK {name}: {quick} of its {full} draws (all of them: ROV_LONG=1 cargo test -p \
         host-sim --test it {module}::{name})"
    );
    quick
}
