//! Linker set-up for the MCU build only: the memory map and the link scripts of the
//! binaries (cortex-m-rt's `link.x`, defmt's `defmt.x`). The host build (tests) needs none.
//!
//! The memory map is the workspace's `memory.x` (STM32F405, also QEMU `netduinoplus2`) for
//! every binary: the linker finds it in its working directory (the workspace root) before
//! any search path, and `OUT_DIR` has a copy too. The node's image, with its own budget
//! (`memory-node.x`), is the `node-firmware` crate's.
use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../memory.x");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let from = manifest.join("..").join("memory.x");
    if let Err(e) = fs::copy(&from, out.join("memory.x")) {
        println!("cargo:warning=cannot copy {}: {e}", from.display());
        std::process::exit(1);
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
