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
//! 2 = Z (HMC1001), 3 = the thermistor divider ([`crate::thermistor`]): the
//! same in both phases, so a pair's temperature code is their mean.
//!
//! Each phase is paced by the ADC's DRDY (SBAS890 §8.5.1.9):
//!
//! 1. read out whatever is buffered — it was converted before the pulse
//!    (the part buffers two conversions, §8.5.1.9.1);
//! 2. pulse the strap ([`STRAP_PULSE_US`]);
//! 3. discard a conversion that was already waiting (it ended before or
//!    during the pulse), then wait for DRDY [`SETTLE_CONVERSIONS`] + 1 times,
//!    reading each conversion: the sinc³ filter averages three conversion
//!    periods (§8.3.7.1.2), so the 1st–3rd conversions that end after the
//!    flip mix both polarities and the 4th is the first settled one.
//!
//! At OSR 128 with the board's 8 MHz CLKIN ([`crate::clocks::ADC_CLKIN_HZ`], f_MOD = 4 MHz) a conversion
//! takes 32 µs: a phase is about 4 × 32 µs, a pair about 270 µs. The task
//! awaits DRDY (an interrupt on the board), so the CPU is free meanwhile.

use embedded_hal::delay::DelayNs;
use embedded_hal::digital::{InputPin, OutputPin};
use embedded_hal::spi::SpiDevice;
use embedded_hal_async::digital::Wait;

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
/// Set/reset pulse width, µs (HMC1001/1002 datasheet: set/reset pulse
/// ≥ 2 µs).
pub const STRAP_PULSE_US: u32 = 2;
/// Conversions discarded after a strap pulse while the sinc³ filter settles
/// (SBAS890 §8.3.7.1.2: the sinc³ filter spans three conversion periods; a
/// step between two conversions is settled in the fourth).
pub const SETTLE_CONVERSIONS: u8 = 3;
/// Conversions the ADC buffers (SBAS890 §8.5.1.9.1); a drain that reads
/// more than this plus one finds DRDY stuck.
pub const ADC_BUFFERED_CONVERSIONS: u8 = 2;
/// Set/reset pairs per second on the board.
pub const PAIR_RATE_HZ: u32 = 500;
/// SPI frames per pair in steady state: per phase, the settling
/// conversions and the one kept (the drains find nothing buffered).
pub const FRAMES_PER_PAIR: u32 = 2 * (SETTLE_CONVERSIONS as u32 + 1);

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
    /// The DRDY pin could not be read or awaited.
    Drdy,
    /// DRDY stayed asserted through more reads than the ADC can buffer.
    DrdyStuck,
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
    pub fn pulse<D: DelayNs>(&mut self, polarity: Polarity, delay: &mut D) -> Result<(), StrapPinError> {
        match polarity {
            Polarity::Set => pulse_pin(&mut self.set, delay),
            Polarity::Reset => pulse_pin(&mut self.reset, delay),
        }
    }
}

/// A set/reset strap pin refused to change level.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StrapPinError;

fn pulse_pin<P: OutputPin, D: DelayNs>(pin: &mut P, delay: &mut D) -> Result<(), StrapPinError> {
    pin.set_high().map_err(|_| StrapPinError)?;
    delay.delay_us(STRAP_PULSE_US);
    pin.set_low().map_err(|_| StrapPinError)
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
    /// The thermistor channel (CH3), mean of both phases, codes.
    pub temp_code: f32,
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

/// The sensor front end: ADC, its DRDY pin, and the strap.
#[derive(Debug)]
pub struct Acquisition<SPI, S, R, DRDY> {
    adc: Ads131m04<SPI>,
    strap: SetResetStrap<S, R>,
    drdy: DRDY,
    settle_conversions: u8,
    offset: [f32; 3],
    counters: AcqCounters,
}

impl<SPI: SpiDevice, S: OutputPin, R: OutputPin, DRDY: InputPin + Wait> Acquisition<SPI, S, R, DRDY> {
    /// Configures the ADC ([`ADC_OSR`], [`ADC_GAIN`]) and takes the strap
    /// and the DRDY pin.
    pub fn new(spi: SPI, strap: SetResetStrap<S, R>, drdy: DRDY) -> Result<Self, AcqError<SPI::Error>> {
        let mut adc = Ads131m04::new(spi);
        adc.configure(ADC_OSR, ADC_GAIN)?;
        Ok(Self { adc, strap, drdy, settle_conversions: SETTLE_CONVERSIONS, offset: [0.0; 3], counters: AcqCounters::default() })
    }

    /// Changes how many conversions are discarded after a pulse (tests show
    /// what one fewer than [`SETTLE_CONVERSIONS`] does).
    pub fn with_settle_conversions(mut self, n: u8) -> Self {
        self.settle_conversions = n;
        self
    }

    fn drdy_low(&mut self) -> Result<bool, AcqError<SPI::Error>> {
        self.drdy.is_low().map_err(|_| AcqError::Drdy)
    }

    /// Reads out what the ADC has buffered.
    fn drain(&mut self) -> Result<(), AcqError<SPI::Error>> {
        let mut reads = 0u8;
        while self.drdy_low()? {
            if reads > ADC_BUFFERED_CONVERSIONS {
                return Err(AcqError::DrdyStuck);
            }
            self.adc.read()?;
            reads += 1;
        }
        Ok(())
    }

    /// Pulses the strap, waits out the filter's settling on DRDY, and reads
    /// the first settled conversion.
    async fn phase<D: DelayNs>(&mut self, polarity: Polarity, delay: &mut D) -> Result<[i32; 4], AcqError<SPI::Error>> {
        self.drain()?;
        self.strap.pulse(polarity, delay).map_err(|StrapPinError| AcqError::Strap)?;
        // A conversion waiting now ended before or during the pulse.
        self.drain()?;
        let mut last = None;
        for _ in 0..=self.settle_conversions {
            self.drdy.wait_for_low().await.map_err(|_| AcqError::Drdy)?;
            last = Some(self.adc.read()?);
        }
        let c = last.ok_or(AcqError::Drdy)?;
        Ok(c.channels)
    }

    /// Acquires one set/reset pair.
    pub async fn acquire_pair<D: DelayNs>(&mut self, delay: &mut D) -> Result<PairSample, AcqError<SPI::Error>> {
        let result = match self.phase(Polarity::Set, delay).await {
            Ok(s) => self.phase(Polarity::Reset, delay).await.map(|r| (s, r)),
            Err(e) => Err(e),
        };
        let (set, reset) = match result {
            Ok(v) => v,
            Err(e) => {
                self.counters.errors = self.counters.errors.wrapping_add(1);
                return Err(e);
            }
        };
        let [sx, sy, sz, st] = set;
        let [rx, ry, rz, rt] = reset;
        let (set, reset) = ([sx, sy, sz], [rx, ry, rz]);
        let temp_code = ((i64::from(st) + i64::from(rt)) as f32) * 0.5;
        let mut out = PairSample { field_counts: [0.0; 3], offset_counts: [0.0; 3], saturated: false, temp_code };
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
    temp_sum: f32,
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
    /// Temperature at the sensor from the mean thermistor code, °C (`None`:
    /// open or shorted thermistor, [`crate::thermistor::temp_c_of_code`]).
    pub temp_c: Option<f32>,
}

impl Decimator {
    /// Averages `factor` (≥ 1) pairs.
    pub fn new(factor: u16) -> Self {
        Self { factor: factor.max(1), n: 0, sum: [0.0; 3], temp_sum: 0.0, saturated: false, tag: None }
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
        self.temp_sum += p.temp_code;
        self.saturated |= p.saturated;
        self.n += 1;
        if self.n < self.factor {
            return None;
        }
        let inv = 1.0 / f32::from(self.n);
        let out = RawSample {
            field_counts: [self.sum[0] * inv, self.sum[1] * inv, self.sum[2] * inv],
            saturated: self.saturated,
            tag: self.tag.flatten(),
            temp_c: crate::thermistor::temp_c_of_code(self.temp_sum * inv),
        };
        *self = Self::new(self.factor);
        Some(out)
    }
}

/// Runs a future that never has to wait for an interrupt (the model's
/// DRDY, whose waits complete at once) to its end; `None` if it would block.
pub fn run_ready<F: core::future::Future>(f: F) -> Option<F::Output> {
    let mut f = core::pin::pin!(f);
    let mut cx = core::task::Context::from_waker(core::task::Waker::noop());
    match f.as_mut().poll(&mut cx) {
        core::task::Poll::Ready(v) => Some(v),
        core::task::Poll::Pending => None,
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::adc::Ads131m04;
    use crate::ads131m04_model::{model_codes_per_nt, Ads131m04Model, BridgeModel, DrdyPinModel, ModelDelay, StrapPinModel};

    type ModelFrontEnd = Acquisition<Ads131m04Model, StrapPinModel, StrapPinModel, DrdyPinModel>;

    fn front_end(sensor: &'static BridgeModel) -> ModelFrontEnd {
        let strap = SetResetStrap::new(StrapPinModel::set(sensor), StrapPinModel::reset(sensor));
        Acquisition::new(Ads131m04Model::new(sensor), strap, DrdyPinModel::new(sensor)).unwrap()
    }

    fn pair(acq: &mut ModelFrontEnd, sensor: &'static BridgeModel) -> PairSample {
        run_ready(acq.acquire_pair(&mut ModelDelay::new(sensor))).unwrap().unwrap()
    }

    #[test]
    fn the_chain_constant_is_what_the_datasheets_give() {
        // 3.2 mV/V/G × 5 V × 32 / (1.2 V / 2²³) / 10⁵ nT/G = 35.79 counts/nT.
        assert!((COUNTS_PER_NT - 35.7913).abs() < 1e-3, "{COUNTS_PER_NT}");
        // The model's chain, transcribed on its own, agrees.
        assert!((f64::from(COUNTS_PER_NT) / model_codes_per_nt() - 1.0).abs() < 1e-6);
        // ±2 gauss (the sensors' range) stays inside the ADC's range.
        assert!(2e5 * COUNTS_PER_NT < SATURATION_COUNTS as f32);
    }

    #[test]
    fn set_reset_differencing_removes_the_bridge_offset() {
        static SENSOR: BridgeModel = BridgeModel::new();
        let field_nt = [20_000.0f32, -15_000.0, 45_000.0];
        SENSOR.set_truth(field_nt, [40_000.0, -35_000.0, 1_000.0]);
        let mut acq = front_end(&SENSOR);
        let p = pair(&mut acq, &SENSOR);
        for k in 0..3 {
            // Each phase's code is rounded: the half-difference is within a code.
            let want = f64::from(field_nt[k]) * model_codes_per_nt();
            assert!((f64::from(p.field_counts[k]) - want).abs() <= 1.0, "axis {k}: {} vs {want}", p.field_counts[k]);
        }
        assert_eq!(p.offset_counts, [40_000.0, -35_000.0, 1_000.0]);
        assert!(!p.saturated);
        assert_eq!(acq.bridge_offset(), [40_000.0, -35_000.0, 1_000.0]);
        // The offset drifts; the field does not move, the tracker follows.
        SENSOR.set_truth(field_nt, [41_000.0, -35_000.0, 1_000.0]);
        let p2 = pair(&mut acq, &SENSOR);
        assert_eq!(p2.field_counts[0], p.field_counts[0]);
        assert!((acq.bridge_offset()[0] - 40_010.0).abs() < 1e-3);
        assert_eq!(acq.counters().pairs, 2);
    }

    /// The worst field error over pulses placed across a conversion period,
    /// codes, with `settle` conversions discarded.
    fn worst_error_codes(sensor: &'static BridgeModel, settle: u8) -> f64 {
        let field_nt = [45_000.0f32, -30_000.0, 20_000.0];
        sensor.set_truth(field_nt, [10_000.0; 3]);
        let mut acq = front_end(sensor).with_settle_conversions(settle);
        let period = sensor.conversion_period_ns();
        let mut worst = 0.0f64;
        for step in 0..16 {
            // Start the pair at a different point of the conversion grid.
            sensor.advance_ns(period * step / 16 + 3 * period);
            let p = pair(&mut acq, sensor);
            for k in 0..3 {
                let want = f64::from(field_nt[k]) * model_codes_per_nt();
                worst = worst.max((f64::from(p.field_counts[k]) - want).abs());
            }
        }
        worst
    }

    #[test]
    fn the_settle_count_is_what_the_sinc3_filter_needs() {
        static RIGHT: BridgeModel = BridgeModel::new();
        static ONE_FEWER: BridgeModel = BridgeModel::new();
        // Measured: 0.26 codes worst with 3 discards (rounding only); with 2,
        // the third conversion after a flip still holds the old polarity
        // for part of its window, 2 × F₃(x) of the field: 193 761 codes
        // (5 400 nT on a 45 000 nT axis) when the pulse falls late.
        let right = worst_error_codes(&RIGHT, SETTLE_CONVERSIONS);
        let fewer = worst_error_codes(&ONE_FEWER, SETTLE_CONVERSIONS - 1);
        assert!(right <= 1.0, "settled: {right} codes");
        assert!(fewer > 50_000.0, "one discard fewer: only {fewer} codes");
    }

    #[test]
    fn back_to_back_reads_without_drdy_see_the_old_polarity() {
        // The acquisition before this design: pulse, then three "discard"
        // frames and one read straight after, without waiting for DRDY.
        static SENSOR: BridgeModel = BridgeModel::new();
        let field_nt = 45_000.0f32;
        SENSOR.set_truth([field_nt, 0.0, 0.0], [0.0; 3]);
        let mut adc = Ads131m04::new(Ads131m04Model::new(&SENSOR));
        adc.configure(ADC_OSR, ADC_GAIN).unwrap();
        let mut strap = SetResetStrap::new(StrapPinModel::set(&SENSOR), StrapPinModel::reset(&SENSOR));
        let mut delay = ModelDelay::new(&SENSOR);
        let mut phase = |p: Polarity| {
            strap.pulse(p, &mut delay).unwrap();
            for _ in 0..SETTLE_CONVERSIONS {
                adc.read().unwrap();
            }
            adc.read().unwrap().channels[0]
        };
        SENSOR.advance_ns(1_000_000);
        let set = phase(Polarity::Set);
        let reset = phase(Polarity::Reset);
        let got_nt = (f64::from(set) - f64::from(reset)) / 2.0 / model_codes_per_nt();
        // Four frames take 4 × 18 bytes / 21 MHz ≈ 27 µs, less than one
        // 32 µs conversion: both phases read the same buffered conversions
        // from before their pulses, and the field collapses (measured 0 nT
        // for a true 45 000 nT).
        assert!(got_nt.abs() < 1_000.0, "{got_nt} nT");
    }

    #[test]
    fn the_thermistor_channel_gives_the_sensor_temperature() {
        static SENSOR: BridgeModel = BridgeModel::new();
        SENSOR.set_truth([20_000.0, -15_000.0, 45_000.0], [40_000.0, -35_000.0, 1_000.0]);
        let mut acq = front_end(&SENSOR);
        // Between the model's table rows (its R–T interpolation) and away
        // from the driver's Steinhart–Hart points. Measured: 0.11 °C worst (63 °C).
        for t_c in [-5.0f32, 5.0, 15.0, 35.0, 63.0] {
            SENSOR.set_temp_c(t_c);
            let mut dec = Decimator::new(4);
            let out = (0..4).find_map(|_| dec.push(&pair(&mut acq, &SENSOR))).unwrap();
            let got = out.temp_c.unwrap();
            assert!((got - t_c).abs() < 0.3, "{t_c} °C: read {got}");
            // The field is untouched by channel 3.
            assert!((f64::from(out.field_counts[0]) - 20_000.0 * model_codes_per_nt()).abs() <= 1.0);
        }
        // An open thermistor: no temperature.
        SENSOR.set_temp_c(f32::NAN);
        let mut dec = Decimator::new(1);
        assert_eq!(dec.push(&pair(&mut acq, &SENSOR)).unwrap().temp_c, None);
    }

    #[test]
    fn saturation_is_flagged_and_counted() {
        static SENSOR: BridgeModel = BridgeModel::new();
        SENSOR.set_truth([240_000.0, 0.0, 0.0], [0.0; 3]);
        let mut acq = front_end(&SENSOR);
        let p = pair(&mut acq, &SENSOR);
        assert!(p.saturated);
        assert_eq!(acq.counters().saturated, 1);
    }

    #[test]
    fn decimation_averages_and_keeps_saturation() {
        let mut d = Decimator::new(Decimator::factor_for(1000, 250));
        let pair = |v: f32, sat| PairSample { field_counts: [v, 2.0 * v, -v], offset_counts: [0.0; 3], saturated: sat, temp_code: 0.0 };
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
