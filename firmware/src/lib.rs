//! The magnetometer board's firmware logic, apart from the RTIC `#[app]`.
//!
//! Board-independent modules ([`link`]) compile and test on the host
//! (`cargo test -p firmware --lib`); the hardware glue ([`platform`],
//! [`logger`]) exists only for the Cortex-M target. `src/main.rs` is a thin
//! RTIC app that wires these to interrupts and tasks.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing))]
// `!(x < limit)` is deliberate: it rejects NaN along with the out-of-range.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Per-channel loops index parallel register arrays, as the datasheet's tables do.
#![allow(clippy::needless_range_loop)]
// No heap: the large variants (an RLS state, a pending commit) cannot be boxed,
// and each enum lives once, in a task's state.
#![allow(clippy::large_enum_variant)]

#[cfg(all(feature = "mock-flash", not(test)))]
extern crate std;

pub mod acquisition;
pub mod adc;
pub mod board;
pub mod clocks;
pub mod device;
pub mod layout;
pub mod link;
pub mod nmea;
pub mod platform;
pub mod ads131m04_model;
pub mod store;
pub mod tallies;
pub mod thermistor;
pub mod uart;

#[cfg(target_os = "none")]
pub mod board_hw;
#[cfg(target_os = "none")]
pub mod logger;

/// Firmware name reported by `Identify`.
pub const FIRMWARE_NAME: &str = "magcal-fw";
/// Firmware version reported by `Identify` (the crate's semver).
pub const FIRMWARE_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Under QEMU, ends the emulation with a failure status (so a test sees
/// it); on the board, returns. The one place that tells the two apart for
/// a failure.
#[cfg(target_os = "none")]
pub fn exit_qemu_on_failure() {
    if platform::detect_cached() == magcal_protocol::Platform::Qemu {
        cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    }
}

/// After a firmware bug (panic, fault): exits QEMU with a failure status,
/// else resets the board.
#[cfg(target_os = "none")]
pub fn fail_and_reset() -> ! {
    exit_qemu_on_failure();
    cortex_m::peripheral::SCB::sys_reset()
}

/// Stops the firmware after an unrecoverable start-up failure: logs the
/// reason, then exits QEMU with a failure status or, on the board, waits for
/// the watchdog/reset.
#[cfg(target_os = "none")]
pub fn halt(reason: &str) -> ! {
    defmt::error!("halt: {}", reason);
    exit_qemu_on_failure();
    loop {
        cortex_m::asm::wfi();
    }
}
