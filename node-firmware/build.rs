//! Linker set-up for the MCU build only (as `firmware/build.rs`): cortex-m-rt's `link.x`,
//! defmt's `defmt.x`, and `memory-node.x`, which cuts the workspace's `memory.x`
//! (STM32F405, also QEMU `netduinoplus2`) to the node's budget (32 KiB flash, 8 KiB RAM,
//! the stack at the top of the 8 KiB) and fails the link when the image outgrows it.
use std::{env, fs, path::PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=../memory.x");
    println!("cargo:rerun-if-changed=../memory-node.x");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let out = PathBuf::from(env::var_os("OUT_DIR").unwrap_or_default());
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    for file in ["memory.x", "memory-node.x"] {
        let from = manifest.join("..").join(file);
        if let Err(e) = fs::copy(&from, out.join(file)) {
            println!("cargo:warning=cannot copy {}: {e}", from.display());
            std::process::exit(1);
        }
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // After link.x: its PROVIDE(_ram_end) is overridden by the budget's definition.
    println!("cargo:rustc-link-arg-bins=-Tmemory-node.x");
}
