//! Which hardware the one firmware binary woke up on.
//!
//! QEMU's `netduinoplus2` models the STM32F405's USARTs, SPI and timers but
//! not its reset and clock controller: RCC registers read as zero there. On
//! silicon the internal 16 MHz oscillator is running out of reset, so
//! `RCC_CR.HSION` reads 1. Reading that bit before touching the clocks tells
//! the two apart without a build flag, so the binary tested under QEMU is the
//! binary flashed to the board.

use core::sync::atomic::{AtomicU8, Ordering};
use magcal_protocol::Platform;
use stm32f4xx_hal::pac;

const UNKNOWN: u8 = 0;
const SILICON: u8 = 1;
const QEMU: u8 = 2;
static DETECTED: AtomicU8 = AtomicU8::new(UNKNOWN);

/// Reads `RCC_CR.HSION`. Call before the clock tree is reconfigured (the
/// firmware may switch HSI off once it runs from the PLL).
pub fn detect() -> Platform {
    // SAFETY: a single read of a status register; no other code owns RCC yet
    // (this runs at the top of `init`, before the HAL takes RCC).
    let cr = unsafe { (*pac::RCC::ptr()).cr().read() };
    let platform = if cr.hsion().bit_is_set() { Platform::Silicon } else { Platform::Qemu };
    DETECTED.store(if platform == Platform::Qemu { QEMU } else { SILICON }, Ordering::Relaxed);
    platform
}

/// The platform found by [`detect`] at boot. Before `detect` ran, assumes the
/// board: the safe choice, since it never issues semihosting calls.
pub fn detect_cached() -> Platform {
    match DETECTED.load(Ordering::Relaxed) {
        QEMU => Platform::Qemu,
        _ => Platform::Silicon,
    }
}

/// SysTick's input clock under QEMU: the emulated core's 168 MHz, whatever
/// RCC was asked for (QEMU does not model the clock tree).
pub const QEMU_SYSCLK_HZ: u32 = 168_000_000;

/// The board's high-speed external crystal.
pub const BOARD_HSE_HZ: u32 = 8_000_000;

/// System clock the board runs at (the STM32F405's maximum).
pub const BOARD_SYSCLK_HZ: u32 = 168_000_000;
