//! Where the coefficient store lives in the STM32F405's flash, and how long
//! the independent watchdog waits: both chosen from the datasheet's
//! worst-case flash timings, so that a save can never reset the board.
//!
//! The F405 has one flash bank: while a sector is erased or a byte
//! programmed, every instruction fetch and data read from flash stalls
//! (RM0090 §3.5 "Read interface" / §3.6: "any attempt to read the flash
//! memory while it is being written or erased causes the bus to stall"), so
//! no interrupt handler or task in flash runs and nobody can feed the
//! watchdog. The design therefore
//!
//! * stores on two **16 KiB** sectors (1 and 2, RM0090 §3.3 Table 5), whose
//!   worst-case erase is 800 ms at ×8 parallelism (STM32F405 datasheet
//!   DS8626 §6.3.12, Table "Flash memory programming": t_ERASE16KB, ×8,
//!   max), instead of 128 KiB sectors (4 s worst);
//! * places the program after them (`_stext` in `memory.x`: the vector
//!   table stays in sector 0, `.text` starts at sector 3);
//! * feeds the watchdog just before a save and sets its timeout so that the
//!   worst stall takes less than half of it even with the LSI at its fastest
//!   (DS8626 §6.3.8, LSI oscillator: 17–47 kHz; the IWDG counts LSI; the
//!   LSI figures are in [`crate::clocks`]).
//!
//! The stm32f4xx-hal erases and programs with ×8 parallelism (PSIZE = 0),
//! valid at any supply voltage; the ×8 figures are used throughout.

use crate::clocks;

/// Start of the flash in the memory map.
pub const FLASH_BASE: u32 = 0x0800_0000;
/// Size of each store sector (sectors 1 and 2).
pub const STORE_SECTOR_BYTES: u32 = 16 * 1024;
/// Offsets of the two store sectors from [`FLASH_BASE`] (sectors 1 and 2).
pub const STORE_OFFSETS: [u32; 2] = [0x0000_4000, 0x0000_8000];
/// Where `.text` starts (sector 3), as `_stext` in `memory.x`.
pub const TEXT_START: u32 = 0x0800_C000;

/// Worst-case erase of a 16 KiB sector at ×8 parallelism, ms (DS8626
/// §6.3.12, t_ERASE16KB max).
pub const ERASE_16K_MAX_MS: u32 = 800;
/// Worst-case byte program at ×8 parallelism, µs (DS8626 §6.3.12, t_prog max).
pub const PROGRAM_BYTE_MAX_US: u32 = 100;
/// Bytes a save programs at most (header, payload, CRC; see `store`).
pub const RECORD_MAX_BYTES: u32 = 16 + crate::store::MAX_PAYLOAD as u32 + 4;

/// The longest the CPU can stall in one save: one sector erase plus a full
/// record programmed byte by byte, all at their datasheet maxima, ms.
pub const fn worst_store_stall_ms() -> u32 {
    ERASE_16K_MAX_MS + (RECORD_MAX_BYTES * PROGRAM_BYTE_MAX_US).div_ceil(1000)
}

/// Independent watchdog timeout asked of the HAL, ms. The HAL computes the
/// prescaler and reload for the LSI's typical 32 kHz.
pub const WATCHDOG_TIMEOUT_MS: u32 = 2_500;

/// The shortest the watchdog can actually wait: the nominal timeout with
/// the LSI at its fastest, ms.
pub const fn watchdog_min_timeout_ms() -> u32 {
    (WATCHDOG_TIMEOUT_MS as u64 * clocks::LSI_TYP_HZ as u64 / clocks::LSI_MAX_HZ as u64) as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_worst_save_stall_fits_twice_in_the_shortest_watchdog() {
        // 800 ms erase + (16 + 108 + 4) B × 100 µs = 812.8 → 813 ms (the
        // record holds one encoded coefficient set, 27 f32); 2 500 ms × 32/47
        // = 1 702 ms.
        assert_eq!(RECORD_MAX_BYTES, 128);
        assert_eq!(worst_store_stall_ms(), 813);
        assert_eq!(watchdog_min_timeout_ms(), 1_702);
        assert!(2 * worst_store_stall_ms() < watchdog_min_timeout_ms());
    }

    #[test]
    fn the_store_sectors_sit_between_the_vector_table_and_the_program() {
        // RM0090 Table 5: sectors 0-3 are 16 KiB from 0x0800_0000.
        assert_eq!(STORE_OFFSETS, [STORE_SECTOR_BYTES, 2 * STORE_SECTOR_BYTES]);
        assert_eq!(TEXT_START, FLASH_BASE + 3 * STORE_SECTOR_BYTES);
    }
}
