//! Link script set-up for the MCU build only: copy the workspace's `memory.x` (STM32F405,
//! the part QEMU's `netduinoplus2` emulates) into `OUT_DIR` and link the binary with
//! cortex-m-rt's `link.x`. The host build needs neither.
use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../memory.x");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let memory = manifest.join("..").join("memory.x");
    if let Err(e) = fs::copy(&memory, out.join("memory.x")) {
        println!("cargo:warning=cannot copy {}: {e}", memory.display());
        std::process::exit(1);
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
}
