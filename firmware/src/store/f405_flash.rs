//! A test double of the STM32F405's 1 MiB flash, written from the reference
//! manual and the datasheet (not from the store): the sector map, NOR rules,
//! ×8 program width, erase and program durations, the CPU stall they cause,
//! an independent watchdog that fires when nobody can feed it, power cuts at
//! any byte operation, and read errors.
//!
//! * Sector map (RM0090 §3.3, Table 5): sectors 0–3 of 16 KiB, 4 of 64 KiB,
//!   5–11 of 128 KiB.
//! * Erase works on whole sectors and sets every bit to 1; programming only
//!   clears bits (RM0090 §3.5.4: "successive write operations are possible
//!   … when changing bits from 1 to 0").
//! * ×8 parallelism: one byte per program operation (RM0090 §3.6.2).
//! * Durations (DS8626 §6.3.12, "Flash memory programming", ×8): sector
//!   erase 16 KiB 400 / 800 ms, 64 KiB 1 200 / 2 400 ms, 128 KiB 2 / 4 s;
//!   byte program 16 / 100 µs (typical / maximum).
//! * One bank: the CPU stalls for the whole operation (RM0090 §3.5), so the
//!   model's clock jumps by the duration and the watchdog, fed before,
//!   is checked after.
//! * A power cut after `n` byte operations: an erase visits the sector's
//!   bytes in an arbitrary (seeded) order, leaves the byte it was on with
//!   random bits, and leaves the rest as they were; a program cut leaves the
//!   byte with a random subset of the bits it was clearing cleared.
//!   Afterwards every operation fails until [`F405Flash::powered_again`].
//!
//! A host-only test double (it allocates): the store's unit tests use it,
//! and so does the fuzz target `coefficient_record` (feature `mock-flash`).

// A test double: indexes its own cell vector at offsets it has checked.
#![allow(clippy::indexing_slicing)]

use std::vec;
use std::vec::Vec;

use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

/// Sector sizes in KiB, sector 0 first (RM0090 Table 5).
pub const SECTOR_KIB: [u32; 12] = [16, 16, 16, 16, 64, 128, 128, 128, 128, 128, 128, 128];

/// Typical or worst-case durations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Timing {
    /// Typical figures.
    Typical,
    /// Maximum figures.
    Worst,
}

/// Erase duration of a sector of `kib` KiB at ×8, µs (DS8626 §6.3.12).
fn erase_us(kib: u32, timing: Timing) -> u64 {
    let (typ_ms, max_ms) = match kib {
        16 => (400, 800),
        64 => (1_200, 2_400),
        _ => (2_000, 4_000),
    };
    1_000 * if timing == Timing::Worst { max_ms } else { typ_ms }
}

/// Byte program duration at ×8, µs (DS8626 §6.3.12).
fn program_us(timing: Timing) -> u64 {
    if timing == Timing::Worst { 100 } else { 16 }
}

/// What went wrong.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashFault {
    /// The power failed (now or earlier).
    PowerCut,
    /// The watchdog reset the chip during a stall.
    WatchdogReset,
    /// A read failed (injected).
    ReadError,
    /// Not a whole sector, or outside the flash.
    Range,
}

impl NorFlashError for FlashFault {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashFault::Range => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// The flash, its clock and the watchdog watching the CPU.
#[derive(Clone)]
pub struct F405Flash {
    data: Vec<u8>,
    /// Durations used.
    pub timing: Timing,
    /// Time, µs.
    pub now_us: u64,
    /// Last watchdog feed, µs.
    pub fed_at_us: u64,
    /// The watchdog's actual timeout (None: not running), µs.
    pub watchdog_us: Option<u64>,
    /// The watchdog fired.
    pub watchdog_fired: bool,
    /// Longest single stall seen, µs.
    pub longest_stall_us: u64,
    /// Byte operations allowed before the power fails (None: never).
    pub cut_after: Option<usize>,
    /// Byte operations done so far.
    pub ops: usize,
    /// Reads that fail (counting from 0 at power-up).
    pub failing_reads: Vec<usize>,
    reads: usize,
    dead: bool,
    rng: u64,
}

impl F405Flash {
    /// An erased chip, typical timing, no watchdog.
    pub fn new(seed: u64) -> Self {
        Self::first_sectors(SECTOR_KIB.len(), seed)
    }

    /// Only sectors `0..n` (the rest of the address space is out of
    /// range): cheaper to clone in tests that cut the power thousands of times.
    pub fn first_sectors(n: usize, seed: u64) -> Self {
        let size: u32 = SECTOR_KIB.iter().take(n).map(|k| k * 1024).sum();
        Self {
            data: vec![0xFF; size as usize],
            timing: Timing::Typical,
            now_us: 0,
            fed_at_us: 0,
            watchdog_us: None,
            watchdog_fired: false,
            longest_stall_us: 0,
            cut_after: None,
            ops: 0,
            failing_reads: Vec::new(),
            reads: 0,
            dead: false,
            rng: seed | 1,
        }
    }

    /// The same cells after the power comes back: no cut pending, counters
    /// reset, a new seed for what happens next.
    pub fn powered_again(&self, seed: u64) -> Self {
        let mut f = Self::first_sectors(0, seed);
        f.data.clone_from(&self.data);
        f.timing = self.timing;
        f.watchdog_us = self.watchdog_us;
        f
    }

    /// The firmware feeds the watchdog.
    pub fn feed(&mut self) {
        self.fed_at_us = self.now_us;
    }

    /// The raw cells.
    pub fn cells(&self) -> &[u8] {
        &self.data
    }

    /// Mutable cells (to corrupt them on purpose).
    pub fn cells_mut(&mut self) -> &mut [u8] {
        &mut self.data
    }

    fn random(&mut self) -> u64 {
        // xorshift64*
        self.rng ^= self.rng >> 12;
        self.rng ^= self.rng << 25;
        self.rng ^= self.rng >> 27;
        self.rng.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    fn alive(&self) -> Result<(), FlashFault> {
        if self.watchdog_fired {
            Err(FlashFault::WatchdogReset)
        } else if self.dead {
            Err(FlashFault::PowerCut)
        } else {
            Ok(())
        }
    }

    /// One byte operation; false when the power fails on it.
    fn spend(&mut self) -> bool {
        if self.cut_after.is_some_and(|n| self.ops >= n) {
            self.dead = true;
            return false;
        }
        self.ops += 1;
        true
    }

    /// The CPU stalls for `us`; the watchdog may fire.
    fn stall(&mut self, us: u64) -> Result<(), FlashFault> {
        self.now_us += us;
        self.longest_stall_us = self.longest_stall_us.max(us);
        if let Some(t) = self.watchdog_us {
            if self.now_us - self.fed_at_us > t {
                self.watchdog_fired = true;
                return Err(FlashFault::WatchdogReset);
            }
        }
        Ok(())
    }

    /// `(start, size)` of each sector, bytes.
    pub fn sectors() -> impl Iterator<Item = (u32, u32)> {
        SECTOR_KIB.iter().scan(0u32, |start, &kib| {
            let s = *start;
            *start += kib * 1024;
            Some((s, kib * 1024))
        })
    }

    fn erase_sector(&mut self, start: u32, size: u32) -> Result<(), FlashFault> {
        // Any order of completion: a seeded permutation of the sector.
        let mut order: Vec<u32> = (0..size).collect();
        for i in (1..order.len()).rev() {
            let j = (self.random() % (i as u64 + 1)) as usize;
            order.swap(i, j);
        }
        for &k in &order {
            let at = (start + k) as usize;
            if !self.spend() {
                // The byte being erased when the power went: some bits set.
                let r = self.random() as u8;
                self.data[at] |= r;
                return Err(FlashFault::PowerCut);
            }
            self.data[at] = 0xFF;
        }
        self.stall(erase_us(size / 1024, self.timing))
    }
}

impl ErrorType for F405Flash {
    type Error = FlashFault;
}

impl ReadNorFlash for F405Flash {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashFault> {
        self.alive()?;
        let n = self.reads;
        self.reads += 1;
        if self.failing_reads.contains(&n) {
            return Err(FlashFault::ReadError);
        }
        let o = offset as usize;
        let src = self.data.get(o..o + bytes.len()).ok_or(FlashFault::Range)?;
        bytes.copy_from_slice(src);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.data.len()
    }
}

impl NorFlash for F405Flash {
    const WRITE_SIZE: usize = 1;
    /// The smallest sector; larger sectors are erased whole, and a range
    /// that does not cover whole sectors is refused (the flash cannot erase
    /// part of one).
    const ERASE_SIZE: usize = 16 * 1024;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashFault> {
        self.alive()?;
        if to as usize > self.data.len() || from >= to {
            return Err(FlashFault::Range);
        }
        let touched: Vec<(u32, u32)> = Self::sectors().filter(|&(s, n)| s < to && s + n > from).collect();
        if touched.first().is_none_or(|&(s, _)| s != from) || touched.last().is_none_or(|&(s, n)| s + n != to) {
            return Err(FlashFault::Range);
        }
        for (s, n) in touched {
            self.erase_sector(s, n)?;
        }
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashFault> {
        self.alive()?;
        if offset as usize + bytes.len() > self.data.len() {
            return Err(FlashFault::Range);
        }
        for (i, &b) in bytes.iter().enumerate() {
            let at = offset as usize + i;
            if !self.spend() {
                // Half-programmed: some of the bits being cleared are.
                let clearing = self.data[at] & !b;
                let r = self.random() as u8;
                self.data[at] &= !(clearing & r);
                return Err(FlashFault::PowerCut);
            }
            self.data[at] &= b;
            self.stall(program_us(self.timing))?;
        }
        Ok(())
    }
}
