//! STM32F405 specifics that only exist on the Cortex-M target: the flash
//! controller behind [`NorFlash`], a cycle-counting delay, the boot nonce.

use embedded_hal::delay::DelayNs;
use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use stm32f4xx_hal::flash::{Error as FlashError, FlashExt, LockedFlash};

/// The on-chip flash, unlocked only for the duration of each erase/write.
pub struct BoardFlash {
    flash: LockedFlash,
}

impl BoardFlash {
    /// Takes the flash controller.
    pub fn new(flash: LockedFlash) -> Self {
        Self { flash }
    }
}

impl ErrorType for BoardFlash {
    type Error = FlashError;
}

impl ReadNorFlash for BoardFlash {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        ReadNorFlash::read(&mut self.flash, offset, bytes)
    }
    fn capacity(&self) -> usize {
        self.flash.len()
    }
}

impl NorFlash for BoardFlash {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = 128 * 1024;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let mut unlocked = self.flash.unlocked();
        NorFlash::erase(&mut unlocked, from, to)
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let mut unlocked = self.flash.unlocked();
        NorFlash::write(&mut unlocked, offset, bytes)
    }
}

/// Offsets of the store's sectors from the start of flash (sectors 10 and
/// 11, reserved in memory.x) and their size.
pub const STORE_SECTORS: (u32, u32, u32) = (0x000C_0000, 0x000E_0000, 0x0002_0000);

/// Busy-wait delay counted in core cycles.
pub struct CycleDelay {
    cycles_per_us: u32,
}

impl CycleDelay {
    /// For a core clock of `sysclk_hz`.
    pub fn new(sysclk_hz: u32) -> Self {
        Self { cycles_per_us: (sysclk_hz / 1_000_000).max(1) }
    }
}

impl DelayNs for CycleDelay {
    fn delay_ns(&mut self, ns: u32) {
        let cycles = (u64::from(ns) * u64::from(self.cycles_per_us)).div_ceil(1000);
        cortex_m::asm::delay(cycles.min(u64::from(u32::MAX)) as u32);
    }
}

/// A per-boot unlock challenge: the 96-bit unique device ID (on silicon;
/// QEMU does not map it) mixed with SysTick's current value. Not a secret: it
/// makes an unlock deliberate and stale unlock keys useless after a reset.
pub fn boot_challenge(platform: magcal_protocol::Platform) -> u32 {
    let uid = match platform {
        // SAFETY: the unique ID is a read-only system-memory area on every STM32F4.
        magcal_protocol::Platform::Silicon => unsafe {
            [core::ptr::read_volatile(0x1FFF_7A10 as *const u32), core::ptr::read_volatile(0x1FFF_7A14 as *const u32), core::ptr::read_volatile(0x1FFF_7A18 as *const u32)]
        },
        magcal_protocol::Platform::Qemu => [0x5145_4D55, 0, 0],
    };
    let tick = cortex_m::peripheral::SYST::get_current();
    let mut h: u32 = 0x811c_9dc5;
    for w in uid.iter().chain(core::iter::once(&tick)) {
        for b in w.to_le_bytes() {
            h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
    }
    h
}
