//! Magnetometer calibration math for autonomous underwater vehicles.
//!
//! `no_std`, no allocation, no panics on data: every function here runs
//! unchanged on the Cortex-M4F firmware (in `f32`) and in the host tools (in
//! `f64`). Transcendental functions come from the pure-Rust `libm`, so an
//! `f32` computation gives the same bits on the MCU and on the host. The one
//! exception is the `f32` square root on a hard-float Arm target: the FPU's
//! `VSQRT` (IEEE 754 correctly rounded, as libm's is, so the same bits) in
//! place of libm's software one (`real::sqrt_f32`).
//!
//! The equations are those of `docs/ALGORITHMS.md` (the English reading of
//! the two source papers); each module names the equations it implements.
#![cfg_attr(not(test), no_std)]
// Unsafe only for the FPU's square root (`real::sqrt_f32`).
#![deny(unsafe_code)]
#![deny(missing_docs)]
// No unwrap/expect/panic outside tests. Indexing is allowed: every index in
// this crate is a loop counter bounded by a const array size, and data
// slices from outside are walked with iterators.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]
// `!(x > 0)` is deliberate throughout: it rejects NaN together with the
// out-of-range values, which `x <= 0` would let through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// The linear algebra indexes several fixed-size arrays with one counter, as
// the formulas do; iterator zips would hide the indices the comments cite.
#![allow(clippy::needless_range_loop)]

pub mod attitude_fit;
pub mod backstep;
pub mod cal;
pub mod conformance;
pub mod fit;
pub mod gyro;
pub mod hardiron;
pub mod heading;
pub mod integrity;
pub mod linalg;
pub mod lsq;
pub mod online;
pub mod ortho;
pub mod quality;
pub mod series;
pub mod swing;
pub mod uncertainty;
pub mod water_current;
pub mod real;
pub mod trigf;

pub use real::Real;
