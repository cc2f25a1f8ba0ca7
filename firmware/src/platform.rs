//! Which hardware the one firmware binary woke up on.
//!
//! QEMU's `netduinoplus2` models the STM32F405's USARTs, SPI and timers but
//! not its reset and clock controller nor its debug MCU block: both read as
//! zero there. On silicon, two independent registers say otherwise:
//!
//! * `RCC_CR` (RM0090 §6.3.1): its reset value is `0x0000_XX83` — HSION,
//!   HSIRDY, HSITRIM = 16 and the factory HSICAL byte. A bootloader may turn
//!   HSI off, but HSITRIM and HSICAL stay, so the register is never zero.
//! * `DBGMCU_IDCODE` (RM0090 §38.6.1, at `0xE004_2000`): DEV_ID = `0x413`
//!   on the STM32F405/407.
//!
//! The board is taken for QEMU only when **both** read as QEMU leaves them;
//! any disagreement is taken for silicon (the safe side: QEMU mistaken for
//! a board merely runs without a watchdog it does not model, while a board
//! mistaken for QEMU would stop at its first semihosting call) and logged.
//! Reading them before touching the clocks tells the two apart without a
//! build flag, so the binary tested under QEMU is the binary flashed to the
//! board.

use magcal_protocol::Platform;

/// `DBGMCU_IDCODE.DEV_ID` of the STM32F405/407 (RM0090 §38.6.1).
pub const DEV_ID_F405: u32 = 0x413;

/// What the two registers say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Detection {
    /// The platform decided.
    pub platform: Platform,
    /// The two signals disagreed (worth a warning).
    pub disagreement: bool,
}

/// Decides the platform from `RCC_CR` and `DBGMCU_IDCODE` as read at boot.
pub fn classify(rcc_cr: u32, dbgmcu_idcode: u32) -> Detection {
    let rcc_says_silicon = rcc_cr != 0;
    let idcode_says_silicon = dbgmcu_idcode != 0;
    let platform = if rcc_says_silicon || idcode_says_silicon { Platform::Silicon } else { Platform::Qemu };
    Detection { platform, disagreement: rcc_says_silicon != idcode_says_silicon }
}

/// Whether an IDCODE is an STM32F405/407's (for the boot log).
pub fn is_f405(dbgmcu_idcode: u32) -> bool {
    dbgmcu_idcode & 0xFFF == DEV_ID_F405
}

#[cfg(target_os = "none")]
pub use target::*;

#[cfg(target_os = "none")]
mod target {
    use super::{classify, Detection};
    use core::sync::atomic::{AtomicU8, Ordering};
    use magcal_protocol::Platform;
    use stm32f4xx_hal::pac;

    const UNKNOWN: u8 = 0;
    const SILICON: u8 = 1;
    const QEMU: u8 = 2;
    static DETECTED: AtomicU8 = AtomicU8::new(UNKNOWN);

    /// `DBGMCU_IDCODE` address (RM0090 §38.6.1).
    const DBGMCU_IDCODE: *const u32 = 0xE004_2000 as *const u32;

    /// Reads `RCC_CR` and `DBGMCU_IDCODE` and classifies. Call before the
    /// clock tree is reconfigured. Returns the decision and both readings.
    pub fn detect() -> (Detection, u32, u32) {
        // SAFETY: single reads of two read-only-at-boot registers; no other
        // code owns RCC yet (this runs at the top of `init`, before the HAL
        // takes RCC), and DBGMCU_IDCODE is read-only.
        let (cr, id) = unsafe { ((*pac::RCC::ptr()).cr().read().bits(), core::ptr::read_volatile(DBGMCU_IDCODE)) };
        let d = classify(cr, id);
        DETECTED.store(if d.platform == Platform::Qemu { QEMU } else { SILICON }, Ordering::Relaxed);
        (d, cr, id)
    }

    /// The platform found by [`detect`] at boot. Before `detect` ran, assumes the
    /// board: the safe choice, since it never issues semihosting calls.
    pub fn detect_cached() -> Platform {
        match DETECTED.load(Ordering::Relaxed) {
            QEMU => Platform::Qemu,
            _ => Platform::Silicon,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RCC_CR out of reset on silicon (RM0090 §6.3.1: 0x0000_XX83, HSICAL
    /// a factory byte), and with HSI turned off by a bootloader that runs
    /// from HSE (HSEON|HSERDY, HSION|HSIRDY clear; trim and calibration stay).
    const RCC_CR_RESET: u32 = 0x0000_6C83;
    const RCC_CR_HSI_OFF: u32 = 0x0003_6C80;
    /// DBGMCU_IDCODE of an STM32F405 revision Z (REV_ID 0x1001, DEV_ID 0x413).
    const IDCODE_F405: u32 = 0x1001_6413;

    #[test]
    fn every_combination_of_the_two_signals() {
        let cases = [
            // (RCC_CR, IDCODE, platform, disagreement)
            (RCC_CR_RESET, IDCODE_F405, Platform::Silicon, false),
            (RCC_CR_HSI_OFF, IDCODE_F405, Platform::Silicon, false),
            // A part whose IDCODE reads 0 without a debugger: RCC decides.
            (RCC_CR_RESET, 0, Platform::Silicon, true),
            (RCC_CR_HSI_OFF, 0, Platform::Silicon, true),
            // An emulator that models RCC as zero but returns an IDCODE.
            (0, IDCODE_F405, Platform::Silicon, true),
            // QEMU: both zero.
            (0, 0, Platform::Qemu, false),
        ];
        for (cr, id, platform, disagreement) in cases {
            assert_eq!(classify(cr, id), Detection { platform, disagreement }, "RCC_CR {cr:#x}, IDCODE {id:#x}");
        }
        // The old single-bit test (HSION) would have called the HSI-off
        // board QEMU.
        assert_eq!(RCC_CR_HSI_OFF & 1, 0);
        assert!(is_f405(IDCODE_F405) && !is_f405(0));
    }
}
