//! `f32` sine and cosine in `f32` arithmetic only, for |x| ≤ 8192 rad.
//!
//! Why not libm's `sinf`/`cosf`: they compute in `f64` (FreeBSD's kernels)
//! and link the Payne–Hanek reduction for huge arguments; on the
//! Cortex-M4F, whose FPU is single precision, the `f64` arithmetic is
//! software — about 2.6 KiB of flash for the additions, multiplications
//! and conversions, and slow. No angle of this stack needs either:
//! attitudes are within ±π, headings are wrapped, the largest argument is a
//! harmonic of a heading.
//!
//! The method is Cody and Waite's (as in Moshier's Cephes `sinf.c`): the
//! argument is reduced to |y| ≤ π/4 by the nearest even multiple of π/4,
//! subtracted in three parts (the first exact, the first difference exact by
//! Sterbenz's lemma), then a minimax polynomial of
//! degree 7 (sine) or 8 (cosine) in `y`. Error against `f64` libm: about
//! one unit of the `f32` spacing of the result (measured 1.003; of 0.5's
//! near a zero of the function: 6·10⁻⁸ absolute), over every `f32` in
//! [0, 8] in steps of 2⁻¹⁶ and random arguments to 8192. The same code on
//! the MCU and the host gives the same bits (no fused multiply-add: Rust
//! does not contract). Beyond 8192 rad the result is NaN, which every
//! validation in the stack refuses, instead of a number.

// The polynomials' coefficients as Cephes publishes them (rounded to f32 by
// the compiler).
#![allow(clippy::excessive_precision)]

/// The largest |x| reduced.
pub const MAX_ARG_RAD: f32 = 8192.0;

const FOUR_OVER_PI: f32 = 1.273_239_5;
/// π/4 in three parts: 0.78515625 (8 significant bits: its product with the
/// multiple is exact), then 12 more bits, then the rest.
const PIO4_1: f32 = 0.785_156_25;
const PIO4_2: f32 = 2.418_756_484_985_351_562_5e-4;
const PIO4_3: f32 = 3.774_894_977_445_941_1e-8;

/// x = j·π/4 + y with j even and |y| ≤ π/4, for 0 ≤ x ≤ [`MAX_ARG_RAD`];
/// returns the quadrant `j/2 mod 4` and `y`.
#[inline(always)]
fn reduce(ax: f32) -> (u32, f32) {
    let mut j = (ax * FOUR_OVER_PI) as u32;
    j += j & 1;
    let n = j as f32;
    (((j >> 1) & 3), ((ax - n * PIO4_1) - n * PIO4_2) - n * PIO4_3)
}

/// sin y on |y| ≤ π/4 (Cephes' single-precision coefficients).
#[inline(always)]
fn sin_poly(y: f32) -> f32 {
    let z = y * y;
    ((-1.951_529_589_1e-4 * z + 8.332_160_873_6e-3) * z - 1.666_665_461_1e-1) * z * y + y
}

/// cos y on |y| ≤ π/4 (Cephes' single-precision coefficients).
#[inline(always)]
fn cos_poly(y: f32) -> f32 {
    let z = y * y;
    ((2.443_315_711_809_948e-5 * z - 1.388_731_625_493_765e-3) * z + 4.166_664_568_298_827e-2) * z * z - 0.5 * z + 1.0
}

/// sin x for |x| ≤ [`MAX_ARG_RAD`]; NaN beyond, and for NaN or ±∞.
pub fn sinf(x: f32) -> f32 {
    let ax = x.abs();
    if !(ax <= MAX_ARG_RAD) {
        return f32::NAN;
    }
    let (q, y) = reduce(ax);
    let s = match q {
        0 => sin_poly(y),
        1 => cos_poly(y),
        2 => -sin_poly(y),
        _ => -cos_poly(y),
    };
    // sin is odd.
    if x.is_sign_negative() { -s } else { s }
}

/// cos x for |x| ≤ [`MAX_ARG_RAD`]; NaN beyond, and for NaN or ±∞.
pub fn cosf(x: f32) -> f32 {
    let ax = x.abs();
    if !(ax <= MAX_ARG_RAD) {
        return f32::NAN;
    }
    let (q, y) = reduce(ax);
    match q {
        0 => cos_poly(y),
        1 => -sin_poly(y),
        2 => -cos_poly(y),
        _ => sin_poly(y),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conformance::SplitMix64;

    /// Error of `got` against the exact value `want` (f64 libm) in units of
    /// the f32 spacing at `want`, that spacing floored at the spacing of
    /// 0.5 (below, the absolute error counts: a result near a zero of the
    /// function carries the reduction's absolute error, not a relative one).
    fn ulps(got: f32, want: f64) -> f64 {
        let spacing = libm::fabs(want).max(0.5) * f64::from(f32::EPSILON);
        libm::fabs(f64::from(got) - want) / spacing
    }

    #[test]
    fn sine_and_cosine_are_within_one_and_a_half_ulp_of_f64_libm_up_to_8192_rad() {
        // f64 libm is the independent reference. Every f32 in [0, 8] in
        // steps of 2⁻¹⁶, and random magnitudes up to 8192 rad.
        let mut xs: Vec<f32> = (0..(8 << 16)).map(|k| k as f32 / 65_536.0).collect();
        let mut rng = SplitMix64::new(5);
        for _ in 0..200_000 {
            xs.push((rng.uniform() * f64::from(MAX_ARG_RAD)) as f32);
        }
        xs.extend([MAX_ARG_RAD, f32::MIN_POSITIVE, 1e-40, 0.0, core::f32::consts::FRAC_PI_4, core::f32::consts::PI]);
        let (mut worst_sin, mut worst_cos) = (0.0f64, 0.0f64);
        let mut checked = 0;
        for x in xs {
            for x in [x, -x] {
                let x64 = f64::from(x);
                worst_sin = worst_sin.max(ulps(sinf(x), libm::sin(x64)));
                worst_cos = worst_cos.max(ulps(cosf(x), libm::cos(x64)));
                checked += 1;
            }
        }
        // Measured: 1.003 (sine), 0.971 (cosine) units of the f32 spacing
        // (floored at 0.5's: 6·10⁻⁸ absolute near the zeros).
        std::println!("worst: sin {worst_sin:.3}, cos {worst_cos:.3} ulp over {checked} arguments");
        assert!(worst_sin < 1.5 && worst_cos < 1.5, "sin {worst_sin} cos {worst_cos}");
        assert!(checked > 1_000_000);
        // The sign of zero, as libm.
        assert!(sinf(-0.0).is_sign_negative() && sinf(0.0).is_sign_positive());
    }

    #[test]
    fn beyond_8192_rad_is_nan() {
        for x in [8192.001f32, 5e8, 1e12, 3.4e38, -7e20, f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert!(sinf(x).is_nan() && cosf(x).is_nan(), "{x}");
        }
    }
}
