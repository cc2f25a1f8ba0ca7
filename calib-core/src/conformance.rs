//! Fixed workloads whose `f32` result bits must be the same on every platform.
//!
//! calib-core promises the same numbers, bit for bit, on the Cortex-M4F and on
//! the host (pure-Rust `libm`, no fused multiply-add contraction, no platform
//! maths library). These digests make that promise testable: the on-target
//! suite computes them on the MCU under QEMU and compares them with the value
//! the host computed at build time.

use crate::heading::{level, magnetic_heading_rad, ned_field, ned_to_body};

/// FNV-1a over the bits of a sequence of `f32`s.
fn fnv1a(mut hash: u32, v: f32) -> u32 {
    for byte in v.to_bits().to_le_bytes() {
        hash ^= u32::from(byte);
        hash = hash.wrapping_mul(0x0100_0193);
    }
    hash
}

/// Digest of the body field, levelled channels and heading over a grid of
/// attitudes (roll ±60°, pitch ±30°, yaw all round) at the paper's site
/// (48 730 nT, dip 55.7°), computed in `f32`.
pub fn heading_digest_f32() -> u32 {
    let deg = core::f32::consts::PI / 180.0;
    let field = ned_field(48_730.0f32, 55.68 * deg, 0.0);
    let mut hash = 0x811c_9dc5;
    for r in -6i16..=6 {
        for p in -3i16..=3 {
            for y in 0i16..36 {
                let (roll, pitch, yaw) =
                    (f32::from(r) * 10.0 * deg, f32::from(p) * 10.0 * deg, f32::from(y) * 10.0 * deg);
                let body = ned_to_body(field, roll, pitch, yaw);
                for v in body.iter().chain(level(body, roll, pitch).iter()) {
                    hash = fnv1a(hash, *v);
                }
                hash = fnv1a(hash, magnetic_heading_rad(body, roll, pitch));
            }
        }
    }
    hash
}
