//! Running the built `host-sim` binary from a test, as a script would (the exit-code and
//! limit tests).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty folder `host-sim-<kind>-<tag>-<pid>` under the system's temporary folder.
pub fn scratch(kind: &str, tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("host-sim-{kind}-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run the binary in `cwd` with `args`.
pub fn host_sim(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .current_dir(cwd)
        .args(args)
        .output()
        .unwrap()
}
