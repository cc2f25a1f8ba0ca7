//! Driver for the Texas Instruments ADS131M04: 4-channel, simultaneously
//! sampling, 24-bit delta-sigma ADC on SPI (datasheet SBAS890).
//!
//! The driver owns its bus as an embedded-hal 1.0 [`SpiDevice`] (chip select
//! is the device's business) and speaks the part's frame protocol:
//!
//! * SPI mode 1, 24-bit words (the power-on word length); 16-bit commands and
//!   register values are left-justified in a word;
//! * a frame is 6 words: command (or response), four channel words, CRC;
//! * the device answers a command in the *next* frame (RREG's value, WREG's
//!   acknowledgement, RESET's `0xFF24`); a NULL command returns STATUS;
//! * every output frame ends with a CRC-16-CCITT (0x1021, seed 0xFFFF) over the
//!   words before it, checked here before any data is used.
//!
//! Errors are `Error<SpiError>`: bus errors pass through, everything the
//! device says that does not make sense becomes a typed error.

// Indexing below uses frame positions bounded by the const frame layout; no
// index is derived from received data.
#![allow(clippy::indexing_slicing)]

use embedded_hal::spi::{Operation, SpiDevice};

/// Bytes per word (24-bit word length).
pub const WORD: usize = 3;
/// Words per frame: command/response, four channels, CRC.
pub const FRAME_WORDS: usize = 6;
/// Bytes per frame.
pub const FRAME_BYTES: usize = WORD * FRAME_WORDS;

/// Commands (datasheet §8.5.1).
pub mod cmd {
    /// No operation; the response is STATUS.
    pub const NULL: u16 = 0x0000;
    /// Reset the device.
    pub const RESET: u16 = 0x0011;
    /// Enter standby.
    pub const STANDBY: u16 = 0x0022;
    /// Leave standby.
    pub const WAKEUP: u16 = 0x0033;
    /// Read registers: `101a aaaa annn nnnn`.
    pub const RREG: u16 = 0xA000;
    /// Write registers: `011a aaaa annn nnnn`.
    pub const WREG: u16 = 0x6000;
    /// The response to RESET on a 4-channel part.
    pub const RESET_OK: u16 = 0xFF24;
}

/// Register addresses (datasheet §8.6).
pub mod reg {
    /// Device ID (`0x24xx` on the ADS131M04).
    pub const ID: u8 = 0x00;
    /// Status.
    pub const STATUS: u8 = 0x01;
    /// Mode.
    pub const MODE: u8 = 0x02;
    /// Clock: channel enables, OSR, power mode.
    pub const CLOCK: u8 = 0x03;
    /// PGA gains of channels 0–3.
    pub const GAIN1: u8 = 0x04;
    /// Global configuration.
    pub const CFG: u8 = 0x06;
}

/// Full-scale code: ±2²³.
pub const FULL_SCALE_COUNTS: i32 = 1 << 23;
/// Internal reference: the input range is ±1.2 V / gain.
pub const REFERENCE_V: f32 = 1.2;
/// Modulator clock in high-resolution mode for a CLKIN of `clkin_hz`:
/// f_CLKIN / 2 (SBAS890 §8.4.1). The board's CLKIN is
/// [`crate::clocks::ADC_CLKIN_HZ`]; the driver takes it as an argument.
pub const fn modulator_hz(clkin_hz: u32) -> u32 {
    clkin_hz / 2
}

/// Why a transaction failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Error<E> {
    /// The SPI bus failed.
    Spi(E),
    /// The output frame's CRC does not match its contents.
    Crc {
        /// CRC computed over the frame.
        computed: u16,
        /// CRC the device sent.
        received: u16,
    },
    /// The device answered a command with something else.
    UnexpectedResponse {
        /// What was expected.
        expected: u16,
        /// What came.
        got: u16,
    },
    /// The ID register does not identify an ADS131M04.
    WrongDevice {
        /// The ID read.
        id: u16,
    },
}

/// Oversampling ratio (sets the data rate `f_MOD / OSR`, [`modulator_hz`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Osr {
    /// 128 → 31.25 kSPS with the board's 8 MHz CLKIN (32 kSPS at 8.192 MHz).
    X128 = 0,
    /// 256 → 16 kSPS.
    X256 = 1,
    /// 512 → 8 kSPS.
    X512 = 2,
    /// 1024 → 4 kSPS (power-on default).
    X1024 = 3,
    /// 2048 → 2 kSPS.
    X2048 = 4,
    /// 4096 → 1 kSPS.
    X4096 = 5,
}

impl Osr {
    /// Output data rate with a CLKIN of `clkin_hz`, samples per second.
    pub fn data_rate_hz(self, clkin_hz: u32) -> u32 {
        modulator_hz(clkin_hz) / (128u32 << (self as u32))
    }

    /// One conversion period with a CLKIN of `clkin_hz`, ns.
    pub fn conversion_period_ns(self, clkin_hz: u32) -> u32 {
        ((128u64 << (self as u32)) * 1_000_000_000 / u64::from(modulator_hz(clkin_hz))) as u32
    }
}

/// PGA gain (1 … 128).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Gain {
    /// ×1: ±1.2 V.
    X1 = 0,
    /// ×2.
    X2 = 1,
    /// ×4.
    X4 = 2,
    /// ×8.
    X8 = 3,
    /// ×16.
    X16 = 4,
    /// ×32.
    X32 = 5,
    /// ×64.
    X64 = 6,
    /// ×128.
    X128 = 7,
}

impl Gain {
    /// The factor.
    pub fn factor(self) -> u32 {
        1 << (self as u32)
    }
}

/// One conversion of the four channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Conversion {
    /// The STATUS word (or the response to the previous command).
    pub response: u16,
    /// Channel codes, sign-extended from 24 bits.
    pub channels: [i32; 4],
}

/// CRC-16-CCITT as the ADS131M04 computes it.
pub const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

/// Builds an input frame with `command` and optional register data words.
pub fn command_frame(command: u16, data: &[u16]) -> [u8; FRAME_BYTES] {
    let mut f = [0u8; FRAME_BYTES];
    let [hi, lo] = command.to_be_bytes();
    f[0] = hi;
    f[1] = lo;
    for (w, value) in data.iter().take(FRAME_WORDS - 2).enumerate() {
        let [hi, lo] = value.to_be_bytes();
        f[WORD * (w + 1)] = hi;
        f[WORD * (w + 1) + 1] = lo;
    }
    f
}

/// A 16-bit value left-justified in word `w` of a frame.
fn word16(frame: &[u8; FRAME_BYTES], w: usize) -> u16 {
    u16::from_be_bytes([frame[WORD * w], frame[WORD * w + 1]])
}

/// A 24-bit two's-complement channel word, sign-extended.
fn word24(frame: &[u8; FRAME_BYTES], w: usize) -> i32 {
    let b = [frame[WORD * w], frame[WORD * w + 1], frame[WORD * w + 2]];
    (i32::from_be_bytes([b[0], b[1], b[2], 0])) >> 8
}

/// Decodes and checks an output frame.
pub fn decode_frame<E>(frame: &[u8; FRAME_BYTES]) -> Result<Conversion, Error<E>> {
    let computed = CRC16.checksum(&frame[..WORD * (FRAME_WORDS - 1)]);
    let received = word16(frame, FRAME_WORDS - 1);
    if computed != received {
        return Err(Error::Crc { computed, received });
    }
    Ok(Conversion { response: word16(frame, 0), channels: [word24(frame, 1), word24(frame, 2), word24(frame, 3), word24(frame, 4)] })
}

/// The ADS131M04 on an SPI bus.
#[derive(Debug)]
pub struct Ads131m04<SPI> {
    spi: SPI,
}

impl<SPI: SpiDevice> Ads131m04<SPI> {
    /// The driver; talks to the device only when asked.
    pub fn new(spi: SPI) -> Self {
        Self { spi }
    }

    /// Gives the bus back.
    pub fn release(self) -> SPI {
        self.spi
    }

    /// One full-duplex frame: sends `tx`, returns the checked response.
    fn frame(&mut self, tx: [u8; FRAME_BYTES]) -> Result<Conversion, Error<SPI::Error>> {
        let mut rx = [0u8; FRAME_BYTES];
        self.spi.transaction(&mut [Operation::Transfer(&mut rx, &tx)]).map_err(Error::Spi)?;
        decode_frame(&rx)
    }

    /// Resets the device and checks its `0xFF24` acknowledgement.
    pub fn reset(&mut self) -> Result<(), Error<SPI::Error>> {
        self.frame(command_frame(cmd::RESET, &[]))?;
        let ack = self.frame(command_frame(cmd::NULL, &[]))?.response;
        if ack != cmd::RESET_OK {
            return Err(Error::UnexpectedResponse { expected: cmd::RESET_OK, got: ack });
        }
        Ok(())
    }

    /// Reads one register.
    pub fn read_register(&mut self, address: u8) -> Result<u16, Error<SPI::Error>> {
        self.frame(command_frame(cmd::RREG | (u16::from(address & 0x3F) << 7), &[]))?;
        Ok(self.frame(command_frame(cmd::NULL, &[]))?.response)
    }

    /// Writes one register and checks the acknowledgement `010a aaaa a000 0000`.
    pub fn write_register(&mut self, address: u8, value: u16) -> Result<(), Error<SPI::Error>> {
        let a = u16::from(address & 0x3F) << 7;
        self.frame(command_frame(cmd::WREG | a, &[value]))?;
        let ack = self.frame(command_frame(cmd::NULL, &[]))?.response;
        let expected = 0x4000 | a;
        if ack != expected {
            return Err(Error::UnexpectedResponse { expected, got: ack });
        }
        Ok(())
    }

    /// Checks that the part is an ADS131M04 (ID `0x24xx`).
    pub fn verify_id(&mut self) -> Result<u16, Error<SPI::Error>> {
        let id = self.read_register(reg::ID)?;
        if id >> 8 != 0x24 {
            return Err(Error::WrongDevice { id });
        }
        Ok(id)
    }

    /// Resets, identifies and configures: channels 0–2 on (3 off), the given
    /// OSR in high-resolution mode, the same PGA gain on every channel.
    pub fn configure(&mut self, osr: Osr, gain: Gain) -> Result<(), Error<SPI::Error>> {
        self.reset()?;
        self.verify_id()?;
        // CLOCK: CH3..CH0_EN (bits 11:8; CH3 reads the thermistor), OSR
        // (bits 4:2), PWR = high resolution (0b10).
        self.write_register(reg::CLOCK, 0x0F00 | ((osr as u16) << 2) | 0b10)?;
        let g = gain as u16;
        self.write_register(reg::GAIN1, g | (g << 4) | (g << 8) | (g << 12))?;
        Ok(())
    }

    /// Reads the latest conversion (a NULL frame).
    pub fn read(&mut self) -> Result<Conversion, Error<SPI::Error>> {
        self.frame(command_frame(cmd::NULL, &[]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_hal_mock::eh1::spi::{Mock, Transaction};

    /// An output frame as the device would send it.
    fn out_frame(response: u16, ch: [i32; 4]) -> Vec<u8> {
        let mut f = vec![0u8; FRAME_BYTES];
        f[0..2].copy_from_slice(&response.to_be_bytes());
        for (i, c) in ch.iter().enumerate() {
            let b = c.to_be_bytes();
            f[WORD * (i + 1)..WORD * (i + 2)].copy_from_slice(&b[1..4]);
        }
        let crc = CRC16.checksum(&f[..15]);
        f[15..17].copy_from_slice(&crc.to_be_bytes());
        f
    }

    fn xfer(tx: [u8; FRAME_BYTES], rx: Vec<u8>) -> Vec<Transaction<u8>> {
        vec![Transaction::transaction_start(), Transaction::transfer(tx.to_vec(), rx), Transaction::transaction_end()]
    }

    #[test]
    fn crc_is_ccitt_false_as_in_the_datasheet() {
        // CRC-16-CCITT, seed 0xFFFF, polynomial 0x1021: check value 0x29B1.
        assert_eq!(CRC16.checksum(b"123456789"), 0x29B1);
    }

    #[test]
    fn configure_sends_the_datasheet_sequence() {
        let idle = out_frame(0x0500, [0; 4]);
        let mut expect = Vec::new();
        expect.extend(xfer(command_frame(cmd::RESET, &[]), idle.clone()));
        expect.extend(xfer(command_frame(cmd::NULL, &[]), out_frame(cmd::RESET_OK, [0; 4])));
        expect.extend(xfer(command_frame(0xA000, &[]), idle.clone()));
        expect.extend(xfer(command_frame(cmd::NULL, &[]), out_frame(0x2410, [0; 4])));
        // CLOCK = 0x0F02: CH3..CH0 on (SBAS890 §8.6 CLOCK bits 11:8), OSR 128 (0), HR; ack 0x4000 | 0x03 << 7 = 0x4180.
        expect.extend(xfer(command_frame(0x6000 | (0x03 << 7), &[0x0F02]), idle.clone()));
        expect.extend(xfer(command_frame(cmd::NULL, &[]), out_frame(0x4180, [0; 4])));
        // GAIN1 = 0 (×1 everywhere); ack 0x4200.
        expect.extend(xfer(command_frame(0x6000 | (0x04 << 7), &[0x0000]), idle.clone()));
        expect.extend(xfer(command_frame(cmd::NULL, &[]), out_frame(0x4200, [0; 4])));
        let mut spi = Mock::new(&expect);
        let mut adc = Ads131m04::new(spi.clone());
        adc.configure(Osr::X128, Gain::X1).unwrap();
        spi.done();
    }

    #[test]
    fn conversions_are_sign_extended_and_crc_checked() {
        let ch = [-1, FULL_SCALE_COUNTS - 1, -FULL_SCALE_COUNTS, 123_456];
        let mut bad = out_frame(0x050F, [1, 2, 3, 4]);
        bad[5] ^= 1;
        let mut expect = xfer(command_frame(cmd::NULL, &[]), out_frame(0x050F, ch));
        expect.extend(xfer(command_frame(cmd::NULL, &[]), bad));
        let mut spi = Mock::new(&expect);
        let mut adc = Ads131m04::new(spi.clone());
        let c = adc.read().unwrap();
        assert_eq!(c.channels, ch);
        assert_eq!(c.response, 0x050F);
        assert!(matches!(adc.read(), Err(Error::Crc { .. })));
        spi.done();
    }

    #[test]
    fn a_wrong_part_or_a_failed_reset_is_reported() {
        let idle = out_frame(0, [0; 4]);
        let mut expect = xfer(command_frame(cmd::RESET, &[]), idle.clone());
        expect.extend(xfer(command_frame(cmd::NULL, &[]), out_frame(0x0011, [0; 4])));
        expect.extend(xfer(command_frame(0xA000, &[]), idle.clone()));
        expect.extend(xfer(command_frame(cmd::NULL, &[]), out_frame(0x2810, [0; 4])));
        let mut spi = Mock::new(&expect);
        let mut adc = Ads131m04::new(spi.clone());
        assert_eq!(adc.reset(), Err(Error::UnexpectedResponse { expected: 0xFF24, got: 0x0011 }));
        assert_eq!(adc.verify_id(), Err(Error::WrongDevice { id: 0x2810 }));
        spi.done();
    }

    #[test]
    fn data_rates_follow_the_osr() {
        // SBAS890 Table 8-2 scaled from 8.192 MHz to the board's 8 MHz CLKIN.
        assert_eq!(Osr::X128.data_rate_hz(8_000_000), 31_250);
        assert_eq!(Osr::X1024.data_rate_hz(8_000_000), 3_906);
        assert_eq!(Osr::X128.conversion_period_ns(8_000_000), 32_000);
        // The table's own nominal CLKIN, 8.192 MHz: 32 kSPS at OSR 128.
        assert_eq!(Osr::X128.data_rate_hz(8_192_000), 32_000);
        assert_eq!(Gain::X32.factor(), 32);
    }
}
