//! Linker setup for the on-target tests (memory.x, cortex-m-rt, defmt,
//! embedded-test), for the Cortex-M target only.
use std::{env, fs, path::PathBuf};

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let memory_x = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../memory.x");
    fs::copy(&memory_x, out.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo::rustc-check-cfg=cfg(rust_analyzer)");
    // What the host computes, for the target to reproduce bit for bit.
    fs::write(
        out.join("host_digests.rs"),
        format!(
            "/// `calib_core::conformance::heading_digest_f32()` computed on the build host.\n\
             pub const HEADING_DIGEST_F32: u32 = {:#010x};\n",
            calib_core::conformance::heading_digest_f32()
        ),
    )
    .expect("write host_digests.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        for script in ["-Tlink.x", "-Tdefmt.x", "-Tembedded-test.x"] {
            println!("cargo:rustc-link-arg-tests={script}");
        }
    }
}
