//! Puts the top-level `memory.x` on the linker's search path and, for the
//! Cortex-M target only, passes cortex-m-rt's and defmt's linker scripts.
//! Doing this here (not through RUSTFLAGS) keeps host builds of the library
//! untouched and survives a RUSTFLAGS set in the environment.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory_x = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../memory.x");
    fs::copy(&memory_x, out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
        println!("cargo:rustc-link-arg-bins=--nmagic");
    }
}
