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
    /// The store's sectors (1 and 2) are 16 KiB (RM0090 §3.3 Table 5); the
    /// HAL erases every sector a range touches.
    const ERASE_SIZE: usize = crate::layout::STORE_SECTOR_BYTES as usize;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let mut unlocked = self.flash.unlocked();
        NorFlash::erase(&mut unlocked, from, to)
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let mut unlocked = self.flash.unlocked();
        NorFlash::write(&mut unlocked, offset, bytes)
    }
}

/// Starts DWT's cycle counter: it keeps counting while the CPU stalls on a
/// flash erase, when SysTick's interrupt (the monotonic's millisecond) cannot
/// run. QEMU does not model it (it reads 0).
pub fn enable_cycle_counter(mut dcb: cortex_m::peripheral::DCB, mut dwt: cortex_m::peripheral::DWT) {
    dcb.enable_trace();
    dwt.enable_cycle_counter();
}

/// A time stamp from two clocks: the monotonic's milliseconds (stop during
/// a flash stall on silicon) and the cycle counter (0 under QEMU). An
/// elapsed time is the larger of the two readings.
#[derive(Debug, Clone, Copy)]
pub struct Stopwatch {
    cycles: u32,
    ms: u32,
}

impl Stopwatch {
    /// Now, given the monotonic's milliseconds.
    pub fn now(ms: u32) -> Self {
        Self { cycles: cortex_m::peripheral::DWT::cycle_count(), ms }
    }

    /// Milliseconds from `self` to `later`.
    pub fn elapsed_ms_to(&self, later: &Stopwatch) -> u32 {
        let by_cycles = later.cycles.wrapping_sub(self.cycles) / (crate::clocks::BOARD_SYSCLK_HZ / 1000);
        by_cycles.max(later.ms.wrapping_sub(self.ms))
    }

    /// Milliseconds from `self` to now.
    pub fn elapsed_ms(&self, now_ms: u32) -> u32 {
        self.elapsed_ms_to(&Self::now(now_ms))
    }
}

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

/// The ADS131M04's DRDY on a GPIO whose EXTI line fires on the falling edge
/// (SBAS890 §8.5.1.9: DRDY falls when a conversion is ready). The EXTI
/// handler writes `signal`; a wait returns at once if DRDY is already low.
pub struct ExtiDrdy<P> {
    pin: P,
    signal: rtic_sync::signal::SignalReader<'static, ()>,
}

impl<P: embedded_hal::digital::InputPin> ExtiDrdy<P> {
    /// The pin (configured for a falling-edge EXTI interrupt) and the
    /// reader of the signal its handler writes.
    pub fn new(pin: P, signal: rtic_sync::signal::SignalReader<'static, ()>) -> Self {
        Self { pin, signal }
    }
}

impl<P: embedded_hal::digital::InputPin> embedded_hal::digital::ErrorType for ExtiDrdy<P> {
    type Error = embedded_hal::digital::ErrorKind;
}

impl<P: embedded_hal::digital::InputPin> embedded_hal::digital::InputPin for ExtiDrdy<P> {
    fn is_high(&mut self) -> Result<bool, Self::Error> {
        self.pin.is_high().map_err(|_| embedded_hal::digital::ErrorKind::Other)
    }
    fn is_low(&mut self) -> Result<bool, Self::Error> {
        self.pin.is_low().map_err(|_| embedded_hal::digital::ErrorKind::Other)
    }
}

impl<P: embedded_hal::digital::InputPin> embedded_hal_async::digital::Wait for ExtiDrdy<P> {
    async fn wait_for_low(&mut self) -> Result<(), Self::Error> {
        // Forget old edges, then look at the level: an edge after this
        // point is kept by the signal, so none is missed.
        let _ = self.signal.try_read();
        if self.pin.is_low().map_err(|_| embedded_hal::digital::ErrorKind::Other)? {
            return Ok(());
        }
        self.signal.wait().await;
        Ok(())
    }
    async fn wait_for_falling_edge(&mut self) -> Result<(), Self::Error> {
        self.wait_for_low().await
    }
    async fn wait_for_high(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
    async fn wait_for_rising_edge(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
    async fn wait_for_any_edge(&mut self) -> Result<(), Self::Error> {
        self.wait_for_low().await
    }
}
