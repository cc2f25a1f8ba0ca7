//! The simulated ADC of the QEMU board: an ADS131M04 *device model* behind
//! the same [`SpiDevice`] interface the real driver uses, so the driver, the
//! set/reset sequencing and everything after them run unchanged in
//! emulation. QEMU has no ADC behind its SPI; the field it "measures" comes
//! from the host over USART2 ([`BridgeModel::set_truth`]).
//!
//! The model follows the part's frame protocol: a response one frame late,
//! RESET answered `0xFF24`, RREG/WREG on a register file, CRC-16-CCITT on
//! every output frame, 24-bit codes clamped to the converter's range. The
//! bridge output flips sign with the last strap pulse, as the HMC100x does.

// Indexing below is into the fixed 18-byte frame at const offsets; the
// bytes from the bus are only ever values.
#![allow(clippy::indexing_slicing)]

use core::cell::Cell;
use core::convert::Infallible;

use critical_section::Mutex;
use embedded_hal::digital::{ErrorType as PinErrorType, OutputPin};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

use crate::acquisition::Polarity;
use crate::adc::{cmd, CRC16, FRAME_BYTES, FULL_SCALE_COUNTS, WORD};

#[derive(Debug, Clone, Copy)]
struct State {
    field_counts: [f32; 3],
    offset_counts: [f32; 3],
    polarity: Polarity,
    updates: u32,
    seq: u32,
}

/// The magnetic truth the simulated bridges see, shared between the feed
/// (USART2) and the simulated ADC.
pub struct BridgeModel {
    state: Mutex<Cell<State>>,
}

impl Default for BridgeModel {
    fn default() -> Self {
        Self::new()
    }
}

impl BridgeModel {
    /// Zero field, zero offset.
    pub const fn new() -> Self {
        Self {
            state: Mutex::new(Cell::new(State { field_counts: [0.0; 3], offset_counts: [0.0; 3], polarity: Polarity::Set, updates: 0, seq: 0 })),
        }
    }

    /// Sets the field (bridge output × sensitivity, counts) and the bridge
    /// offsets the next conversions will show.
    pub fn set_truth(&self, field_counts: [f32; 3], offset_counts: [f32; 3]) {
        self.set_truth_seq(field_counts, offset_counts, 0);
    }

    /// [`BridgeModel::set_truth`], tagged with the feed frame's sequence number.
    pub fn set_truth_seq(&self, field_counts: [f32; 3], offset_counts: [f32; 3], seq: u32) {
        critical_section::with(|cs| {
            let cell = self.state.borrow(cs);
            let mut s = cell.get();
            s.field_counts = field_counts;
            s.offset_counts = offset_counts;
            s.updates = s.updates.wrapping_add(1);
            s.seq = seq;
            cell.set(s);
        });
    }

    /// The sequence number of the feed frame in force.
    pub fn seq(&self) -> u32 {
        critical_section::with(|cs| self.state.borrow(cs).get().seq)
    }

    /// How many truth updates have arrived.
    pub fn updates(&self) -> u32 {
        critical_section::with(|cs| self.state.borrow(cs).get().updates)
    }

    fn set_polarity(&self, p: Polarity) {
        critical_section::with(|cs| {
            let cell = self.state.borrow(cs);
            let mut s = cell.get();
            s.polarity = p;
            cell.set(s);
        });
    }

    fn snapshot(&self) -> State {
        critical_section::with(|cs| self.state.borrow(cs).get())
    }
}

/// A strap GPIO of the simulated board: driving it high pulses the strap.
pub struct StrapPinModel {
    sensor: &'static BridgeModel,
    polarity: Polarity,
}

impl StrapPinModel {
    /// The SET pulse pin.
    pub fn set(sensor: &'static BridgeModel) -> Self {
        Self { sensor, polarity: Polarity::Set }
    }
    /// The RESET pulse pin.
    pub fn reset(sensor: &'static BridgeModel) -> Self {
        Self { sensor, polarity: Polarity::Reset }
    }
}

impl PinErrorType for StrapPinModel {
    type Error = Infallible;
}

impl OutputPin for StrapPinModel {
    fn set_high(&mut self) -> Result<(), Infallible> {
        self.sensor.set_polarity(self.polarity);
        Ok(())
    }
    fn set_low(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// Power-on register file of the ADS131M04 (ID, STATUS, MODE, CLOCK, GAIN1).
const POWER_ON: [(u8, u16); 5] = [(0x00, 0x2410), (0x01, 0x0500), (0x02, 0x0510), (0x03, 0x0F0E), (0x04, 0x0000)];

/// The simulated ADS131M04.
pub struct Ads131m04Model {
    sensor: &'static BridgeModel,
    regs: [u16; 64],
    pending: u16,
    frames: u32,
}

impl Ads131m04Model {
    /// A device just powered on.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        let mut adc = Self { sensor, regs: [0; 64], pending: 0, frames: 0 };
        adc.power_on();
        adc
    }

    fn power_on(&mut self) {
        self.regs = [0; 64];
        for (a, v) in POWER_ON {
            if let Some(r) = self.regs.get_mut(usize::from(a)) {
                *r = v;
            }
        }
        self.pending = self.status();
    }

    fn status(&self) -> u16 {
        // DRDY3..0 set: a conversion is always ready.
        self.regs.get(1).copied().unwrap_or(0) | 0x000F
    }

    /// Frames exchanged so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// One frame: answers with the pending response and the channels, then
    /// executes `tx`'s command.
    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) {
        let s = self.sensor.snapshot();
        let sign = match s.polarity {
            Polarity::Set => 1.0,
            Polarity::Reset => -1.0,
        };
        let mut out = [0u8; FRAME_BYTES];
        out[..2].copy_from_slice(&self.pending.to_be_bytes());
        for k in 0..4 {
            let v = match (s.offset_counts.get(k), s.field_counts.get(k)) {
                (Some(o), Some(f)) => o + sign * f,
                _ => 0.0,
            };
            let code = clamp_code(v);
            let b = code.to_be_bytes();
            out[WORD * (k + 1)..WORD * (k + 2)].copy_from_slice(&b[1..4]);
        }
        let crc = CRC16.checksum(&out[..WORD * 5]);
        out[WORD * 5..WORD * 5 + 2].copy_from_slice(&crc.to_be_bytes());
        for (d, s) in rx.iter_mut().zip(out.iter()) {
            *d = *s;
        }
        self.frames = self.frames.wrapping_add(1);

        let word = |w: usize| match (tx.get(WORD * w), tx.get(WORD * w + 1)) {
            (Some(&h), Some(&l)) => u16::from_be_bytes([h, l]),
            _ => 0,
        };
        let command = word(0);
        let addr = usize::from((command >> 7) & 0x3F);
        self.pending = if command == cmd::RESET {
            self.power_on();
            cmd::RESET_OK
        } else if command & 0xE000 == cmd::RREG {
            self.regs.get(addr).copied().unwrap_or(0)
        } else if command & 0xE000 == cmd::WREG {
            if let Some(r) = self.regs.get_mut(addr) {
                *r = word(1);
            }
            0x4000 | (command & 0x1F80)
        } else {
            self.status()
        };
    }
}

/// A 24-bit code from a value, rounded and clamped to the converter's range.
fn clamp_code(v: f32) -> i32 {
    let max = (FULL_SCALE_COUNTS - 1) as f32;
    let min = -(FULL_SCALE_COUNTS as f32);
    if v.is_nan() {
        return 0;
    }
    let c = v.clamp(min, max);
    // Round half away from zero without std.
    (if c >= 0.0 { c + 0.5 } else { c - 0.5 }) as i32
}

impl ErrorType for Ads131m04Model {
    type Error = Infallible;
}

impl SpiDevice for Ads131m04Model {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        for op in operations.iter_mut() {
            match op {
                Operation::Transfer(rx, tx) => self.exchange(tx, rx),
                Operation::TransferInPlace(buf) => {
                    let mut tx = [0u8; FRAME_BYTES];
                    for (d, s) in tx.iter_mut().zip(buf.iter()) {
                        *d = *s;
                    }
                    self.exchange(&tx, buf);
                }
                Operation::Write(tx) => self.exchange(tx, &mut []),
                Operation::Read(rx) => self.exchange(&[], rx),
                Operation::DelayNs(_) => {}
            }
        }
        Ok(())
    }
}

/// The QEMU board's sensor feed (USART2): frames from the host that set what
/// the modelled bridges see. The body of the firmware's `feed` task.
pub struct FeedReceiver {
    decoder: magcal_protocol::FrameDecoder,
    offsets: [f32; 3],
}

impl Default for FeedReceiver {
    fn default() -> Self {
        Self::new()
    }
}

impl FeedReceiver {
    /// A receiver with no frame yet (bridge offsets zero).
    pub const fn new() -> Self {
        Self { decoder: magcal_protocol::FrameDecoder::new(), offsets: [0.0; 3] }
    }

    /// One byte from USART2. A complete, valid [`magcal_protocol::SensorFeed`]
    /// frame sets `bridges` (field converted with the chain gain, offsets
    /// kept when the frame leaves them out) and returns its sequence number;
    /// damaged frames are ignored.
    pub fn on_byte(&mut self, byte: u8, bridges: &BridgeModel) -> Option<u32> {
        let Some(Ok(body)) = self.decoder.push(byte) else { return None };
        let f = magcal_protocol::decode_body::<magcal_protocol::SensorFeed>(body).ok()?;
        if let Some(o) = f.offset_counts {
            self.offsets = o;
        }
        let g = crate::acquisition::COUNTS_PER_NT;
        bridges.set_truth_seq(f.field_nt.map(|v| v * g), self.offsets, f.seq);
        Some(f.seq)
    }
}

#[cfg(test)]
mod feed_tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use magcal_protocol::{encode, SensorFeed, MAX_FRAME_LEN};

    fn frame(f: &SensorFeed) -> ([u8; MAX_FRAME_LEN], usize) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(f, &mut buf).unwrap();
        (buf, n)
    }

    #[test]
    fn feed_frames_set_the_bridges_and_damage_is_ignored() {
        static BRIDGES: BridgeModel = BridgeModel::new();
        let mut rx = FeedReceiver::new();
        let (a, n) = frame(&SensorFeed { seq: 5, field_nt: [1000.0, -2000.0, 500.0], offset_counts: Some([10.0, 20.0, 30.0]) });
        let got: Vec<Option<u32>> = a[..n].iter().map(|&b| rx.on_byte(b, &BRIDGES)).collect();
        assert_eq!(got.iter().flatten().copied().collect::<Vec<_>>(), vec![5]);
        assert_eq!((BRIDGES.seq(), BRIDGES.updates()), (5, 1));
        // A damaged frame changes nothing; the next good one, without
        // offsets, keeps the previous offsets.
        let (mut b, n) = frame(&SensorFeed { seq: 6, field_nt: [0.0; 3], offset_counts: None });
        b[3] ^= 0x40;
        assert!(b[..n].iter().all(|&x| rx.on_byte(x, &BRIDGES).is_none()));
        assert_eq!((BRIDGES.seq(), BRIDGES.updates()), (5, 1));
        let (c, n) = frame(&SensorFeed { seq: 7, field_nt: [0.0; 3], offset_counts: None });
        assert_eq!(c[..n].iter().filter_map(|&x| rx.on_byte(x, &BRIDGES)).last(), Some(7));
        assert_eq!(rx.offsets, [10.0, 20.0, 30.0]);
    }
}
