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
//! One room per job: the bridges, the amplifier and the thermistor to
//! codes (`analog`); the converter's clock, sinc³ filter, buffer and frames
//! (`converter`); the shared state, here ([`BridgeModel`]); the board's view
//! of it through embedded-hal (`hal`: the SPI device, the DRDY pin, the
//! straps, the delay). The host's frames that set the bridges arrive on
//! USART2 and are decoded by [`FeedReceiver`] (module `feed`).

// Indexing below is into the fixed 18-byte frame at const offsets; the
// bytes from the bus are only ever values.
#![allow(clippy::indexing_slicing)]

use core::cell::RefCell;

use critical_section::Mutex;

mod analog;
mod converter;
mod feed;
mod hal;

use analog::ntc_code;
pub use analog::{model_codes_per_nt, model_ntc_ohm};
use converter::World;
pub use feed::FeedReceiver;
pub use hal::{Ads131m04Model, DrdyPinModel, ModelDelay, StrapPinModel};

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

#[cfg(test)]
mod tests;
