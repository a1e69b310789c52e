//! Link setup for the `uno-r4` board binary; does nothing for host builds.
//!
//! With feature `board-uno-r4` on an ARM target: copies the workspace's `memory.x` (the RA4M1
//! map that keeps the Arduino bootloader) into OUT_DIR for cortex-m-rt's `link.x`, and passes
//! the linker scripts to the binaries only (`-Tlink.x`, `-Tdefmt.x`), so libraries built for
//! thumbv7em (geometry, protocol) are untouched. The on-target test binaries (`tests/board*.rs`)
//! get the same scripts and embedded-test's `embedded-test.x`.

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    // embedded-test's `#[tests]` expands to a `cfg(rust_analyzer)` check.
    println!("cargo::rustc-check-cfg=cfg(rust_analyzer)");
    let board = env::var_os("CARGO_FEATURE_BOARD_UNO_R4").is_some();
    let target = env::var("TARGET").unwrap_or_default();
    if !board || !target.starts_with("thumbv7em-") {
        return;
    }
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let memory_x = manifest.join("../../memory.x");
    println!("cargo:rerun-if-changed={}", memory_x.display());
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets it"));
    fs::copy(&memory_x, out.join("memory.x")).expect("memory.x at the workspace root");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    // Identical code folding: the linker keeps one copy of functions LTO left byte-identical
    // (`__aeabi_memcpy4`/`8`, `__aeabi_memclr4`/`8`, the panic entry stubs, outlined
    // sequences): 380 B of the board binary. Nothing in it compares function addresses.
    println!("cargo:rustc-link-arg-bins=--icf=all");
    // The on-target test binaries (tests/board*.rs, embedded-test): the same scripts, plus
    // embedded-test's, which keeps the test-case symbols probe-rs and ra4m1-run read.
    println!("cargo:rustc-link-arg-tests=--nmagic");
    println!("cargo:rustc-link-arg-tests=-Tlink.x");
    println!("cargo:rustc-link-arg-tests=-Tdefmt.x");
    println!("cargo:rustc-link-arg-tests=-Tembedded-test.x");
}
