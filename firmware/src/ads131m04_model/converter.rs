//! The converter (SBAS890): conversions at the period the CLOCK register
//! selects, the sinc³ filter across set/reset flips, the two-deep buffer
//! and DRDY, and the SPI frames with their CRC, on the model's own clock.

use super::analog::{ADS_CODE_MAX, ADS_CODE_MIN, CODES_PER_NT_F32};

/// Bytes per 24-bit word and words per frame (response, 4 channels, CRC).
const ADS_WORD_BYTES: usize = 3;
pub(super) const ADS_FRAME_BYTES: usize = 18;
/// Conversions buffered per channel (SBAS890 §8.5.1.9.1).
const ADS_FIFO_DEPTH: usize = 2;
/// The board's clocks, unless [`super::BridgeModel::set_clocks`] says otherwise
/// (0 in the state stands for these: an all-zero initial state puts the
/// QEMU board's model in `.bss`, not in flash).
const DEFAULT_CLKIN_HZ: u32 = crate::clocks::ADC_CLKIN_HZ;
const DEFAULT_SCLK_HZ: u32 = crate::clocks::SPI_SCLK_HZ;
/// Polarity flips remembered (a pair has two; a window spans 3 periods).
const FLIPS_KEPT: usize = 8;

/// CRC-16-CCITT, polynomial 0x1021, initial 0xFFFF, MSB first (SBAS890
/// §8.5.1.11), bit by bit.
pub(super) fn ccitt(bytes: &[u8]) -> u16 {
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
pub(super) fn div_u64_u32(mut a: u64, b: u32) -> u64 {
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
pub(super) fn div_ceil_u64_u32(a: u64, b: u32) -> u64 {
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

/// The magnetic truth, the converter's state and the model's clock.
#[derive(Debug, Clone, Copy)]
pub(super) struct World {
    // The magnetic truth and the bridges.
    pub(super) field_nt: [f32; 3],
    pub(super) offset_codes: [f32; 3],
    /// Channel 3's code (the thermistor divider at the sensor's
    /// temperature); `None` before any: 25 °C.
    pub(super) ntc_code: Option<i32>,
    pub(super) seq: u32,
    pub(super) updates: u32,
    /// (time, +1 after SET / −1 after RESET), oldest first.
    flips: [(u64, i8); FLIPS_KEPT],
    n_flips: usize,
    // Time.
    pub(super) now_ns: u64,
    pub(super) clkin_hz: u32,
    pub(super) sclk_hz: u32,
    // The converter.
    regs: [u16; 64],
    pending: u16,
    grid_origin_ns: u64,
    /// Index of the next conversion to complete (completes at origin + k·T).
    pub(super) next_k: u64,
    fifo: [[i32; 4]; ADS_FIFO_DEPTH],
    pub(super) fifo_len: usize,
    last_out: [i32; 4],
    pub(super) frames: u32,
    pub(super) conversions: u64,
}

/// Power-on register values (SBAS890 §8.6, register map): ID 0x24xx,
/// STATUS 0x0500, MODE 0x0510, CLOCK 0x0F0E (4 channels, OSR 1024, HR),
/// GAIN1 0x0000, CFG 0x0600.
const POWER_ON: [(usize, u16); 6] = [(0x00, 0x2410), (0x01, 0x0500), (0x02, 0x0510), (0x03, 0x0F0E), (0x04, 0x0000), (0x06, 0x0600)];

impl World {
    pub(super) const fn new() -> Self {
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

    pub(super) fn power_on(&mut self) {
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
    pub(super) fn period_ns(&self) -> u64 {
        div_ceil_u64_u32(self.osr() * 2 * 1_000_000_000, if self.clkin_hz == 0 { DEFAULT_CLKIN_HZ } else { self.clkin_hz })
    }

    pub(super) fn completion_ns(&self, k: u64) -> u64 {
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
    pub(super) fn catch_up(&mut self) {
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

    pub(super) fn advance(&mut self, ns: u64) {
        self.now_ns += ns;
        self.catch_up();
    }

    pub(super) fn exchange(&mut self, tx: &[u8], rx: &mut [u8]) {
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

    pub(super) fn flip(&mut self, sign: i8) {
        self.catch_up();
        if self.n_flips == FLIPS_KEPT {
            self.flips.copy_within(1.., 0);
            self.n_flips -= 1;
        }
        self.flips[self.n_flips] = (self.now_ns, sign);
        self.n_flips += 1;
    }
}
