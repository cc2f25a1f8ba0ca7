//! The simulated front end of the QEMU board and of the host tests: an
//! ADS131M04 *device model* behind the same [`SpiDevice`] the driver uses,
//! its DRDY pin, the HMC100x set/reset straps, and the time they share.
//!
//! Written from the ADS131M04 datasheet (TI SBAS890) and the HMC1001/1002
//! datasheet with its **own** constants; it imports nothing from the driver
//! (`adc`) or the acquisition, so a misreading of the datasheet on one side
//! is not mirrored on the other.
//!
//! What it models:
//!
//! * **Time.** A virtual clock in ns, advanced by SPI frames (bytes × 8 /
//!   SCLK), by the [`ModelDelay`] the host tests give the driver, and by a
//!   wait on DRDY (to the next conversion). Under QEMU nothing else advances
//!   it: the model's time is its own, only the order of events matters.
//! * **Conversions at the real period** (SBAS890 §8.3.6, §8.4.1):
//!   f_MOD = f_CLKIN / 2 in high-resolution mode, one conversion every
//!   OSR / f_MOD, OSR from CLOCK[4:2]; conversions run continuously from
//!   the last reset or CLOCK write.
//! * **The sinc³ filter** (SBAS890 §8.3.7.1.2): each conversion is the
//!   input weighted over the last 3 conversion periods by the sinc³
//!   impulse response (three cascaded averages of OSR samples: the
//!   Irwin–Hall density of order 3 in units of a period). A set/reset flip
//!   is a step in the bridge output, so the 1st–3rd conversions after it
//!   mix both polarities and the 4th is the first fully settled one.
//! * **Buffered conversions and DRDY** (SBAS890 §8.5.1.9, §8.5.1.9.1): a
//!   two-deep buffer per channel; a conversion completing on a full buffer
//!   drops the oldest, so after a pause the first read returns stale data.
//!   DRDY (active low) is asserted while unread data are buffered; the
//!   STATUS word's DRDY[3:0] bits say the same. Reading with nothing new
//!   returns the last data again with DRDY[3:0] clear.
//! * **Frames** (SBAS890 §8.5.1.7, §8.5.1.8): 24-bit words; the response
//!   to a command comes in the next frame; RESET answers `0xFF24`, WREG
//!   `010a aaaa a000 0000`, RREG the register; every output frame ends with
//!   CRC-16-CCITT (polynomial 0x1021, seed 0xFFFF, computed bitwise here);
//!   codes clip at ±2²³ (§8.5.1.3, Table 8-10).
//! * **The bridges** (HMC1001/1002 datasheet): output = offset ± S · V_b ·
//!   H after a set / reset pulse, S = 3.2 mV/V/gauss, V_b = 5 V; the board's
//!   instrumentation amplifier (gain 32) feeds the ADC (±1.2 V full scale,
//!   gain 1).
//! * **The thermistor on channel 3** (Murata NCP18XH103F03RB datasheet, R–T
//!   table): a 10 kΩ resistor from a 1.25 V reference over the NTC to
//!   ground; the NTC's resistance at the sensor's temperature (set by the
//!   feed) is the datasheet table's, interpolated as `ln R` linear in `1/T`
//!   (the B-law between neighbouring rows). An open thermistor (NaN
//!   temperature) puts the whole reference on the input: the code clips.
//!
//! The host's frames that set the bridges arrive on USART2 and are decoded
//! by [`FeedReceiver`] (module `feed`).

// Indexing below is into the fixed 18-byte frame at const offsets; the
// bytes from the bus are only ever values.
#![allow(clippy::indexing_slicing)]

use core::cell::RefCell;
use core::convert::Infallible;

use critical_section::Mutex;
use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{ErrorType as PinErrorType, InputPin, OutputPin};
use embedded_hal::spi::{ErrorType, Operation, SpiDevice};

mod feed;
pub use feed::FeedReceiver;

/// HMC1001/1002 sensitivity, V per V of bridge supply per gauss (datasheet typ).
const HMC_SENSITIVITY_V_PER_V_PER_GAUSS: f64 = 3.2e-3;
/// Bridge supply on the board, V.
const HMC_BRIDGE_SUPPLY_V: f64 = 5.0;
/// Instrumentation amplifier gain on the board.
const BOARD_AMP_GAIN: f64 = 32.0;
/// ADS131M04 full scale at gain 1, V (SBAS890 §8.5.1.3).
const ADS_FULL_SCALE_V: f64 = 1.2;
/// Codes per volt at gain 1: 2²³ / 1.2 V.
const ADS_CODES_PER_V: f64 = 8_388_608.0 / ADS_FULL_SCALE_V;
/// Largest and smallest 24-bit codes.
const ADS_CODE_MAX: i32 = 0x7F_FFFF;
const ADS_CODE_MIN: i32 = -0x80_0000;
/// Bytes per 24-bit word and words per frame (response, 4 channels, CRC).
const ADS_WORD_BYTES: usize = 3;
const ADS_FRAME_BYTES: usize = 18;
/// Conversions buffered per channel (SBAS890 §8.5.1.9.1).
const ADS_FIFO_DEPTH: usize = 2;
/// The board's clocks, unless [`BridgeModel::set_clocks`] says otherwise
/// (0 in the state stands for these: an all-zero initial state puts the
/// QEMU board's model in `.bss`, not in flash).
const DEFAULT_CLKIN_HZ: u32 = crate::clocks::ADC_CLKIN_HZ;
const DEFAULT_SCLK_HZ: u32 = crate::clocks::SPI_SCLK_HZ;
/// Polarity flips remembered (a pair has two; a window spans 3 periods).
const FLIPS_KEPT: usize = 8;
/// The thermistor divider: reference (V) and top resistor (Ω).
const NTC_DIVIDER_REF_V: f32 = 1.25;
const NTC_DIVIDER_TOP_OHM: f32 = 10_000.0;
/// NCP18XH103 R–T table (Murata catalog R44E, XH column): °C, kΩ.
const NTC_TABLE: [(f32, f32); 19] = [
    (-40.0, 195.652),
    (-30.0, 113.347),
    (-20.0, 68.237),
    (-10.0, 42.506),
    (0.0, 27.219),
    (10.0, 17.926),
    (20.0, 12.081),
    (25.0, 10.0),
    (30.0, 8.315),
    (40.0, 5.834),
    (50.0, 4.161),
    (60.0, 3.014),
    (70.0, 2.228),
    (80.0, 1.669),
    (85.0, 1.452),
    (90.0, 1.268),
    (100.0, 0.974),
    (110.0, 0.7576),
    (125.0, 0.531),
];

/// The NTC's resistance at `temp_c`, Ω (clamped to the table's ends).
pub fn model_ntc_ohm(temp_c: f32) -> f32 {
    let inv_t = |c: f32| 1.0 / (c + 273.15);
    let t = temp_c.clamp(-40.0, 125.0);
    let mut lo = NTC_TABLE[0];
    let mut hi = NTC_TABLE[1];
    for w in NTC_TABLE.windows(2) {
        if let [a, b] = w {
            lo = *a;
            hi = *b;
            if t <= b.0 {
                break;
            }
        }
    }
    let x = (inv_t(t) - inv_t(lo.0)) / (inv_t(hi.0) - inv_t(lo.0));
    let ln_r = libm::logf(lo.1 * 1000.0) + x * (libm::logf(hi.1 * 1000.0) - libm::logf(lo.1 * 1000.0));
    libm::expf(ln_r)
}

/// Channel 3's code for the sensor at `temp_c` (NaN: open thermistor).
fn ntc_code(temp_c: f32) -> i32 {
    let v = if temp_c.is_nan() {
        NTC_DIVIDER_REF_V
    } else {
        let r = model_ntc_ohm(temp_c);
        NTC_DIVIDER_REF_V * r / (r + NTC_DIVIDER_TOP_OHM)
    };
    let code = libm::roundf(v * (ADS_CODES_PER_V as f32));
    code.clamp(ADS_CODE_MIN as f32, ADS_CODE_MAX as f32) as i32
}

/// Field to ADC code through the modelled chain, codes per nT.
pub const fn model_codes_per_nt() -> f64 {
    HMC_SENSITIVITY_V_PER_V_PER_GAUSS * HMC_BRIDGE_SUPPLY_V * BOARD_AMP_GAIN * ADS_CODES_PER_V / 1e5
}

/// [`model_codes_per_nt`] rounded to `f32` at compile time: the model
/// converts in `f32` (the Cortex-M4F's FPU; `f64` would link ~2.6 KiB of
/// software arithmetic into the board image). A code is 0.028 nT; `f32`'s
/// roundings (the constant, the product, the sum with the offset) stay
/// under one code (0.03 nT) at 100 000 nT.
const CODES_PER_NT_F32: f32 = model_codes_per_nt() as f32;

/// CRC-16-CCITT, polynomial 0x1021, initial 0xFFFF, MSB first (SBAS890
/// §8.5.1.11), bit by bit.
fn ccitt(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    for &b in bytes {
        crc ^= u16::from(b) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ 0x1021 } else { crc << 1 };
        }
    }
    crc
}

/// `a / b` rounded down, without a 64-bit division: the board binary
/// carries this model for QEMU, and a `u64` division (or an `f64` one)
/// would link ~1 KiB of software division each. `u32` chunks, then the
/// hardware's 32-bit divide.
fn div_u64_u32(mut a: u64, b: u32) -> u64 {
    let b = b.max(1);
    let chunk_q = u64::from(u32::MAX / b);
    let chunk = chunk_q * u64::from(b);
    let mut q = 0u64;
    while a > u64::from(u32::MAX) {
        a -= chunk;
        q += chunk_q;
    }
    q + u64::from(a as u32 / b)
}

/// `a / b` rounded up (as [`div_u64_u32`]).
fn div_ceil_u64_u32(a: u64, b: u32) -> u64 {
    let q = div_u64_u32(a, b);
    if q * u64::from(b.max(1)) < a { q + 1 } else { q }
}

/// Cumulative sinc³ step response at `x` conversion periods into its
/// 3-period window: the Irwin–Hall CDF of order 3.
fn sinc3_cdf(x: f32) -> f32 {
    const SIXTH: f32 = 1.0 / 6.0;
    if x <= 0.0 {
        0.0
    } else if x < 1.0 {
        x * x * x * SIXTH
    } else if x < 2.0 {
        (-2.0 * x * x * x + 9.0 * x * x - 9.0 * x + 3.0) * SIXTH
    } else if x < 3.0 {
        let y = 3.0 - x;
        1.0 - y * y * y * SIXTH
    } else {
        1.0
    }
}

#[derive(Debug, Clone, Copy)]
struct World {
    // The magnetic truth and the bridges.
    field_nt: [f32; 3],
    offset_codes: [f32; 3],
    /// Channel 3's code (the thermistor divider at the sensor's
    /// temperature); `None` before any: 25 °C.
    ntc_code: Option<i32>,
    seq: u32,
    updates: u32,
    /// (time, +1 after SET / −1 after RESET), oldest first.
    flips: [(u64, i8); FLIPS_KEPT],
    n_flips: usize,
    // Time.
    now_ns: u64,
    clkin_hz: u32,
    sclk_hz: u32,
    // The converter.
    regs: [u16; 64],
    pending: u16,
    grid_origin_ns: u64,
    /// Index of the next conversion to complete (completes at origin + k·T).
    next_k: u64,
    fifo: [[i32; 4]; ADS_FIFO_DEPTH],
    fifo_len: usize,
    last_out: [i32; 4],
    frames: u32,
    conversions: u64,
}

/// Power-on register values (SBAS890 §8.6, register map): ID 0x24xx,
/// STATUS 0x0500, MODE 0x0510, CLOCK 0x0F0E (4 channels, OSR 1024, HR),
/// GAIN1 0x0000, CFG 0x0600.
const POWER_ON: [(usize, u16); 6] = [(0x00, 0x2410), (0x01, 0x0500), (0x02, 0x0510), (0x03, 0x0F0E), (0x04, 0x0000), (0x06, 0x0600)];

impl World {
    const fn new() -> Self {
        Self {
            field_nt: [0.0; 3],
            offset_codes: [0.0; 3],
            ntc_code: None,
            seq: 0,
            updates: 0,
            flips: [(0, 0); FLIPS_KEPT],
            n_flips: 0,
            now_ns: 0,
            clkin_hz: 0,
            sclk_hz: 0,
            regs: [0; 64],
            pending: 0,
            grid_origin_ns: 0,
            next_k: 0,
            fifo: [[0; 4]; ADS_FIFO_DEPTH],
            fifo_len: 0,
            last_out: [0; 4],
            frames: 0,
            conversions: 0,
        }
    }

    fn power_on(&mut self) {
        self.regs = [0; 64];
        for (a, v) in POWER_ON {
            if let Some(r) = self.regs.get_mut(a) {
                *r = v;
            }
        }
        self.restart_conversions();
    }

    fn restart_conversions(&mut self) {
        self.grid_origin_ns = self.now_ns;
        self.next_k = 1;
        self.fifo_len = 0;
    }

    /// OSR from CLOCK[4:2] (SBAS890 §8.6: 000 = 128 … 111 = 16384).
    fn osr(&self) -> u64 {
        128u64 << ((self.regs[3] >> 2) & 0x7)
    }

    /// One conversion period, ns: OSR / f_MOD with f_MOD = f_CLKIN / 2.
    fn period_ns(&self) -> u64 {
        div_ceil_u64_u32(self.osr() * 2 * 1_000_000_000, if self.clkin_hz == 0 { DEFAULT_CLKIN_HZ } else { self.clkin_hz })
    }

    fn completion_ns(&self, k: u64) -> u64 {
        self.grid_origin_ns + k * self.period_ns()
    }

    /// Bridge sign at time `t`.
    fn sign_at(&self, t: u64) -> f32 {
        let mut s = 1.0;
        for &(at, sign) in self.flips.iter().take(self.n_flips) {
            if at <= t {
                s = f32::from(sign);
            }
        }
        s
    }

    /// ∫ sign(t) w(t) dt over the window of the conversion ending at `end`.
    fn weighted_sign(&self, end: u64) -> f32 {
        let start = end.saturating_sub(3 * self.period_ns());
        // Offsets within the window (under 3 periods) in periods, and the
        // sinc³ weights, in f32 (the FPU's): a 32 µs period resolved to
        // 0.004 ns, weights to 1e-7 — only conversions with a flip inside
        // their window (the ones the acquisition discards) are not exactly
        // ±1.
        let t_period = u32::try_from(self.period_ns()).unwrap_or(u32::MAX) as f32;
        let periods = |d: u64| u32::try_from(d).unwrap_or(u32::MAX) as f32 / t_period;
        let mut acc = 0.0;
        let mut seg_start = start;
        let mut sign = self.sign_at(start);
        for &(at, s) in self.flips.iter().take(self.n_flips) {
            if at > start && at < end {
                let a = periods(seg_start - start);
                let b = periods(at - start);
                acc += sign * (sinc3_cdf(b) - sinc3_cdf(a));
                seg_start = at;
                sign = f32::from(s);
            }
        }
        let a = periods(seg_start - start);
        acc + sign * (1.0 - sinc3_cdf(a))
    }

    fn convert(&self, end: u64) -> [i32; 4] {
        let w = self.weighted_sign(end);
        let mut out = [0i32; 4];
        let enabled = (self.regs[3] >> 8) & 0xF;
        for ch in 0..3 {
            if enabled & (1 << ch) == 0 {
                continue;
            }
            let v = self.offset_codes[ch] + w * self.field_nt[ch] * CODES_PER_NT_F32;
            // `as` saturates (NaN → 0); the integer clamp is the 24-bit range.
            out[ch] = (libm::roundf(v) as i32).clamp(ADS_CODE_MIN, ADS_CODE_MAX);
        }
        if enabled & (1 << 3) != 0 {
            // 10 kΩ at 25 °C before any temperature: half the 1.25 V reference.
            out[3] = self.ntc_code.unwrap_or(4_369_067);
        }
        out
    }

    /// Completes every conversion due by now (only the last two can still
    /// be in the buffer, so older ones are skipped).
    fn catch_up(&mut self) {
        let t = u32::try_from(self.period_ns().max(1)).unwrap_or(u32::MAX);
        if self.now_ns < self.completion_ns(self.next_k) {
            return;
        }
        let last_k = div_u64_u32(self.now_ns - self.grid_origin_ns, t);
        let first = self.next_k.max(last_k.saturating_sub(ADS_FIFO_DEPTH as u64 - 1));
        self.conversions += last_k + 1 - self.next_k;
        for k in first..=last_k {
            let data = self.convert(self.completion_ns(k));
            if self.fifo_len == ADS_FIFO_DEPTH {
                self.fifo[0] = self.fifo[1];
                self.fifo_len -= 1;
            }
            self.fifo[self.fifo_len] = data;
            self.fifo_len += 1;
        }
        self.next_k = last_k + 1;
    }

    fn status(&self) -> u16 {
        let drdy = if self.fifo_len > 0 { 0x000F } else { 0 };
        (self.regs[1] & !0x000F) | drdy
    }

    fn advance(&mut self, ns: u64) {
        self.now_ns += ns;
        self.catch_up();
    }

    fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) {
        self.catch_up();
        let status = self.status();
        let data = if self.fifo_len > 0 {
            let d = self.fifo[0];
            self.fifo[0] = self.fifo[1];
            self.fifo_len -= 1;
            self.last_out = d;
            d
        } else {
            self.last_out
        };
        let mut out = [0u8; ADS_FRAME_BYTES];
        out[..2].copy_from_slice(&self.pending.to_be_bytes());
        for (ch, code) in data.iter().enumerate() {
            let b = code.to_be_bytes();
            out[ADS_WORD_BYTES * (ch + 1)..ADS_WORD_BYTES * (ch + 2)].copy_from_slice(&b[1..4]);
        }
        let crc = ccitt(&out[..15]);
        out[15..17].copy_from_slice(&crc.to_be_bytes());
        for (d, s) in rx.iter_mut().zip(out.iter()) {
            *d = *s;
        }
        self.frames = self.frames.wrapping_add(1);
        // The command in this frame; its response goes out in the next.
        let word = |w: usize| match (tx.get(ADS_WORD_BYTES * w), tx.get(ADS_WORD_BYTES * w + 1)) {
            (Some(&h), Some(&l)) => u16::from_be_bytes([h, l]),
            _ => 0,
        };
        let command = word(0);
        let addr = usize::from((command >> 7) & 0x3F);
        self.pending = match command {
            0x0011 => {
                self.power_on();
                0xFF24
            }
            c if c & 0xE000 == 0xA000 => self.regs.get(addr).copied().unwrap_or(0),
            c if c & 0xE000 == 0x6000 => {
                if let Some(r) = self.regs.get_mut(addr) {
                    *r = word(1);
                }
                if addr == 3 {
                    // A new OSR resets the filter: conversions restart.
                    self.restart_conversions();
                }
                0x4000 | (c & 0x1F80)
            }
            _ => status,
        };
        // The frame takes its time on the bus.
        let bits = (ADS_FRAME_BYTES * 8) as u64;
        self.advance(div_ceil_u64_u32(bits * 1_000_000_000, if self.sclk_hz == 0 { DEFAULT_SCLK_HZ } else { self.sclk_hz }));
    }

    fn flip(&mut self, sign: i8) {
        self.catch_up();
        if self.n_flips == FLIPS_KEPT {
            self.flips.copy_within(1.., 0);
            self.n_flips -= 1;
        }
        self.flips[self.n_flips] = (self.now_ns, sign);
        self.n_flips += 1;
    }
}

/// The magnetic truth the simulated bridges see, the simulated converter
/// and their shared clock; one per board (a `static`).
pub struct BridgeModel {
    world: Mutex<RefCell<World>>,
}

impl Default for BridgeModel {
    fn default() -> Self {
        Self::new()
    }
}

impl BridgeModel {
    /// Zero field, zero offset; an 8 MHz CLKIN and a 21 MHz SCLK, as on the
    /// board.
    pub const fn new() -> Self {
        Self { world: Mutex::new(RefCell::new(World::new())) }
    }

    fn with<R>(&self, f: impl FnOnce(&mut World) -> R) -> R {
        critical_section::with(|cs| f(&mut self.world.borrow_ref_mut(cs)))
    }

    /// Sets the clocks the board gives the ADC (CLKIN) and its SPI (SCLK).
    pub fn set_clocks(&self, clkin_hz: u32, sclk_hz: u32) {
        self.with(|w| {
            w.clkin_hz = clkin_hz;
            w.sclk_hz = sclk_hz;
        });
    }

    /// Sets the field (nT, per axis) and the bridge offsets (ADC codes) the
    /// next conversions see.
    pub fn set_truth(&self, field_nt: [f32; 3], offset_codes: [f32; 3]) {
        self.set_truth_seq(field_nt, offset_codes, 0);
    }

    /// [`BridgeModel::set_truth`], tagged with the feed frame's sequence number.
    pub fn set_truth_seq(&self, field_nt: [f32; 3], offset_codes: [f32; 3], seq: u32) {
        self.with(|w| {
            w.catch_up();
            w.field_nt = field_nt;
            w.offset_codes = offset_codes;
            w.updates = w.updates.wrapping_add(1);
            w.seq = seq;
        });
    }

    /// Sets the temperature of the thermistor next to the sensor, °C (NaN:
    /// an open thermistor).
    pub fn set_temp_c(&self, temp_c: f32) {
        let code = ntc_code(temp_c);
        self.with(|w| {
            w.catch_up();
            w.ntc_code = Some(code);
        });
    }

    /// The sequence number of the feed frame in force.
    pub fn seq(&self) -> u32 {
        self.with(|w| w.seq)
    }

    /// How many truth updates have arrived.
    pub fn updates(&self) -> u32 {
        self.with(|w| w.updates)
    }

    /// The model's time, ns.
    pub fn now_ns(&self) -> u64 {
        self.with(|w| w.now_ns)
    }

    /// Conversions completed since power-on.
    pub fn conversions(&self) -> u64 {
        self.with(|w| w.conversions)
    }

    /// Lets `ns` of time pass.
    pub fn advance_ns(&self, ns: u64) {
        self.with(|w| w.advance(ns));
    }

    /// The conversion period the registers select, ns.
    pub fn conversion_period_ns(&self) -> u64 {
        self.with(|w| w.period_ns())
    }

    /// The DRDY pin: low while unread conversions are buffered.
    fn drdy_low(&self) -> bool {
        self.with(|w| {
            w.catch_up();
            w.fifo_len > 0
        })
    }

    /// Waits (in model time) for the next conversion if none is buffered.
    fn wait_drdy(&self) {
        self.with(|w| {
            w.catch_up();
            if w.fifo_len == 0 {
                let due = w.completion_ns(w.next_k);
                let dt = due.saturating_sub(w.now_ns);
                w.advance(dt);
            }
        });
    }
}

/// A strap GPIO of the simulated board: driving it high pulses the strap
/// and flips the bridges.
pub struct StrapPinModel {
    sensor: &'static BridgeModel,
    sign: i8,
}

impl StrapPinModel {
    /// The SET pulse pin.
    pub fn set(sensor: &'static BridgeModel) -> Self {
        Self { sensor, sign: 1 }
    }
    /// The RESET pulse pin.
    pub fn reset(sensor: &'static BridgeModel) -> Self {
        Self { sensor, sign: -1 }
    }
}

impl PinErrorType for StrapPinModel {
    type Error = Infallible;
}

impl OutputPin for StrapPinModel {
    fn set_high(&mut self) -> Result<(), Infallible> {
        let sign = self.sign;
        self.sensor.with(|w| w.flip(sign));
        Ok(())
    }
    fn set_low(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

/// The ADC's DRDY pin (active low): readable, and awaitable — a wait lets
/// model time run to the next conversion.
pub struct DrdyPinModel {
    sensor: &'static BridgeModel,
}

impl DrdyPinModel {
    /// The pin of `sensor`'s converter.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        Self { sensor }
    }
}

impl PinErrorType for DrdyPinModel {
    type Error = Infallible;
}

impl InputPin for DrdyPinModel {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(!self.sensor.drdy_low())
    }
    fn is_low(&mut self) -> Result<bool, Infallible> {
        Ok(self.sensor.drdy_low())
    }
}

impl embedded_hal_async::digital::Wait for DrdyPinModel {
    async fn wait_for_high(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
    async fn wait_for_low(&mut self) -> Result<(), Infallible> {
        self.sensor.wait_drdy();
        Ok(())
    }
    async fn wait_for_rising_edge(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
    async fn wait_for_falling_edge(&mut self) -> Result<(), Infallible> {
        self.sensor.wait_drdy();
        Ok(())
    }
    async fn wait_for_any_edge(&mut self) -> Result<(), Infallible> {
        self.sensor.wait_drdy();
        Ok(())
    }
}

/// A delay that lets model time pass (host tests), instead of spinning.
pub struct ModelDelay {
    sensor: &'static BridgeModel,
}

impl ModelDelay {
    /// Delays on `sensor`'s clock.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        Self { sensor }
    }
}

impl DelayNs for ModelDelay {
    fn delay_ns(&mut self, ns: u32) {
        self.sensor.advance_ns(u64::from(ns));
    }
}

/// The simulated ADS131M04.
pub struct Ads131m04Model {
    sensor: &'static BridgeModel,
}

impl Ads131m04Model {
    /// A device just powered on.
    pub fn new(sensor: &'static BridgeModel) -> Self {
        sensor.with(|w| w.power_on());
        Self { sensor }
    }

    /// Frames exchanged so far.
    pub fn frames(&self) -> u32 {
        self.sensor.with(|w| w.frames)
    }
}

impl ErrorType for Ads131m04Model {
    type Error = Infallible;
}

impl SpiDevice for Ads131m04Model {
    fn transaction(&mut self, operations: &mut [Operation<'_, u8>]) -> Result<(), Infallible> {
        self.sensor.with(|w| {
            for op in operations.iter_mut() {
                match op {
                    Operation::Transfer(rx, tx) => w.exchange(tx, rx),
                    Operation::TransferInPlace(buf) => {
                        let mut tx = [0u8; ADS_FRAME_BYTES];
                        for (d, s) in tx.iter_mut().zip(buf.iter()) {
                            *d = *s;
                        }
                        w.exchange(&tx, buf);
                    }
                    Operation::Write(tx) => w.exchange(tx, &mut []),
                    Operation::Read(rx) => w.exchange(&[], rx),
                    Operation::DelayNs(ns) => w.advance(u64::from(*ns)),
                }
            }
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests;
