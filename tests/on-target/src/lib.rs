//! On-target test suite (see `tests/on_target.rs`); this library is empty.
//! Run with `cargo test -p target-tests --target thumbv7em-none-eabihf`
//! (or `cargo xtask test`): each test runs on the Cortex-M4F in QEMU.
#![no_std]
