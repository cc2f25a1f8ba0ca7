//! The board's behaviour, apart from the hardware: requests in, replies out;
//! raw samples in, calibrated samples out. Host-testable; the RTIC app owns
//! one [`Device`] and calls it from its tasks.
//!
//! Coefficient safety:
//! * every set is validated (finite, orientation-preserving, plausible
//!   anisotropy, bias within the ADC range, swing below 1 rad, declination
//!   within ±π, field 10 000–100 000 nT) before it is staged, stored or used;
//! * writes need an unlock (the boot's challenge XOR [`UNLOCK_XOR`]) that
//!   expires, and are refused in mission mode;
//! * a commit must quote the CRC of what was staged, is stored first and used
//!   only once stored (a failed write keeps the old set in use).
//!
//! Current and temperature terms (the calibration document's `current` and
//! `temperature` blocks) are applied to every sample,
//! `h = M·(raw ⊘ (1 + k ⊙ (T − T₀)) − b − c·I)`
//! ([`calib_core::cal::Calibration::apply_tilt_env`]), with:
//! * the temperature `T` measured on the board (the thermistor on ADC
//!   channel 3, [`crate::thermistor`]); when it is missing (open or shorted
//!   thermistor) the sample is corrected at the reference `T₀` (no gain
//!   correction), `Sample::temp_c` is `None`, `Health::temp_missing` counts
//!   it and `Health::env_degraded` is set;
//! * the motor current `I` from [`RequestBody::AttitudeEnv`], stale after
//!   [`ATTITUDE_TIMEOUT_MS`] like the attitude. A stale or never-sent
//!   current counts as 0 A for the field; if the stored current term is
//!   non-zero the sample's heading is withheld (`None`, as for a stale
//!   attitude), `Health::current_stale` counts it and `env_degraded` is
//!   set. With a zero current term the current is not needed.

use calib_core::cal::{Calibration, EnvTerms, Environment, FieldCal, Swing};
use calib_core::heading::Tilt;
use calib_core::fit::{AxisRls, FitError, FullRls, Normalization, SphereRls};
use calib_core::gyro::{GyroConfig, GyroFit, GyroSample, MAX_WINDOW_STEPS};
use calib_core::quality::CoverageMask;
use magcal_protocol::{
    CoefficientSource, Coefficients, ModelKind, FitReport, Health, DeviceError, RequestBody, ResponseBody, Sample, StreamMode,
    ATTITUDE_TIMEOUT_MS, MAX_MOTOR_CURRENT_A, UNLOCK_TIMEOUT_MS, UNLOCK_XOR,
};

use crate::acquisition::{RawSample, COUNTS_PER_NT};
use crate::adc::FULL_SCALE_COUNTS;

/// Where committed coefficients go.
pub trait CoefficientStore {
    /// Stores an encoded set; returns its sequence number.
    fn save(&mut self, bytes: &[u8]) -> Result<u32, SaveFailed>;
}

/// The store could not write a set; the previous one stays in force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SaveFailed;

/// Largest encoded coefficient set.
const PENDING_BYTES: usize = 128;

/// A validated, encoded set waiting to be stored.
#[derive(Debug, Clone)]
pub struct PendingCommit {
    staged: Coefficients,
    calibration: Calibration<f32>,
    bytes: [u8; PENDING_BYTES],
    len: usize,
}

impl PendingCommit {
    /// The record's payload for the store.
    pub fn bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }
}

/// What a request needs next.
#[derive(Debug, Clone)]
pub enum Handled {
    /// The reply, ready.
    Reply(ResponseBody),
    /// A commit to store outside any lock, then [`Device::finish_commit`].
    Save(PendingCommit),
}

/// Field intensities accepted for coefficients and fits, nT.
pub const FIELD_RANGE_NT: (f32, f32) = (10_000.0, 100_000.0);

/// Largest current term accepted, counts per A: 100 A would move a channel
/// through its whole range.
pub const MAX_CURRENT_BIAS_PER_A: f32 = FULL_SCALE_COUNTS as f32 / 100.0;

/// The nominal coefficients: the chain's gain, no bias, no swing, no
/// current or temperature terms.
pub fn default_coefficients() -> Coefficients {
    let g = 1.0 / COUNTS_PER_NT;
    let none = EnvTerms::<f32>::none();
    Coefficients {
        bias: [0.0; 3],
        matrix: [[g, 0.0, 0.0], [0.0, g, 0.0], [0.0, 0.0, g]],
        swing: [0.0; 5],
        declination_rad: 0.0,
        field_nt: 50_000.0,
        current_bias_per_a: none.bias_per_a,
        temp_ref_c: none.ref_c,
        temp_gain_per_c: none.gain_per_c,
    }
}

/// Checks a set against physical bounds and converts it.
pub fn validate(c: &Coefficients) -> Result<Calibration<f32>, DeviceError> {
    let field = FieldCal { bias: c.bias, matrix: c.matrix };
    field.validate(FULL_SCALE_COUNTS as f32).map_err(|_| DeviceError::InvalidCoefficients)?;
    let swing_ok = c.swing.iter().all(|v| v.is_finite() && v.abs() < 1.0);
    let decl_ok = c.declination_rad.is_finite() && c.declination_rad.abs() <= core::f32::consts::PI;
    let field_ok = c.field_nt >= FIELD_RANGE_NT.0 && c.field_nt <= FIELD_RANGE_NT.1;
    // A gain far from the chain's means the set was made for another sensor.
    let gain = (c.matrix[0][0].abs() + c.matrix[1][1].abs() + c.matrix[2][2].abs()) / 3.0 * COUNTS_PER_NT;
    if !(swing_ok && decl_ok && field_ok && gain > 0.2 && gain < 5.0) {
        return Err(DeviceError::InvalidCoefficients);
    }
    let env = c.env_terms();
    env.validate(MAX_CURRENT_BIAS_PER_A).map_err(|_| DeviceError::InvalidCoefficients)?;
    Ok(Calibration { field, swing: Swing::from_array(c.swing), declination_rad: c.declination_rad, env })
}

/// The next unlock challenge (FNV-1a of the old one and the time): not a
/// secret, only never the same twice in a row.
fn next_challenge(old: u32, now_ms: u32) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    for b in old.to_le_bytes().into_iter().chain(now_ms.to_le_bytes()) {
        h = (h ^ u32::from(b)).wrapping_mul(0x0100_0193);
    }
    if h == old { h.wrapping_add(1) } else { h }
}

/// Postcard-encodes a set for the store.
pub fn encode_coefficients(c: &Coefficients, buf: &mut [u8]) -> Option<usize> {
    postcard::to_slice(c, buf).ok().map(|b| b.len())
}

/// A set as store record version 1 held it (protocol 2, before the current
/// and temperature terms): bias, matrix, swing, declination, field — the
/// postcard encoding of a struct is that of the tuple of its fields.
type CoefficientsV1 = ([f32; 3], [[f32; 3]; 3], [f32; 5], f32, f32);

/// Decodes and validates a stored set of store record `version`
/// ([`crate::store::VERSION`]; a version-1 record loads with no current or
/// temperature terms).
pub fn decode_coefficients(bytes: &[u8], version: u16) -> Option<(Coefficients, Calibration<f32>)> {
    let c: Coefficients = match version {
        1 => {
            let (bias, matrix, swing, declination_rad, field_nt): CoefficientsV1 = postcard::from_bytes(bytes).ok()?;
            let none = EnvTerms::<f32>::none();
            Coefficients { bias, matrix, swing, declination_rad, field_nt, current_bias_per_a: none.bias_per_a, temp_ref_c: none.ref_c, temp_gain_per_c: none.gain_per_c }
        }
        crate::store::VERSION => postcard::from_bytes(bytes).ok()?,
        _ => return None,
    };
    let cal = validate(&c).ok()?;
    Some((c, cal))
}

enum Rls {
    Sphere(SphereRls<f32>),
    Axis(AxisRls<f32>),
    Full(FullRls<f32>),
    /// The gyro-aided fit, with the board time it started (its samples'
    /// times count from there, so `f32` keeps millisecond resolution).
    Gyro(GyroFit<f32>, u32),
}

/// Body rates and attitude from the AHRS ([`RequestBody::Motion`]), with the
/// board time they arrived.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Motion {
    roll_rad: f32,
    pitch_rad: f32,
    rate_rad_s: [f32; 3],
    at_ms: u32,
}

/// The largest body rate a [`RequestBody::Motion`] may carry, rad/s
/// (2 000°/s, a MEMS gyro's widest range).
const MAX_RATE_RAD_S: f32 = 35.0;

/// The gyro-aided fit's integration window on the board, s (as the host's
/// `host_tools::compute::gyro::WINDOW_S`).
const GYRO_WINDOW_S: f32 = 0.7;

struct OnboardFit {
    model: ModelKind,
    field_nt: f32,
    rls: Rls,
    coverage: CoverageMask,
    running: bool,
    /// The latest samples, for the residual of the current estimate.
    recent: heapless::Deque<[f32; 3], RECENT>,
    /// Samples refused as implausible.
    rejected: u32,
}

/// Samples kept for the fit's residual.
const RECENT: usize = 32;

impl OnboardFit {
    /// `None` for a model the board does not fit (triangular: fit `full`,
    /// the same calibration, and factor it on the host; attitude: a batch
    /// fit on the host's recording). The gyro-aided fit
    /// integrates the rates of [`RequestBody::Motion`] between output
    /// samples (`output_rate_hz`).
    fn new(model: ModelKind, field_nt: f32, centre: [f32; 3], output_rate_hz: u8, now_ms: u32) -> Option<Self> {
        let norm = Normalization { centre, scale: field_nt * COUNTS_PER_NT };
        let rls = match model {
            ModelKind::Sphere => Rls::Sphere(SphereRls::new(norm)),
            ModelKind::Axis => Rls::Axis(AxisRls::new(norm)),
            ModelKind::Full => Rls::Full(FullRls::new(norm)),
            ModelKind::Gyro => {
                let period_s = 1.0 / f32::from(output_rate_hz.max(1));
                let mut cfg = GyroConfig::new(3.0 * period_s);
                cfg.window_steps = ((GYRO_WINDOW_S / period_s + 0.5) as usize).clamp(1, MAX_WINDOW_STEPS);
                Rls::Gyro(GyroFit::new(norm, cfg), now_ms)
            }
            ModelKind::Triangular | ModelKind::Attitude => return None,
        };
        Some(Self { model, field_nt, rls, coverage: CoverageMask::new(), running: true, recent: heapless::Deque::new(), rejected: 0 })
    }

    /// Absorbs a sample; refuses (`false`) one whose distance from the
    /// fit's centre is implausible for the reference field (a dead channel,
    /// a stuck feed, a magnet held against the hull).
    fn push(&mut self, raw: [f32; 3], motion: Option<Motion>, now_ms: u32) -> bool {
        let c = self.centre();
        let d = [raw[0] - c[0], raw[1] - c[1], raw[2] - c[2]];
        let r = calib_core::real::sqrt_f32(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        let expected = self.field_nt * COUNTS_PER_NT;
        if !(r > 0.5 * expected && r < 2.0 * expected) {
            self.rejected = self.rejected.saturating_add(1);
            return false;
        }
        match &mut self.rls {
            Rls::Sphere(r) => {
                r.push(raw);
            }
            Rls::Axis(r) => {
                r.push(raw);
            }
            Rls::Full(r) => {
                r.push(raw);
            }
            Rls::Gyro(g, start_ms) => {
                // Without fresh rates the sample breaks the chain of
                // integrated rotations (NaN rates are refused by the fit).
                let fresh = motion.filter(|m| now_ms.wrapping_sub(m.at_ms) <= ATTITUDE_TIMEOUT_MS);
                let (rate_rad_s, roll_rad, pitch_rad) = match fresh {
                    Some(m) => (m.rate_rad_s, m.roll_rad, m.pitch_rad),
                    None => ([f32::NAN; 3], f32::NAN, f32::NAN),
                };
                let t_s = now_ms.wrapping_sub(*start_ms) as f32 / 1000.0;
                if !g.push(&GyroSample { t_s, raw, rate_rad_s, roll_rad, pitch_rad }) {
                    self.rejected = self.rejected.saturating_add(1);
                    return false;
                }
            }
        };
        self.coverage.add(d);
        if self.recent.is_full() {
            self.recent.pop_front();
        }
        let _ = self.recent.push_back(raw);
        true
    }

    /// RMS of |h| − F over the latest samples with the current estimate.
    fn residual_rms_nt(&self, est: &FieldCal<f32>) -> f32 {
        let (mut ss, mut n) = (0.0f32, 0u32);
        for raw in self.recent.iter() {
            let h = est.apply(*raw);
            let r = calib_core::real::sqrt_f32(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]) - self.field_nt;
            ss += r * r;
            n += 1;
        }
        if n == 0 { 0.0 } else { calib_core::real::sqrt_f32(ss / n as f32) }
    }

    fn centre(&self) -> [f32; 3] {
        match &self.rls {
            Rls::Sphere(r) => r.normalization().centre,
            Rls::Axis(r) => r.normalization().centre,
            Rls::Full(r) => r.normalization().centre,
            Rls::Gyro(g, _) => g.normalization().centre,
        }
    }

    fn count(&self) -> u32 {
        match &self.rls {
            Rls::Sphere(r) => r.count(),
            Rls::Axis(r) => r.count(),
            Rls::Full(r) => r.count(),
            Rls::Gyro(g, _) => g.kinematic_windows(),
        }
    }

    fn estimate(&self) -> Result<FieldCal<f32>, FitError> {
        match &self.rls {
            Rls::Sphere(r) => r.estimate(self.field_nt),
            Rls::Axis(r) => r.estimate(self.field_nt),
            Rls::Full(r) => r.estimate(self.field_nt),
            Rls::Gyro(g, _) => g.estimate(self.field_nt).map(|e| e.cal),
        }
    }
}

/// The boot challenge the fuzz target's seed corpus is written for
/// (`fuzz/seeds/frame_decoder/`): its unlock frames carry
/// `FUZZ_CHALLENGE ^ UNLOCK_XOR`.
pub const FUZZ_CHALLENGE: u32 = 0x5EED;

/// The counters a status report needs that the device does not own: the
/// acquisition's, the link's, the UARTs' and the sensor feed's. The app
/// reads them when a request arrives and hands them to [`Device::handle`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct BoardCounters {
    /// Set/reset pairs acquired.
    pub pairs: u32,
    /// Pairs with a saturated channel.
    pub saturated: u32,
    /// ADC errors.
    pub acq_errors: u32,
    /// Acquisition deadlines missed.
    pub overruns: u32,
    /// Received bytes dropped (queue full, UART errors).
    pub rx_dropped: u32,
    /// Reply or sample frames dropped (transmit queue full).
    pub tx_dropped: u32,
    /// Damaged frames received.
    pub bad_frames: u32,
    /// Requests served.
    pub requests: u32,
    /// Sensor-feed frames applied (QEMU board).
    pub feed_updates: u32,
    /// Longest gap between two acquired pairs, ms.
    pub max_acq_gap_ms: u32,
    /// Coefficient saves done.
    pub store_saves: u32,
    /// Longest save, ms.
    pub max_store_ms: u32,
}

/// Counters the device keeps (the link and acquisition keep their own).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DeviceCounters {
    /// Output samples produced.
    pub samples: u32,
    /// Samples whose heading was withheld for a stale or missing current.
    pub current_stale: u32,
    /// Samples without a valid temperature.
    pub temp_missing: u32,
}

/// The board's state.
pub struct Device {
    coefficients: Coefficients,
    calibration: Calibration<f32>,
    source: CoefficientSource,
    seq: u32,
    staged: Option<Coefficients>,
    unlocked_until_ms: Option<u32>,
    challenge: u32,
    mission: bool,
    stream: StreamMode,
    output_rate_hz: u8,
    attitude: Option<(Tilt<f32>, u32)>,
    motion: Option<Motion>,
    /// The motor current from [`RequestBody::AttitudeEnv`], A, with the board
    /// time it arrived.
    current: Option<(f32, u32)>,
    /// The last valid temperature, °C.
    last_temp_c: Option<f32>,
    /// The last sample used a stale current or a missing temperature.
    env_degraded: bool,
    fit: Option<OnboardFit>,
    last_error: Option<DeviceError>,
    counters: DeviceCounters,
}

/// Coefficients recovered from the store at boot.
pub struct Boot {
    /// The stored set, if one was valid.
    pub stored: Option<(Coefficients, u32)>,
    /// The unlock challenge for this boot.
    pub challenge: u32,
}

impl Device {
    /// The device after boot: the stored set if valid, else the defaults
    /// (and `last_error` says so).
    pub fn new(boot: Boot) -> Self {
        let (coefficients, source, seq, calibration, last_error) = match boot.stored.and_then(|(c, s)| validate(&c).ok().map(|cal| (c, s, cal))) {
            Some((c, s, cal)) => (c, CoefficientSource::Stored, s, cal, None),
            None => {
                let c = default_coefficients();
                let cal = validate(&c).unwrap_or_else(|_| Calibration::identity());
                (c, CoefficientSource::Default, 0, cal, Some(DeviceError::Storage))
            }
        };
        Self {
            coefficients,
            calibration,
            source,
            seq,
            staged: None,
            unlocked_until_ms: None,
            challenge: boot.challenge,
            mission: false,
            stream: StreamMode::Off,
            output_rate_hz: 10,
            attitude: None,
            motion: None,
            current: None,
            last_temp_c: None,
            env_degraded: false,
            fit: None,
            last_error,
            counters: DeviceCounters::default(),
        }
    }

    /// The output rate asked for, Hz.
    pub fn output_rate_hz(&self) -> u8 {
        self.output_rate_hz
    }

    /// What is streamed.
    pub fn stream(&self) -> StreamMode {
        self.stream
    }

    /// The calibration in use.
    pub fn calibration(&self) -> &Calibration<f32> {
        &self.calibration
    }

    fn unlocked(&self, now_ms: u32) -> bool {
        self.unlocked_until_ms.is_some_and(|t| now_ms.wrapping_sub(t) as i32 <= 0) && !self.mission
    }

    fn refuse(&mut self, e: DeviceError) -> ResponseBody {
        self.last_error = Some(e);
        ResponseBody::Error(e)
    }

    fn fit_report(&self) -> FitReport {
        match &self.fit {
            None => FitReport { running: false, model: None, samples: 0, coverage_pct: 0, residual_rms_nt: 0.0, estimate: None },
            Some(f) => {
                let fitted = f.estimate().ok();
                let residual_rms_nt = fitted.as_ref().map(|e| f.residual_rms_nt(e)).unwrap_or(0.0);
                let estimate = fitted.map(|cal| Coefficients {
                    bias: cal.bias,
                    matrix: cal.matrix,
                    swing: self.coefficients.swing,
                    declination_rad: self.coefficients.declination_rad,
                    field_nt: f.field_nt,
                    current_bias_per_a: self.coefficients.current_bias_per_a,
                    temp_ref_c: self.coefficients.temp_ref_c,
                    temp_gain_per_c: self.coefficients.temp_gain_per_c,
                });
                let estimate = estimate.filter(|c| validate(c).is_ok());
                FitReport {
                    running: f.running,
                    model: Some(f.model),
                    samples: f.count(),
                    coverage_pct: f.coverage.percent(),
                    residual_rms_nt,
                    estimate,
                }
            }
        }
    }

    /// Serves one request. `board` holds the counters the device does not
    /// own (acquisition, link, UART, feed), for a status report.
    pub fn handle(&mut self, req: &RequestBody, now_ms: u32, store: &mut impl CoefficientStore, board: &BoardCounters) -> ResponseBody {
        match self.handle_request(req, now_ms, board) {
            Handled::Reply(body) => body,
            Handled::Save(pending) => {
                let saved = store.save(pending.bytes());
                self.finish_commit(pending, saved)
            }
        }
    }

    /// [`Device::handle`] without the store: a commit that passed every
    /// check comes back as [`Handled::Save`], for the caller to store
    /// outside any lock (an erase stalls the CPU for up to 800 ms) and hand
    /// back to [`Device::finish_commit`].
    pub fn handle_request(&mut self, req: &RequestBody, now_ms: u32, board: &BoardCounters) -> Handled {
        Handled::Reply(match *req {
            // Answered by the link layer; here for completeness.
            RequestBody::Ping { nonce } => ResponseBody::Pong { nonce },
            RequestBody::Identify => ResponseBody::Error(DeviceError::Unsupported),
            RequestBody::Status => ResponseBody::Status(self.health(now_ms, board)),
            RequestBody::SetStream(_) | RequestBody::SetOutputRate { .. } | RequestBody::Attitude { .. } | RequestBody::Motion { .. } | RequestBody::AttitudeEnv { .. } => {
                self.handle_output(req, now_ms)
            }
            RequestBody::FitStart { .. } | RequestBody::FitStop | RequestBody::FitQuery => self.handle_fit(req, now_ms),
            RequestBody::ReadCoefficients | RequestBody::Unlock { .. } | RequestBody::WriteCoefficients(_) | RequestBody::Commit { .. } => {
                return self.handle_coefficients(req, now_ms);
            }
            RequestBody::SetMissionMode { enabled } => {
                self.mission = enabled;
                if enabled {
                    self.unlocked_until_ms = None;
                    self.staged = None;
                }
                ResponseBody::Ack
            }
        })
    }

    /// Ends a commit after the store: the set is used only once stored; a
    /// failed save keeps the old set in use and says so.
    pub fn finish_commit(&mut self, pending: PendingCommit, saved: Result<u32, SaveFailed>) -> ResponseBody {
        match saved {
            Ok(seq) => {
                self.coefficients = pending.staged;
                self.calibration = pending.calibration;
                self.source = CoefficientSource::Stored;
                self.seq = seq;
                self.staged = None;
                self.unlocked_until_ms = None;
                self.last_error = None;
                ResponseBody::Committed { seq }
            }
            Err(SaveFailed) => self.refuse(DeviceError::Storage),
        }
    }

    /// The one health snapshot: the device's own state and `board`'s counters.
    pub fn health(&self, now_ms: u32, board: &BoardCounters) -> Health {
        Health {
            uptime_ms: now_ms,
            pairs: board.pairs,
            samples: self.counters.samples,
            saturated: board.saturated,
            acq_errors: board.acq_errors,
            overruns: board.overruns,
            rx_dropped: board.rx_dropped,
            tx_dropped: board.tx_dropped,
            bad_frames: board.bad_frames,
            requests: board.requests,
            mission_mode: self.mission,
            unlocked: self.unlocked(now_ms),
            unlock_challenge: self.challenge,
            coefficient_source: self.source,
            coefficient_seq: self.seq,
            last_error: self.last_error,
            output_rate_hz: self.output_rate_hz,
            stream: self.stream,
            feed_updates: board.feed_updates,
            max_acq_gap_ms: board.max_acq_gap_ms,
            store_saves: board.store_saves,
            max_store_ms: board.max_store_ms,
            current_stale: self.counters.current_stale,
            temp_missing: self.counters.temp_missing,
            temp_c: self.last_temp_c,
            env_degraded: self.env_degraded,
        }
    }

    /// What the board streams and how: stream mode, output rate, attitude.
    fn handle_output(&mut self, req: &RequestBody, now_ms: u32) -> ResponseBody {
        match *req {
            RequestBody::SetStream(mode) => {
                self.stream = mode;
                ResponseBody::Ack
            }
            RequestBody::SetOutputRate { hz } => {
                if !(1..=100).contains(&hz) {
                    return self.refuse(DeviceError::BadArgument);
                }
                self.output_rate_hz = hz;
                ResponseBody::Ack
            }
            RequestBody::Attitude { roll_rad, pitch_rad } => {
                let ok = roll_rad.is_finite() && pitch_rad.is_finite() && roll_rad.abs() <= core::f32::consts::PI && pitch_rad.abs() <= core::f32::consts::FRAC_PI_2;
                if !ok {
                    return self.refuse(DeviceError::BadArgument);
                }
                // The trigonometry once per attitude, not once per sample.
                self.attitude = Some((Tilt::new(roll_rad, pitch_rad), now_ms));
                ResponseBody::Ack
            }
            RequestBody::Motion { roll_rad, pitch_rad, rate_rad_s } => {
                let ok = roll_rad.is_finite()
                    && pitch_rad.is_finite()
                    && roll_rad.abs() <= core::f32::consts::PI
                    && pitch_rad.abs() <= core::f32::consts::FRAC_PI_2
                    && rate_rad_s.iter().all(|w| w.is_finite() && w.abs() <= MAX_RATE_RAD_S);
                if !ok {
                    return self.refuse(DeviceError::BadArgument);
                }
                self.attitude = Some((Tilt::new(roll_rad, pitch_rad), now_ms));
                self.motion = Some(Motion { roll_rad, pitch_rad, rate_rad_s, at_ms: now_ms });
                ResponseBody::Ack
            }
            RequestBody::AttitudeEnv { roll_rad, pitch_rad, motor_current_a } => {
                let ok = roll_rad.is_finite()
                    && pitch_rad.is_finite()
                    && roll_rad.abs() <= core::f32::consts::PI
                    && pitch_rad.abs() <= core::f32::consts::FRAC_PI_2
                    && motor_current_a.is_finite()
                    && motor_current_a.abs() <= MAX_MOTOR_CURRENT_A;
                if !ok {
                    return self.refuse(DeviceError::BadArgument);
                }
                self.attitude = Some((Tilt::new(roll_rad, pitch_rad), now_ms));
                self.current = Some((motor_current_a, now_ms));
                ResponseBody::Ack
            }
            _ => ResponseBody::Error(DeviceError::Unsupported),
        }
    }

    /// The on-board fit: start, stop, query.
    fn handle_fit(&mut self, req: &RequestBody, now_ms: u32) -> ResponseBody {
        match *req {
            RequestBody::FitStart { model, field_nt } => {
                if !(field_nt >= FIELD_RANGE_NT.0 && field_nt <= FIELD_RANGE_NT.1) {
                    return self.refuse(DeviceError::BadArgument);
                }
                let Some(fit) = OnboardFit::new(model, field_nt, self.calibration.field.bias, self.output_rate_hz, now_ms) else {
                    return self.refuse(DeviceError::Unsupported);
                };
                self.fit = Some(fit);
                ResponseBody::Fit(self.fit_report())
            }
            RequestBody::FitStop => {
                if let Some(f) = &mut self.fit {
                    f.running = false;
                }
                ResponseBody::Fit(self.fit_report())
            }
            RequestBody::FitQuery => ResponseBody::Fit(self.fit_report()),
            _ => ResponseBody::Error(DeviceError::Unsupported),
        }
    }

    /// The coefficients: read, unlock, stage, commit (validated, stored,
    /// then used).
    fn handle_coefficients(&mut self, req: &RequestBody, now_ms: u32) -> Handled {
        if let RequestBody::Commit { crc } = *req {
            return self.prepare_commit(crc, now_ms);
        }
        Handled::Reply(match *req {
            RequestBody::ReadCoefficients => ResponseBody::Coefficients { coefficients: self.coefficients, source: self.source, seq: self.seq },
            RequestBody::Unlock { key } => {
                if self.mission {
                    return Handled::Reply(self.refuse(DeviceError::MissionMode));
                }
                if key != self.challenge ^ UNLOCK_XOR {
                    return Handled::Reply(self.refuse(DeviceError::BadKey));
                }
                self.unlocked_until_ms = Some(now_ms.wrapping_add(UNLOCK_TIMEOUT_MS));
                // One key, one unlock: a replayed Unlock frame is refused.
                self.challenge = next_challenge(self.challenge, now_ms);
                ResponseBody::Ack
            }
            RequestBody::WriteCoefficients(c) => {
                if self.mission {
                    return Handled::Reply(self.refuse(DeviceError::MissionMode));
                }
                if !self.unlocked(now_ms) {
                    return Handled::Reply(self.refuse(DeviceError::Locked));
                }
                if validate(&c).is_err() {
                    return Handled::Reply(self.refuse(DeviceError::InvalidCoefficients));
                }
                self.staged = Some(c);
                ResponseBody::Ack
            }
            _ => ResponseBody::Error(DeviceError::Unsupported),
        })
    }

    /// Checks a commit and encodes the staged set for the store.
    fn prepare_commit(&mut self, crc: u32, now_ms: u32) -> Handled {
        if self.mission {
            return Handled::Reply(self.refuse(DeviceError::MissionMode));
        }
        if !self.unlocked(now_ms) {
            return Handled::Reply(self.refuse(DeviceError::Locked));
        }
        let Some(staged) = self.staged else {
            return Handled::Reply(self.refuse(DeviceError::NothingStaged));
        };
        if staged.crc() != crc {
            return Handled::Reply(self.refuse(DeviceError::CommitMismatch));
        }
        let Ok(calibration) = validate(&staged) else {
            return Handled::Reply(self.refuse(DeviceError::InvalidCoefficients));
        };
        let mut bytes = [0u8; PENDING_BYTES];
        let Some(len) = encode_coefficients(&staged, &mut bytes) else {
            return Handled::Reply(self.refuse(DeviceError::Storage));
        };
        Handled::Save(PendingCommit { staged, calibration, bytes, len })
    }

    /// Processes one decimated raw sample: applies the current and
    /// temperature terms (see the module doc for stale or missing inputs),
    /// feeds the corrected sample to the on-board fit, applies the
    /// coefficients and the heading (with a fresh attitude, and a fresh
    /// current when the current term needs one), and returns the sample to
    /// stream, if streaming.
    pub fn on_raw_sample(&mut self, raw: &RawSample, now_ms: u32) -> Option<Sample> {
        self.counters.samples = self.counters.samples.wrapping_add(1);
        let terms = &self.calibration.env;
        let fresh = |t: u32| now_ms.wrapping_sub(t) <= ATTITUDE_TIMEOUT_MS;
        let current_a = self.current.filter(|&(_, t)| fresh(t)).map(|(i, _)| i);
        let current_ok = current_a.is_some() || terms.bias_per_a.iter().all(|b| *b == 0.0);
        let temp_c = raw.temp_c;
        let env = Environment { current_a: current_a.unwrap_or(0.0), temp_c: temp_c.unwrap_or(terms.ref_c) };
        match temp_c {
            Some(t) => self.last_temp_c = Some(t),
            None => self.counters.temp_missing = self.counters.temp_missing.wrapping_add(1),
        }
        if !current_ok {
            self.counters.current_stale = self.counters.current_stale.wrapping_add(1);
        }
        self.env_degraded = temp_c.is_none() || !current_ok;
        let tilt = self.attitude.filter(|&(_, t)| fresh(t)).map(|(tilt, _)| tilt);
        // The document's formula, as calib-core applies it (~260
        // instructions a sample with the heading: `cargo xtask bench`).
        // (`apply_tilt_env` is `correct_raw` then `apply_tilt`: the corrected
        // sample is kept for the fit.)
        let corrected = terms.correct_raw(raw.field_counts, &env);
        let (field, heading_rad) = match tilt {
            Some(tilt) => {
                let out = self.calibration.apply_tilt(corrected, &tilt);
                (out.field_nt, current_ok.then_some(out.true_heading_rad))
            }
            None => (self.calibration.field.apply(corrected), None),
        };
        if let Some(f) = &mut self.fit {
            if f.running && !raw.saturated {
                // The fit estimates the field calibration of the corrected
                // sample (the terms stay as stored).
                f.push(corrected, self.motion, now_ms);
            }
        }
        let (raw_out, cal_out) = match self.stream {
            StreamMode::Off => return None,
            StreamMode::Raw => (Some(raw.field_counts), None),
            StreamMode::Calibrated => (None, Some(field)),
            StreamMode::Both => (Some(raw.field_counts), Some(field)),
        };
        Some(Sample {
            t_ms: now_ms,
            raw: raw_out,
            field_nt: cal_out,
            heading_rad: heading_rad.filter(|_| cal_out.is_some()),
            saturated: raw.saturated,
            feed_seq: raw.tag,
            temp_c,
        })
    }
}

#[cfg(test)]
mod tests;
