//! `scripts/modcycles.py` fails when it finds what it looks for: a circle of top-level
//! modules or of files within a crate prints a `CYCLE` line and exits 1; the workspace has
//! none. Skipped without python3.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// The script run in `cwd` (both levels), or `None` (SKIPPED) without python3.
fn modcycles(cwd: &Path) -> Option<Output> {
    let script = workspace().join("scripts/modcycles.py");
    match Command::new("python3")
        .arg(script)
        .current_dir(cwd)
        .output()
    {
        Ok(o) => Some(o),
        Err(e) => {
            eprintln!("SKIPPED: python3 not runnable ({e})");
            None
        }
    }
}

#[test]
fn the_workspace_has_no_module_circle() {
    let Some(o) = modcycles(&workspace()) else {
        return;
    };
    let out = String::from_utf8_lossy(&o.stdout);
    let found: Vec<&str> = out.lines().filter(|l| l.contains("CYCLE")).collect();
    assert!(found.is_empty(), "circles: {found:?}\n{out}");
    assert_eq!(o.status.code(), Some(0), "{out}");
}

#[test]
fn a_circle_of_three_modules_is_found_and_fails_the_check() {
    let dir = std::env::temp_dir().join(format!("modcycles-{}", std::process::id()));
    let src = dir.join("host-sim/src");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&src).unwrap();
    std::fs::write(
        dir.join("Cargo.toml"),
        "[workspace]\nmembers = [\"host-sim\"]\n",
    )
    .unwrap();
    std::fs::write(src.join("a.rs"), "use crate::b::B;\n").unwrap();
    std::fs::write(src.join("b.rs"), "use crate::{c::C, d};\n").unwrap();
    std::fs::write(src.join("c.rs"), "pub use crate::a::A;\n").unwrap();
    // A doc link and a test module are not uses.
    std::fs::write(
        src.join("d.rs"),
        "/// See [`crate::b::B`].\n#[cfg(test)]\nmod tests {\n    use crate::b::B;\n}\n",
    )
    .unwrap();
    let Some(o) = modcycles(&dir) else {
        return;
    };
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("host-sim/src CYCLE a -> b -> c -> a"), "{out}");
    assert!(!out.contains(" d"), "{out}");
    assert_eq!(o.status.code(), Some(1), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_that_uses_its_parent_which_uses_it_is_a_circle() {
    let dir = std::env::temp_dir().join(format!("modcycles-files-{}", std::process::id()));
    let src = dir.join("host-sim/src");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(src.join("t")).unwrap();
    std::fs::write(
        dir.join("Cargo.toml"),
        "[workspace]\nmembers = [\"host-sim\"]\n",
    )
    .unwrap();
    std::fs::write(src.join("lib.rs"), "mod t;\nmod u;\nmod v;\n").unwrap();
    // Grouped paths count: v/mod.rs re-exports `w::{W}`, and w uses `super::{V}`.
    std::fs::create_dir_all(src.join("v")).unwrap();
    std::fs::write(
        src.join("v/mod.rs"),
        "mod w;\npub use w::{W};\npub struct V;\n",
    )
    .unwrap();
    std::fs::write(src.join("v/w.rs"), "use super::{V};\npub struct W;\n").unwrap();
    // t/mod.rs calls its child x, and x uses an item of t: a circle of two files.
    std::fs::write(
        src.join("t/mod.rs"),
        "mod x;\nmod y;\npub struct S;\npub fn f() { x::g(); }\n",
    )
    .unwrap();
    std::fs::write(src.join("t/x.rs"), "use super::S;\npub fn g() {}\n").unwrap();
    // y uses its sibling through super: not a use of the parent file.
    std::fs::write(src.join("t/y.rs"), "use super::x::g;\n").unwrap();
    std::fs::write(src.join("u.rs"), "use crate::t::f;\n").unwrap();
    let Some(o) = modcycles(&dir) else {
        return;
    };
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("host-sim/src CYCLE (files) t -> t::x -> t"),
        "{out}"
    );
    assert!(
        out.contains("host-sim/src CYCLE (files) v -> v::w -> v"),
        "{out}"
    );
    assert!(!out.contains("t::y"), "{out}");
    assert!(!out.contains(" u"), "{out}");
    assert_eq!(o.status.code(), Some(1), "{out}");
    let _ = std::fs::remove_dir_all(&dir);
}
