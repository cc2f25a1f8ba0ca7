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
    // What the host computes, for the target to reproduce (bit for bit, or
    // within the accuracy asked of f32 against the f64 reference).
    fs::write(out.join("host_digests.rs"), host_reference()).expect("write host_digests.rs");
    if env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        for script in ["-Tlink.x", "-Tdefmt.x", "-Tembedded-test.x"] {
            println!("cargo:rustc-link-arg-tests={script}");
        }
    }
}

/// The host's reference values, as Rust source for `include!`.
fn host_reference() -> String {
    use calib_core::conformance::{heading_digest_f32, tumble_sample, SplitMix64, TUMBLE_FIELD_NT};
    use calib_core::fit::{fit_batch, Full};
    let mut rng = SplitMix64::new(TUMBLE_SEED);
    let samples: Vec<[f64; 3]> = (0..TUMBLE_SAMPLES).map(|_| tumble_sample(&mut rng)).collect();
    let full = fit_batch::<Full, 9, f64>(&samples, TUMBLE_FIELD_NT).expect("host batch fit of the tumble");
    format!(
        "/// `heading_digest_f32()` on the build host.\n\
         pub const HEADING_DIGEST_F32: u32 = {:#010x};\n\
         /// Seed and length of the tumble workload.\n\
         pub const TUMBLE_SEED: u64 = {TUMBLE_SEED};\n\
         pub const TUMBLE_SAMPLES: usize = {TUMBLE_SAMPLES};\n\
         /// Host f64 batch full-ellipsoid fit of that workload.\n\
         pub const HOST_FULL_BIAS: [f64; 3] = {:?};\n\
         pub const HOST_FULL_MATRIX: [[f64; 3]; 3] = {:?};\n",
        heading_digest_f32(),
        full.bias,
        full.matrix
    )
}

const TUMBLE_SEED: u64 = 2024;
const TUMBLE_SAMPLES: usize = 2400;
