//! The scalar type the math is generic over: `f32` on the MCU, `f64` on the host.

use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar. Implemented for `f32` and `f64` on top of the
/// pure-Rust `libm`, so results do not depend on the platform's maths library.
pub trait Real:
    Copy
    + PartialOrd
    + core::fmt::Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// π.
    const PI: Self;
    /// 2π.
    const TAU: Self;
    /// Machine epsilon.
    const EPSILON: Self;
    /// Not a number ("not determined").
    const NAN: Self;

    /// Converts from `f64`, rounding to nearest.
    fn from_f64(v: f64) -> Self;
    /// Widens to `f64` (exact for both implementations).
    fn to_f64(self) -> f64;
    /// From a count (exact below 2²⁴ for `f32`), without passing through
    /// `f64` (software arithmetic on the Cortex-M4F).
    fn from_u32(n: u32) -> Self;
    /// Truncates towards zero to a `u32`, saturating (NaN → 0), without
    /// passing through `f64`.
    fn to_u32(self) -> u32;
    /// Square root (NaN for negative input).
    fn sqrt(self) -> Self;
    /// Sine of an angle in radians.
    fn sin(self) -> Self;
    /// Cosine of an angle in radians.
    fn cos(self) -> Self;
    /// Four-quadrant arctangent of `self / x`, in (−π, π].
    fn atan2(self, x: Self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Largest integer value not greater than `self`.
    fn floor(self) -> Self;
    /// Neither NaN nor infinite.
    fn is_finite(self) -> bool;
    /// The smaller of two values (NaN-ignoring).
    fn min(self, other: Self) -> Self {
        if other < self { other } else { self }
    }
    /// The larger of two values (NaN-ignoring).
    fn max(self, other: Self) -> Self {
        if other > self { other } else { self }
    }
}

macro_rules! impl_real {
    ($t:ty, $sqrt:path, $sin:path, $cos:path, $atan2:ident, $fabs:ident, $floor:ident) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const PI: Self = core::f64::consts::PI as $t;
            const TAU: Self = core::f64::consts::TAU as $t;
            const EPSILON: Self = <$t>::EPSILON;
            const NAN: Self = <$t>::NAN;
            #[inline]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_u32(n: u32) -> Self {
                n as $t
            }
            #[inline]
            fn to_u32(self) -> u32 {
                self as u32
            }
            #[inline]
            fn sqrt(self) -> Self {
                $sqrt(self)
            }
            #[inline]
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline]
            fn atan2(self, x: Self) -> Self {
                libm::$atan2(self, x)
            }
            #[inline]
            fn abs(self) -> Self {
                libm::$fabs(self)
            }
            #[inline]
            fn floor(self) -> Self {
                libm::$floor(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
        }
    };
}

// f32 sine and cosine: libm's, without its huge-argument reduction (`trigf`).
impl_real!(f32, sqrt_f32, crate::trigf::sinf, crate::trigf::cosf, atan2f, fabsf, floorf);
impl_real!(f64, libm::sqrt, libm::sin, libm::cos, atan2, fabs, floor);

/// The `f32` square root, correctly rounded (IEEE 754) everywhere: on a
/// hard-float Arm target (the Cortex-M4F's FPv4-SP) the FPU's `VSQRT.F32`,
/// where libm's software square root costs ~40 instructions of the
/// per-sample path; elsewhere libm's. Both round correctly, so the bits are
/// the same (the on-target digest test compares them).
#[inline(always)]
pub fn sqrt_f32(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: `magcal_vsqrtf` (below) follows the AAPCS-VFP calling
        // convention of `extern "C" fn(f32) -> f32` on eabihf: argument and
        // result in s0; it touches nothing else.
        #[allow(unsafe_code)]
        unsafe {
            magcal_vsqrtf(x)
        }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// `VSQRT.F32 s0, s0` as an AAPCS-VFP leaf function.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[allow(unsafe_code)]
mod vsqrt {
    // One leaf function in its own section: s0 in, s0 out, nothing else
    // touched.
    core::arch::global_asm!(
        ".section .text.magcal_vsqrtf,\"ax\",%progbits",
        ".global magcal_vsqrtf",
        ".type magcal_vsqrtf,%function",
        ".thumb_func",
        "magcal_vsqrtf:",
        ".fpu fpv4-sp-d16",
        "vsqrt.f32 s0, s0",
        "bx lr",
        ".size magcal_vsqrtf, . - magcal_vsqrtf",
    );

    unsafe extern "C" {
        /// The function above.
        pub(super) fn magcal_vsqrtf(x: f32) -> f32;
    }
}
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
use vsqrt::magcal_vsqrtf;
