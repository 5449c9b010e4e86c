//! The command line's limits (issue 23): inputs a script can give are refused before any work
//! starts, with exit code 2 and a reason, and nothing is written outside the output folder.
//! These run the built binary.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh, empty folder under the system's temporary folder.
fn scratch(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("host-sim-cli-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Run the binary in `cwd` with `args`.
fn host_sim(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .current_dir(cwd)
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A short 3-D line scenario with `name`, and `extra` TOML appended.
fn scenario_file(dir: &Path, file: &str, name: &str, extra: &str) -> PathBuf {
    let p = dir.join(file);
    std::fs::write(
        &p,
        format!(
            "name = {name:?}\nplane = \"3d\"\ncontroller = \"tracking\"\nduration_s = 2.0\n\
             [reference]\nkind = \"line\"\nstart_m = [0.0, 0.0, 2.0]\nspeed_m_s = 0.3\n\
             [initial]\nz_m = 2.0\n{extra}"
        ),
    )
    .unwrap();
    p
}

#[test]
fn a_scenario_named_dot_dot_is_refused_and_writes_nothing() {
    let dir = scratch("dotdot");
    let work = dir.join("work");
    std::fs::create_dir_all(&work).unwrap();
    for name in ["..", ".", ".hidden"] {
        let f = scenario_file(&dir, "s.toml", name, "");
        let o = host_sim(&work, &["run", f.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "name {name:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("name"), "{}", stderr(&o));
        assert!(
            !work.join("summary.json").exists(),
            "wrote into the working folder"
        );
        assert!(
            !work.join("out").exists(),
            "created the output folder: {name:?}"
        );
    }
}
