//! Power-cut-safe coefficient store on two flash sectors (A/B).
//!
//! Each sector holds at most one record:
//!
//! ```text
//! offset 0   commit slot (8 bytes): magic "MCAL" LE u32, then 0x0000_0000
//! offset 8   version u16, payload length u16, sequence u32
//! offset 16  payload (postcard bytes), padded to the write size with 0xFF
//! then       CRC-32 of version ‖ length ‖ sequence ‖ payload
//! ```
//!
//! A save goes to the sector that does *not* hold the newest valid record:
//! erase it, write the body, and only then write the commit slot. A power cut
//! at any byte before the commit slot is complete leaves a sector without a
//! valid magic, so the other sector's record stays the newest; a cut during
//! the erase leaves either the older record or garbage that fails its CRC.
//! Loading picks the valid record with the highest sequence number. The old
//! or the new set, never a mix.
//!
//! A flash read that fails is not "no record": [`Store::load`] reports it,
//! and [`Store::save`] refuses to write rather than guess which sector is
//! free (guessing could erase the newest set). Every save is read back and
//! checked before it counts.
//!
//! Why not `sequential-storage`: its map gives the same old-or-new
//! guarantee over `embedded-storage`, but its API is async (the flash here is
//! blocking), it needs more flash pages for its own bookkeeping, and one
//! fixed-size record written rarely does not need wear levelling. The A/B
//! store is under 200 lines with its power-cut tests (`store/tests.rs`) on
//! a datasheet model of the F405's flash (`store/f405_flash.rs`, a test
//! double shared with the fuzz target through the `mock-flash` feature, as
//! sequential-storage shares its mock flash with its fuzzers).

// Indexing below is into fixed-size header/body buffers at fixed offsets;
// lengths read from flash are bounded before use.
#![allow(clippy::indexing_slicing)]

use embedded_storage::nor_flash::NorFlash;

/// Commit marker.
pub const MAGIC: u32 = 0x4C41_434D; // "MCAL" little-endian
/// Record format version: 2 since the payload (the protocol's
/// `Coefficients`) carries the current and temperature terms, 3 since it
/// carries the reference inclination. Records of versions 1 and 2 still
/// load (`device::decode_coefficients` reads them without what they lack);
/// a save always writes this version.
pub const VERSION: u16 = 3;
/// The oldest record version still read.
pub const OLDEST_VERSION: u16 = 1;
/// Largest payload stored: an encoded coefficient set
/// ([`magcal_protocol::Coefficients::MAX_ENCODED_LEN`], 108 bytes; a
/// version-1 or -2 record's set is shorter).
pub const MAX_PAYLOAD: usize = magcal_protocol::Coefficients::MAX_ENCODED_LEN;
const HEADER: usize = 16;
// Bit by bit, as the protocol's (no 1 KiB table in flash for a rare save).
const CRC32: crc::Crc<u32, crc::NoTable> = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// Why the store failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum StoreError {
    /// The flash reported an error (or the power failed).
    Flash,
    /// The payload is larger than [`MAX_PAYLOAD`].
    TooLarge,
    /// The sectors are not usable (misaligned or too small).
    Layout,
    /// The record written does not read back as written.
    Verify,
}

/// A record read back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// Sequence number (grows by one per save).
    pub seq: u32,
    /// Which sector (0 = A, 1 = B).
    pub sector: u8,
    /// The record's format version ([`OLDEST_VERSION`] ..= [`VERSION`]).
    pub version: u16,
    /// The payload.
    pub payload: heapless::Vec<u8, MAX_PAYLOAD>,
}

/// Two sectors of a [`NorFlash`].
#[derive(Debug)]
pub struct Store<F> {
    flash: F,
    sectors: [u32; 2],
    sector_size: u32,
}

fn round_up(n: usize, to: usize) -> usize {
    n.div_ceil(to.max(1)) * to.max(1)
}

impl<F: NorFlash> Store<F> {
    /// A store on the sectors at offsets `a` and `b` (each `sector_size`
    /// bytes, a multiple of the erase size).
    pub fn new(flash: F, a: u32, b: u32, sector_size: u32) -> Result<Self, StoreError> {
        let erase = F::ERASE_SIZE as u32;
        let need = round_up(HEADER + MAX_PAYLOAD + 4, F::WRITE_SIZE.max(8)) as u32;
        let aligned = |o: u32| erase != 0 && o.is_multiple_of(erase);
        if !aligned(a) || !aligned(b) || !sector_size.is_multiple_of(erase.max(1)) || sector_size < need || a.abs_diff(b) < sector_size {
            return Err(StoreError::Layout);
        }
        if (a.max(b) as usize) + sector_size as usize > flash.capacity() {
            return Err(StoreError::Layout);
        }
        Ok(Self { flash, sectors: [a, b], sector_size })
    }

    /// Gives the flash back.
    pub fn release(self) -> F {
        self.flash
    }

    /// The record in one sector: `Ok(None)` if it holds no valid record,
    /// an error if the flash could not be read.
    fn read_sector(&mut self, index: u8) -> Result<Option<Record>, StoreError> {
        let Some(&base) = self.sectors.get(usize::from(index)) else { return Err(StoreError::Layout) };
        let mut head = [0u8; HEADER];
        self.flash.read(base, &mut head).map_err(|_| StoreError::Flash)?;
        let magic = u32::from_le_bytes([head[0], head[1], head[2], head[3]]);
        if magic != MAGIC || head[4..8] != [0, 0, 0, 0] {
            return Ok(None);
        }
        let version = u16::from_le_bytes([head[8], head[9]]);
        let len = usize::from(u16::from_le_bytes([head[10], head[11]]));
        let seq = u32::from_le_bytes([head[12], head[13], head[14], head[15]]);
        if !(OLDEST_VERSION..=VERSION).contains(&version) || len > MAX_PAYLOAD {
            return Ok(None);
        }
        let mut buf = [0u8; MAX_PAYLOAD + 4];
        let body = &mut buf[..len + 4];
        self.flash.read(base + HEADER as u32, body).map_err(|_| StoreError::Flash)?;
        let (payload, crc) = body.split_at(len);
        let mut digest = CRC32.digest();
        digest.update(&head[8..16]);
        digest.update(payload);
        if digest.finalize() != u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]) {
            return Ok(None);
        }
        Ok(heapless::Vec::from_slice(payload).ok().map(|payload| Record { seq, sector: index, version, payload }))
    }

    /// The newest valid record (`Ok(None)` when neither sector holds one).
    /// A failed flash read is an error, never taken for an empty sector.
    pub fn load(&mut self) -> Result<Option<Record>, StoreError> {
        let a = self.read_sector(0)?;
        let b = self.read_sector(1)?;
        Ok(match (a, b) {
            (Some(a), Some(b)) => Some(if b.seq.wrapping_sub(a.seq) as i32 > 0 { b } else { a }),
            (a, b) => a.or(b),
        })
    }

    /// Saves a payload as the newest record; returns its sequence number.
    pub fn save(&mut self, payload: &[u8]) -> Result<u32, StoreError> {
        self.save_version(payload, VERSION)
    }

    /// [`Store::save`] with the record version given (tests write records
    /// of an older firmware).
    fn save_version(&mut self, payload: &[u8], version: u16) -> Result<u32, StoreError> {
        if payload.len() > MAX_PAYLOAD {
            return Err(StoreError::TooLarge);
        }
        // A read error here must not be taken for "empty": saving to sector 0
        // with sequence 1 could erase the newest set.
        let current = self.load()?;
        let (target, seq) = match &current {
            Some(r) => (1 - r.sector, r.seq.wrapping_add(1)),
            None => (0, 1),
        };
        let base = self.sectors[usize::from(target)];
        self.flash.erase(base, base + self.sector_size).map_err(|_| StoreError::Flash)?;
        // Body: version, length, sequence, payload, CRC — padded to the write size.
        let mut body = [0xFFu8; 8 + MAX_PAYLOAD + 4 + 16];
        body[0..2].copy_from_slice(&version.to_le_bytes());
        body[2..4].copy_from_slice(&(payload.len() as u16).to_le_bytes());
        body[4..8].copy_from_slice(&seq.to_le_bytes());
        body[8..8 + payload.len()].copy_from_slice(payload);
        let mut digest = CRC32.digest();
        digest.update(&body[..8 + payload.len()]);
        let crc = digest.finalize();
        body[8 + payload.len()..12 + payload.len()].copy_from_slice(&crc.to_le_bytes());
        let len = round_up(12 + payload.len(), F::WRITE_SIZE);
        let chunk = body.get(..len).ok_or(StoreError::TooLarge)?;
        self.flash.write(base + 8, chunk).map_err(|_| StoreError::Flash)?;
        // Commit.
        let mut slot = [0u8; 8];
        slot[..4].copy_from_slice(&MAGIC.to_le_bytes());
        self.flash.write(base, &slot).map_err(|_| StoreError::Flash)?;
        // Read back: the set counts only if it is there, whole.
        match self.read_sector(target)? {
            Some(r) if r.seq == seq && r.version == version && r.payload.as_slice() == payload => Ok(seq),
            _ => Err(StoreError::Verify),
        }
    }
}

/// A RAM-backed NOR flash: the QEMU board's store (QEMU models no flash
/// controller) and the tests'. Programs like NOR: bits only go 1 → 0.
#[derive(Debug)]
pub struct RamFlash<const N: usize, const SECTOR: usize> {
    data: [u8; N],
}

impl<const N: usize, const SECTOR: usize> Default for RamFlash<N, SECTOR> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const SECTOR: usize> RamFlash<N, SECTOR> {
    /// Erased.
    pub const fn new() -> Self {
        Self { data: [0xFF; N] }
    }
}

/// RAM flash errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RamFlashError {
    /// Outside the array or misaligned.
    OutOfBounds,
}

impl embedded_storage::nor_flash::NorFlashError for RamFlashError {
    fn kind(&self) -> embedded_storage::nor_flash::NorFlashErrorKind {
        embedded_storage::nor_flash::NorFlashErrorKind::OutOfBounds
    }
}

impl<const N: usize, const SECTOR: usize> embedded_storage::nor_flash::ErrorType for RamFlash<N, SECTOR> {
    type Error = RamFlashError;
}

impl<const N: usize, const SECTOR: usize> embedded_storage::nor_flash::ReadNorFlash for RamFlash<N, SECTOR> {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamFlashError> {
        let o = offset as usize;
        let src = self.data.get(o..o + bytes.len()).ok_or(RamFlashError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }
    fn capacity(&self) -> usize {
        N
    }
}

impl<const N: usize, const SECTOR: usize> NorFlash for RamFlash<N, SECTOR> {
    const WRITE_SIZE: usize = 1;
    const ERASE_SIZE: usize = SECTOR;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), RamFlashError> {
        let r = self.data.get_mut(from as usize..to as usize).ok_or(RamFlashError::OutOfBounds)?;
        r.fill(0xFF);
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamFlashError> {
        let o = offset as usize;
        let dst = self.data.get_mut(o..o + bytes.len()).ok_or(RamFlashError::OutOfBounds)?;
        for (d, s) in dst.iter_mut().zip(bytes) {
            *d &= *s;
        }
        Ok(())
    }
}

#[cfg(any(test, feature = "mock-flash"))]
pub mod f405_flash;
#[cfg(test)]
pub(crate) mod tests;
