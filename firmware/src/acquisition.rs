//! HMC1001/HMC1002 acquisition: set/reset strap sequencing, the ADC read,
//! bridge-offset tracking, saturation detection and decimation.
//!
//! The magnetoresistive bridges flip their sensitivity with the direction of
//! the last set/reset strap pulse (Honeywell AN-201/AN-213). Sampling after a
//! SET pulse and after a RESET pulse and differencing removes the bridge
//! offset and its temperature drift:
//!
//! ```text
//! set   = +S·H + offset        field  = (set − reset) / 2
//! reset = −S·H + offset        offset = (set + reset) / 2
//! ```
//!
//! Channel map: ADS131M04 channel 0 = X (HMC1002 A), 1 = Y (HMC1002 B),
//! 2 = Z (HMC1001), 3 unused.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::OutputPin;
use embedded_hal::spi::SpiDevice;

use crate::adc::{self, Ads131m04, FULL_SCALE_COUNTS};

/// Bridge excitation, volts.
pub const BRIDGE_DRIVE_V: f32 = 5.0;
/// HMC1001/1002 sensitivity, mV per volt of drive per gauss (datasheet typ).
pub const SENSITIVITY_MV_PER_V_PER_GAUSS: f32 = 3.2;
/// Instrumentation amplifier gain between bridge and ADC.
pub const AMPLIFIER_GAIN: f32 = 32.0;
/// ADC PGA gain.
pub const ADC_GAIN: adc::Gain = adc::Gain::X1;
/// ADC oversampling ratio (32 kSPS: a strap phase settles in ~0.1 ms).
pub const ADC_OSR: adc::Osr = adc::Osr::X128;
/// Counts per nT through the whole chain:
/// `S · V_drive · G_amp / (V_ref / 2²³)` with 1 gauss = 10⁵ nT. ≈ 35.8.
pub const COUNTS_PER_NT: f32 =
    SENSITIVITY_MV_PER_V_PER_GAUSS * 1e-3 * BRIDGE_DRIVE_V / 1e5 * AMPLIFIER_GAIN / (adc::REFERENCE_V / FULL_SCALE_COUNTS as f32);
/// A code at or beyond this magnitude is treated as saturated (98 % of full scale).
pub const SATURATION_COUNTS: i32 = FULL_SCALE_COUNTS / 50 * 49;
/// Set/reset pulse width, µs (the sensors need ≥ 2 µs).
pub const STRAP_PULSE_US: u32 = 2;
/// Conversions discarded after a strap pulse while the sinc³ filter settles.
pub const SETTLE_CONVERSIONS: u8 = 3;
/// Highest set/reset pair rate (the sensor's 1 kHz limit).
pub const MAX_PAIR_RATE_HZ: u32 = 1000;
/// Weight of a new offset in the running bridge-offset estimate.
pub const OFFSET_TRACKING_WEIGHT: f32 = 0.01;

/// Which way the last strap pulse went.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Polarity {
    /// After a SET pulse: positive sensitivity.
    Set,
    /// After a RESET pulse: negative sensitivity.
    Reset,
}

/// The pulse stage: two GPIOs, one per pulse direction.
#[derive(Debug)]
pub struct SetResetStrap<S, R> {
    set: S,
    reset: R,
}

/// Why an acquisition failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum AcqError<E> {
    /// The ADC failed (bus or protocol).
    Adc(adc::Error<E>),
    /// A strap GPIO could not be driven.
    Strap,
}

impl<E> From<adc::Error<E>> for AcqError<E> {
    fn from(e: adc::Error<E>) -> Self {
        AcqError::Adc(e)
    }
}

impl<S: OutputPin, R: OutputPin> SetResetStrap<S, R> {
    /// Both pins low (no pulse).
    pub fn new(mut set: S, mut reset: R) -> Self {
        let _ = set.set_low();
        let _ = reset.set_low();
        Self { set, reset }
    }

    /// One pulse of [`STRAP_PULSE_US`].
    pub fn pulse<D: DelayNs>(&mut self, polarity: Polarity, delay: &mut D) -> Result<(), ()> {
        match polarity {
            Polarity::Set => pulse_pin(&mut self.set, delay),
            Polarity::Reset => pulse_pin(&mut self.reset, delay),
        }
    }
}

fn pulse_pin<P: OutputPin, D: DelayNs>(pin: &mut P, delay: &mut D) -> Result<(), ()> {
    pin.set_high().map_err(|_| ())?;
    delay.delay_us(STRAP_PULSE_US);
    pin.set_low().map_err(|_| ())
}

/// One set/reset pair.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct PairSample {
    /// `(set − reset)/2` per axis, counts.
    pub field_counts: [f32; 3],
    /// `(set + reset)/2` per axis, counts.
    pub offset_counts: [f32; 3],
    /// A channel read at or beyond [`SATURATION_COUNTS`].
    pub saturated: bool,
}

/// Health counters of the acquisition.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct AcqCounters {
    /// Pairs acquired.
    pub pairs: u32,
    /// Pairs with a saturated channel.
    pub saturated: u32,
    /// Failed pairs (bus, CRC, strap).
    pub errors: u32,
}

/// The sensor front end: ADC plus strap.
#[derive(Debug)]
pub struct Acquisition<SPI, S, R> {
    adc: Ads131m04<SPI>,
    strap: SetResetStrap<S, R>,
    offset: [f32; 3],
    counters: AcqCounters,
}

impl<SPI: SpiDevice, S: OutputPin, R: OutputPin> Acquisition<SPI, S, R> {
    /// Configures the ADC ([`ADC_OSR`], [`ADC_GAIN`]) and takes the strap.
    pub fn new(spi: SPI, strap: SetResetStrap<S, R>) -> Result<Self, AcqError<SPI::Error>> {
        let mut adc = Ads131m04::new(spi);
        adc.configure(ADC_OSR, ADC_GAIN)?;
        Ok(Self { adc, strap, offset: [0.0; 3], counters: AcqCounters::default() })
    }

    /// Pulses the strap, lets the filter settle, and reads one conversion.
    fn phase<D: DelayNs>(&mut self, polarity: Polarity, delay: &mut D) -> Result<[i32; 3], AcqError<SPI::Error>> {
        self.strap.pulse(polarity, delay).map_err(|()| AcqError::Strap)?;
        for _ in 0..SETTLE_CONVERSIONS {
            self.adc.read()?;
        }
        let c = self.adc.read()?;
        Ok([c.channels[0], c.channels[1], c.channels[2]])
    }

    /// Acquires one set/reset pair.
    pub fn acquire_pair<D: DelayNs>(&mut self, delay: &mut D) -> Result<PairSample, AcqError<SPI::Error>> {
        let result = self.phase(Polarity::Set, delay).and_then(|s| Ok((s, self.phase(Polarity::Reset, delay)?)));
        let (set, reset) = match result {
            Ok(v) => v,
            Err(e) => {
                self.counters.errors = self.counters.errors.wrapping_add(1);
                return Err(e);
            }
        };
        let mut out = PairSample { field_counts: [0.0; 3], offset_counts: [0.0; 3], saturated: false };
        let first = self.counters.pairs == 0;
        let axes = set.iter().zip(reset.iter()).zip(out.field_counts.iter_mut().zip(out.offset_counts.iter_mut())).zip(self.offset.iter_mut());
        for (((&s, &r), (field, offset)), tracked) in axes {
            out.saturated |= s.saturating_abs() >= SATURATION_COUNTS || r.saturating_abs() >= SATURATION_COUNTS;
            // i64: the difference of two 24-bit codes needs 25 bits.
            *field = ((i64::from(s) - i64::from(r)) as f32) * 0.5;
            *offset = ((i64::from(s) + i64::from(r)) as f32) * 0.5;
            *tracked = if first { *offset } else { *tracked + OFFSET_TRACKING_WEIGHT * (*offset - *tracked) };
        }
        self.counters.pairs = self.counters.pairs.wrapping_add(1);
        if out.saturated {
            self.counters.saturated = self.counters.saturated.wrapping_add(1);
        }
        Ok(out)
    }

    /// The running bridge-offset estimate, counts.
    pub fn bridge_offset(&self) -> [f32; 3] {
        self.offset
    }

    /// Health counters.
    pub fn counters(&self) -> AcqCounters {
        self.counters
    }
}

/// Averages `factor` pairs into one output sample.
#[derive(Debug, Clone, Copy)]
pub struct Decimator {
    factor: u16,
    n: u16,
    sum: [f32; 3],
    saturated: bool,
    tag: Option<Option<u32>>,
}

/// One decimated output sample.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct RawSample {
    /// Mean field, counts.
    pub field_counts: [f32; 3],
    /// Any pair in the average saturated.
    pub saturated: bool,
    /// The tag every pair carried (QEMU: the sensor-feed frame), `None` if
    /// they differed.
    pub tag: Option<u32>,
}

impl Decimator {
    /// Averages `factor` (≥ 1) pairs.
    pub fn new(factor: u16) -> Self {
        Self { factor: factor.max(1), n: 0, sum: [0.0; 3], saturated: false, tag: None }
    }

    /// The factor for a pair rate and an output rate (at least 1).
    pub fn factor_for(pair_rate_hz: u32, output_rate_hz: u32) -> u16 {
        (pair_rate_hz / output_rate_hz.max(1)).clamp(1, u32::from(u16::MAX)) as u16
    }

    /// Adds a pair; returns the average when `factor` pairs are in.
    pub fn push(&mut self, p: &PairSample) -> Option<RawSample> {
        self.push_tagged(p, None)
    }

    /// [`Decimator::push`] with a tag (e.g. the feed frame the pair saw).
    pub fn push_tagged(&mut self, p: &PairSample, tag: Option<u32>) -> Option<RawSample> {
        self.tag = match self.tag {
            None => Some(tag),
            Some(t) if t == tag => Some(t),
            Some(_) => Some(None),
        };
        for (sum, v) in self.sum.iter_mut().zip(p.field_counts) {
            *sum += v;
        }
        self.saturated |= p.saturated;
        self.n += 1;
        if self.n < self.factor {
            return None;
        }
        let inv = 1.0 / f32::from(self.n);
        let out = RawSample { field_counts: [self.sum[0] * inv, self.sum[1] * inv, self.sum[2] * inv], saturated: self.saturated, tag: self.tag.flatten() };
        *self = Self::new(self.factor);
        Some(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ads131m04_model::{Ads131m04Model, StrapPinModel, BridgeModel};
    use embedded_hal_mock::eh1::delay::NoopDelay;

    fn front_end(sensor: &'static BridgeModel) -> Acquisition<Ads131m04Model, StrapPinModel, StrapPinModel> {
        let strap = SetResetStrap::new(StrapPinModel::set(sensor), StrapPinModel::reset(sensor));
        Acquisition::new(Ads131m04Model::new(sensor), strap).unwrap()
    }

    #[test]
    fn the_chain_constant_is_what_the_datasheets_give() {
        // 3.2 mV/V/G × 5 V × 32 / (1.2 V / 2²³) / 10⁵ nT/G = 35.79 counts/nT.
        assert!((COUNTS_PER_NT - 35.7913).abs() < 1e-3, "{COUNTS_PER_NT}");
        // ±2 gauss (the sensors' range) stays inside the ADC's range.
        assert!(2e5 * COUNTS_PER_NT < SATURATION_COUNTS as f32);
    }

    #[test]
    fn set_reset_differencing_removes_the_bridge_offset() {
        static SENSOR: BridgeModel = BridgeModel::new();
        SENSOR.set_truth([12_345.0, -6_789.0, 250_000.0], [40_000.0, -35_000.0, 1_000.0]);
        let mut acq = front_end(&SENSOR);
        let p = acq.acquire_pair(&mut NoopDelay).unwrap();
        assert_eq!(p.field_counts, [12_345.0, -6_789.0, 250_000.0]);
        assert_eq!(p.offset_counts, [40_000.0, -35_000.0, 1_000.0]);
        assert!(!p.saturated);
        assert_eq!(acq.bridge_offset(), [40_000.0, -35_000.0, 1_000.0]);
        // The offset drifts; the field does not move, the tracker follows.
        SENSOR.set_truth([12_345.0, -6_789.0, 250_000.0], [41_000.0, -35_000.0, 1_000.0]);
        let p = acq.acquire_pair(&mut NoopDelay).unwrap();
        assert_eq!(p.field_counts[0], 12_345.0);
        assert!((acq.bridge_offset()[0] - 40_010.0).abs() < 1e-3);
        assert_eq!(acq.counters().pairs, 2);
    }

    #[test]
    fn saturation_is_flagged_and_counted() {
        static SENSOR: BridgeModel = BridgeModel::new();
        SENSOR.set_truth([8_300_000.0, 0.0, 0.0], [0.0; 3]);
        let mut acq = front_end(&SENSOR);
        let p = acq.acquire_pair(&mut NoopDelay).unwrap();
        assert!(p.saturated);
        assert_eq!(acq.counters().saturated, 1);
    }

    #[test]
    fn decimation_averages_and_keeps_saturation() {
        let mut d = Decimator::new(Decimator::factor_for(1000, 250));
        let pair = |v: f32, sat| PairSample { field_counts: [v, 2.0 * v, -v], offset_counts: [0.0; 3], saturated: sat };
        assert!(d.push(&pair(1.0, false)).is_none());
        assert!(d.push(&pair(2.0, true)).is_none());
        assert!(d.push(&pair(3.0, false)).is_none());
        let out = d.push(&pair(6.0, false)).unwrap();
        assert_eq!(out.field_counts, [3.0, 6.0, -3.0]);
        assert!(out.saturated);
        let next = d.push(&pair(1.0, false));
        assert!(next.is_none(), "the decimator restarts");
        // Tags: kept when every pair carries the same, dropped when mixed.
        let mut d = Decimator::new(2);
        assert!(d.push_tagged(&pair(1.0, false), Some(7)).is_none());
        assert_eq!(d.push_tagged(&pair(1.0, false), Some(7)).unwrap().tag, Some(7));
        assert!(d.push_tagged(&pair(1.0, false), Some(7)).is_none());
        assert_eq!(d.push_tagged(&pair(1.0, false), Some(8)).unwrap().tag, None);
        assert_eq!(Decimator::factor_for(1000, 0), 1000);
    }
}
