//! Linker set-up for the MCU build only: copy the workspace's `memory.x` (STM32F405, also
//! QEMU `netduinoplus2`) into `OUT_DIR` and link the binaries with cortex-m-rt's `link.x`
//! and defmt's `defmt.x`. The host build (tests) needs none of it.
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
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
