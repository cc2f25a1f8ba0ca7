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
    ($t:ty, $sqrt:ident, $sin:ident, $cos:ident, $atan2:ident, $fabs:ident, $floor:ident) => {
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
            fn sqrt(self) -> Self {
                libm::$sqrt(self)
            }
            #[inline]
            fn sin(self) -> Self {
                libm::$sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                libm::$cos(self)
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

impl_real!(f32, sqrtf, sinf, cosf, atan2f, fabsf, floorf);
impl_real!(f64, sqrt, sin, cos, atan2, fabs, floor);
