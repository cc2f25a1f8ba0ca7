//! `f32` sine and cosine, bit for bit libm's (`sinf`, `cosf`: FreeBSD's
//! `s_sinf.c`/`s_cosf.c`/`k_sinf.c`/`k_cosf.c`/`e_rem_pio2f.c`, via musl
//! and the Rust `libm` 0.2, whose constants and operation order are kept
//! here) for every |x| below 2²⁸·π/2 ≈ 4.2·10⁸ rad.
//!
//! Why not call libm: its `sinf`/`cosf` link the Payne–Hanek reduction for
//! huge arguments (`rem_pio2_large`, ~2.5 KiB on the Cortex-M4F) that no
//! angle of this stack needs — attitudes are within ±π, headings are
//! wrapped. Beyond 2²⁸·π/2 (where an `f32` angle's spacing is already 32
//! rad, so it means no direction) the result is NaN, which every validation
//! in the stack refuses, instead of a number.
//!
//! Copyright (C) 1993 by Sun Microsystems, Inc. All rights reserved.
//! Developed at SunPro, a Sun Microsystems, Inc. business. Permission to
//! use, copy, modify, and distribute this software is freely granted,
//! provided that this notice is preserved. (Conversion to float by Ian
//! Lance Taylor, Cygnus Support; optimized by Bruce D. Evans.)

// The polynomial and π/2 constants as libm writes them (its exact bits).
#![allow(clippy::excessive_precision)]

use core::f64::consts::{FRAC_2_PI, FRAC_PI_2};

const PIO2_1X: f64 = FRAC_PI_2;
const PIO2_2X: f64 = 2. * FRAC_PI_2;
const PIO2_3X: f64 = 3. * FRAC_PI_2;
const PIO2_4X: f64 = 4. * FRAC_PI_2;

/// |sin(x)/x − s(x)| < 2⁻³⁷·⁵ on [−π/4, π/4].
fn k_sinf(x: f64) -> f32 {
    const S1: f64 = -0.166666666416265235595;
    const S2: f64 = 0.0083333293858894631756;
    const S3: f64 = -0.000198393348360966317347;
    const S4: f64 = 0.0000027183114939898219064;
    let z = x * x;
    let w = z * z;
    let r = S3 + z * S4;
    let s = z * x;
    ((x + s * (S1 + z * S2)) + s * w * r) as f32
}

/// |cos(x) − c(x)| < 2⁻³⁴·¹ on [−π/4, π/4].
fn k_cosf(x: f64) -> f32 {
    const C0: f64 = -0.499999997251031003120;
    const C1: f64 = 0.0416666233237390631894;
    const C2: f64 = -0.00138867637746099294692;
    const C3: f64 = 0.0000243904487962774090654;
    let z = x * x;
    let w = z * z;
    let r = C2 + z * C3;
    (((1.0 + z * C0) + w * C1) + (w * z) * r) as f32
}

/// x = n·π/2 + y, |y| ≤ π/4 (libm's medium-size path, 25 + 53 bits of π).
fn rem_pio2f(x: f32) -> (i32, f64) {
    const TOINT: f64 = 1.5 / f64::EPSILON;
    // libm's 6.36619772367581382433e-01 (0x3FE45F30_6DC9C883): 2/π.
    const INV_PIO2: f64 = FRAC_2_PI;
    const PIO2_1: f64 = 1.57079631090164184570e+00;
    const PIO2_1T: f64 = 1.58932547735281966916e-08;
    let x64 = x as f64;
    let tmp = x64 * INV_PIO2 + TOINT;
    let f_n = tmp - TOINT;
    (f_n as i32, x64 - f_n * PIO2_1 - f_n * PIO2_1T)
}

/// sin x.
pub fn sinf(x: f32) -> f32 {
    let x64 = x as f64;
    let mut ix = x.to_bits();
    let sign = (ix >> 31) != 0;
    ix &= 0x7fff_ffff;
    if ix <= 0x3f49_0fda {
        // |x| ≲ π/4
        if ix < 0x3980_0000 {
            return x;
        }
        return k_sinf(x64);
    }
    if ix <= 0x407b_53d1 {
        // |x| ≲ 5π/4
        if ix <= 0x4016_cbe3 {
            return if sign { -k_cosf(x64 + PIO2_1X) } else { k_cosf(x64 - PIO2_1X) };
        }
        return k_sinf(if sign { -(x64 + PIO2_2X) } else { -(x64 - PIO2_2X) });
    }
    if ix <= 0x40e2_31d5 {
        // |x| ≲ 9π/4
        if ix <= 0x40af_eddf {
            return if sign { k_cosf(x64 + PIO2_3X) } else { -k_cosf(x64 - PIO2_3X) };
        }
        return k_sinf(if sign { x64 + PIO2_4X } else { x64 - PIO2_4X });
    }
    if ix >= 0x4dc9_0fdb {
        // Inf, NaN, or beyond the medium range.
        return f32::NAN;
    }
    let (n, y) = rem_pio2f(x);
    match n & 3 {
        0 => k_sinf(y),
        1 => k_cosf(y),
        2 => k_sinf(-y),
        _ => -k_cosf(y),
    }
}

/// cos x.
pub fn cosf(x: f32) -> f32 {
    let x64 = x as f64;
    let mut ix = x.to_bits();
    let sign = (ix >> 31) != 0;
    ix &= 0x7fff_ffff;
    if ix <= 0x3f49_0fda {
        if ix < 0x3980_0000 {
            return 1.;
        }
        return k_cosf(x64);
    }
    if ix <= 0x407b_53d1 {
        if ix > 0x4016_cbe3 {
            return -k_cosf(if sign { x64 + PIO2_2X } else { x64 - PIO2_2X });
        }
        return if sign { k_sinf(x64 + PIO2_1X) } else { k_sinf(PIO2_1X - x64) };
    }
    if ix <= 0x40e2_31d5 {
        if ix > 0x40af_eddf {
            return k_cosf(if sign { x64 + PIO2_4X } else { x64 - PIO2_4X });
        }
        return if sign { k_sinf(-x64 - PIO2_3X) } else { k_sinf(x64 - PIO2_3X) };
    }
    if ix >= 0x4dc9_0fdb {
        return f32::NAN;
    }
    let (n, y) = rem_pio2f(x);
    match n & 3 {
        0 => k_cosf(y),
        1 => k_sinf(-y),
        2 => -k_cosf(y),
        _ => k_sinf(y),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conformance::SplitMix64;

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    #[test]
    fn sine_and_cosine_are_libms_bit_for_bit_below_2_pow_28_pi_over_2() {
        // libm is the independent reference (the same algorithm, its own
        // code). Every f32 in [0, 8] in steps of 2⁻¹⁶, random magnitudes up
        // to the medium-size limit, the range boundaries and the specials.
        let mut xs: Vec<f32> = (0..(8 << 16)).map(|k| k as f32 / 65_536.0).collect();
        let mut rng = SplitMix64::new(5);
        for _ in 0..200_000 {
            let e = rng.uniform() * 28.0;
            xs.push((libm::exp2(e) * rng.uniform()) as f32);
        }
        for b in [0x3f49_0fdau32, 0x3980_0000, 0x407b_53d1, 0x4016_cbe3, 0x40e2_31d5, 0x40af_eddf] {
            for d in [-1i32, 0, 1] {
                xs.push(f32::from_bits((b as i32 + d) as u32));
            }
        }
        xs.extend([f32::from_bits(0x4dc9_0fda), f32::INFINITY, f32::NAN, f32::MIN_POSITIVE, 1e-40, 0.0]);
        let mut checked = 0;
        for x in xs {
            for x in [x, -x] {
                assert!(same(sinf(x), libm::sinf(x)), "sin({x:e}): {} vs {}", sinf(x), libm::sinf(x));
                assert!(same(cosf(x), libm::cosf(x)), "cos({x:e}): {} vs {}", cosf(x), libm::cosf(x));
                checked += 1;
            }
        }
        assert!(checked > 1_000_000);
    }

    #[test]
    fn beyond_the_medium_range_is_nan() {
        for x in [f32::from_bits(0x4dc9_0fdb), 5e8f32, 1e12, 3.4e38, -7e20] {
            assert!(sinf(x).is_nan() && cosf(x).is_nan(), "{x}");
        }
    }
}
