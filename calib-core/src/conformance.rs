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

/// SplitMix64: a tiny deterministic generator, identical on every platform.
#[derive(Debug, Clone)]
pub struct SplitMix64(u64);

impl SplitMix64 {
    /// Seeded generator.
    pub const fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn gauss(&mut self) -> f64 {
        let u1 = self.uniform().max(f64::MIN_POSITIVE);
        let u2 = self.uniform();
        libm::sqrt(-2.0 * libm::log(u1)) * libm::cos(core::f64::consts::TAU * u2)
    }

    /// A unit vector, uniform on the sphere.
    pub fn direction(&mut self) -> [f64; 3] {
        let z = 2.0 * self.uniform() - 1.0;
        let phi = core::f64::consts::TAU * self.uniform();
        let r = libm::sqrt(1.0 - z * z);
        [r * libm::cos(phi), r * libm::sin(phi), z]
    }
}

/// Reference intensity of [`tumble_sample`], nT.
pub const TUMBLE_FIELD_NT: f64 = 50_000.0;
/// Noise of [`tumble_sample`], nT per axis (1σ).
pub const TUMBLE_NOISE_NT: f64 = 0.4;
/// Hard iron of [`tumble_sample`], raw units (≈ nT).
pub const TUMBLE_BIAS: [f64; 3] = [1200.0, -800.0, 350.0];
/// Soft iron of [`tumble_sample`] (raw per nT).
pub const TUMBLE_DISTORTION: [[f64; 3]; 3] = [[1.05, 0.03, -0.01], [0.03, 0.96, 0.02], [-0.01, 0.02, 1.08]];

/// The full-tumble workload (the board's f32 fit against the host's f64): a field of [`TUMBLE_FIELD_NT`] in a
/// uniformly random direction, distorted by [`TUMBLE_DISTORTION`], offset by
/// [`TUMBLE_BIAS`], plus Gaussian noise. Computed in `f64` with `libm`, so the
/// MCU and the host generate the same samples.
pub fn tumble_sample(rng: &mut SplitMix64) -> [f64; 3] {
    let u = rng.direction();
    let h = [TUMBLE_FIELD_NT * u[0], TUMBLE_FIELD_NT * u[1], TUMBLE_FIELD_NT * u[2]];
    let d = crate::linalg::mul_mat_vec(&TUMBLE_DISTORTION, h);
    let mut out = [0.0; 3];
    for k in 0..3 {
        out[k] = d[k] + TUMBLE_BIAS[k] + TUMBLE_NOISE_NT * rng.gauss();
    }
    out
}

/// Paper 001's simulated sensor (§5.1): θ = 0.06, φ = 0.08, ψ = −0.04 rad,
/// k′XZ = 0.95, k′YZ = 1.05.
pub const PAPER001_TRUTH: crate::ortho::OrthoAngles<f64> =
    crate::ortho::OrthoAngles { theta_rad: 0.06, phi_rad: 0.08, psi_rad: -0.04, k_xz: 0.95, k_yz: 1.05 };

/// One sample of paper 001's simulation: the field (1, 1, √2) (norm 2, in
/// units of 10⁴ nT) seen by the sensor in a uniformly random orientation,
/// through `Γ` of [`PAPER001_TRUTH`], plus independent Gaussian noise of
/// `sigma` on each axis.
pub fn paper001_sample(rng: &mut SplitMix64, sigma: f64) -> [f64; 3] {
    // A uniformly random rotation of a fixed vector is a uniformly random
    // direction of the same length.
    let u = rng.direction();
    let b = [2.0 * u[0], 2.0 * u[1], 2.0 * u[2]];
    let m = crate::linalg::mul_mat_vec(&crate::ortho::gamma(&PAPER001_TRUTH), b);
    let mut out = [0.0; 3];
    for k in 0..3 {
        out[k] = m[k] + sigma * rng.gauss();
    }
    out
}
