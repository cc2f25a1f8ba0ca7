//! The coefficient sets: the physical checks, the nominal set, the store's
//! encoding (record versions 1, 2 and 3), and the read / write / commit
//! requests, held by the coefficient bank ([`Bank`]: in use, staged,
//! sequence and the write lock of [`super::unlock`]).

use calib_core::cal::{Calibration, EnvTerms, FieldCal, Swing};
use magcal_protocol::endpoint::{Commit, Committed, InUse};
use magcal_protocol::{CoefficientSource, Coefficients, DeviceError, Endpoint, Reply, ResponseBody};

use super::unlock::WriteLock;
use super::Device;
use crate::acquisition::COUNTS_PER_NT;
use crate::adc::FULL_SCALE_COUNTS;

/// Where committed coefficients go.
pub trait CoefficientStore {
    /// Stores an encoded set; returns its sequence number.
    fn save(&mut self, bytes: &[u8]) -> Result<u32, SaveFailed>;
}

/// The store could not write a set; the previous one stays in force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SaveFailed;

/// A validated, encoded set waiting to be stored.
#[derive(Debug, Clone)]
pub struct PendingCommit {
    staged: Coefficients,
    calibration: Calibration<f32>,
    bytes: [u8; Coefficients::MAX_ENCODED_LEN],
    len: usize,
}

impl PendingCommit {
    /// The record's payload for the store.
    pub fn bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }
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
        inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION,
    }
}

/// Checks a set against physical bounds and converts it.
pub fn validate(c: &Coefficients) -> Result<Calibration<f32>, DeviceError> {
    let field = FieldCal { bias: c.bias, matrix: c.matrix };
    field.validate(FULL_SCALE_COUNTS as f32).map_err(|_| DeviceError::InvalidCoefficients)?;
    let swing_ok = c.swing.iter().all(|v| v.is_finite() && v.abs() < 1.0);
    let decl_ok = c.declination_rad.is_finite() && c.declination_rad.abs() <= core::f32::consts::PI;
    let field_ok = c.field_nt >= FIELD_RANGE_NT.0 && c.field_nt <= FIELD_RANGE_NT.1;
    // None, or a dip strictly between the horizon and the vertical.
    let incl_ok = c.inclination().is_none_or(|i| i.abs() < core::f32::consts::FRAC_PI_2);
    // A gain far from the chain's means the set was made for another sensor.
    let gain = (c.matrix[0][0].abs() + c.matrix[1][1].abs() + c.matrix[2][2].abs()) / 3.0 * COUNTS_PER_NT;
    if !(swing_ok && decl_ok && field_ok && incl_ok && gain > 0.2 && gain < 5.0) {
        return Err(DeviceError::InvalidCoefficients);
    }
    let env = c.env_terms();
    env.validate(MAX_CURRENT_BIAS_PER_A).map_err(|_| DeviceError::InvalidCoefficients)?;
    Ok(Calibration { field, swing: Swing::from_array(c.swing), declination_rad: c.declination_rad, env })
}

/// Postcard-encodes a set for the store (at most
/// [`Coefficients::MAX_ENCODED_LEN`] bytes).
pub fn encode_coefficients(c: &Coefficients, buf: &mut [u8]) -> Option<usize> {
    postcard::to_slice(c, buf).ok().map(|b| b.len())
}

/// A set as store record version 1 held it (protocol 2, before the current
/// and temperature terms): bias, matrix, swing, declination, field — the
/// postcard encoding of a struct is that of the tuple of its fields.
type CoefficientsV1 = ([f32; 3], [[f32; 3]; 3], [f32; 5], f32, f32);

/// A set as store record version 2 held it (protocol 3 and 4, before the
/// reference inclination).
type CoefficientsV2 = ([f32; 3], [[f32; 3]; 3], [f32; 5], f32, f32, [f32; 3], f32, [f32; 3]);

/// Decodes and validates a stored set of store record `version`
/// ([`crate::store::VERSION`]; a version-1 record loads with no current or
/// temperature terms, a version-1 or -2 record with no reference inclination).
pub fn decode_coefficients(bytes: &[u8], version: u16) -> Option<(Coefficients, Calibration<f32>)> {
    let c: Coefficients = match version {
        1 => {
            let (bias, matrix, swing, declination_rad, field_nt): CoefficientsV1 = postcard::from_bytes(bytes).ok()?;
            let none = EnvTerms::<f32>::none();
            Coefficients { bias, matrix, swing, declination_rad, field_nt, current_bias_per_a: none.bias_per_a, temp_ref_c: none.ref_c, temp_gain_per_c: none.gain_per_c, inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION }
        }
        2 => {
            let (bias, matrix, swing, declination_rad, field_nt, current_bias_per_a, temp_ref_c, temp_gain_per_c): CoefficientsV2 = postcard::from_bytes(bytes).ok()?;
            Coefficients { bias, matrix, swing, declination_rad, field_nt, current_bias_per_a, temp_ref_c, temp_gain_per_c, inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION }
        }
        crate::store::VERSION => postcard::from_bytes(bytes).ok()?,
        _ => return None,
    };
    let cal = validate(&c).ok()?;
    Some((c, cal))
}

/// The coefficient bank: the set in use (with its calibration, where it
/// came from and its store sequence number), the staged set, and the write
/// lock. It alone changes them: a set is staged only unlocked and valid,
/// and used only once stored.
#[derive(Debug, Clone)]
pub(super) struct Bank {
    in_use: Coefficients,
    calibration: Calibration<f32>,
    source: CoefficientSource,
    seq: u32,
    staged: Option<Coefficients>,
    lock: WriteLock,
}

impl Bank {
    /// The bank after boot: the stored set if valid, else the defaults and
    /// the error that says so.
    pub(super) fn boot(stored: Option<(Coefficients, u32)>, challenge: u32) -> (Self, Option<DeviceError>) {
        let (in_use, source, seq, calibration, error) = match stored.and_then(|(c, s)| validate(&c).ok().map(|cal| (c, s, cal))) {
            Some((c, s, cal)) => (c, CoefficientSource::Stored, s, cal, None),
            None => {
                let c = default_coefficients();
                let cal = validate(&c).unwrap_or_else(|_| Calibration::identity());
                (c, CoefficientSource::Default, 0, cal, Some(DeviceError::Storage))
            }
        };
        (Self { in_use, calibration, source, seq, staged: None, lock: WriteLock::new(challenge) }, error)
    }

    /// The set in use.
    pub(super) fn coefficients(&self) -> &Coefficients {
        &self.in_use
    }

    /// The set in use, converted.
    pub(super) fn calibration(&self) -> &Calibration<f32> {
        &self.calibration
    }

    /// Where the set in use came from.
    pub(super) fn source(&self) -> CoefficientSource {
        self.source
    }

    /// The store's sequence number of the set in use (0 for the defaults).
    pub(super) fn seq(&self) -> u32 {
        self.seq
    }

    /// The write lock (its state, for a status report).
    pub(super) fn lock(&self) -> &WriteLock {
        &self.lock
    }

    /// Mission mode on or off; turning it on drops a staged set.
    pub(super) fn set_mission(&mut self, enabled: bool) {
        self.lock.set_mission(enabled);
        if enabled {
            self.staged = None;
        }
    }

    /// The set in use, where it came from and its record's sequence.
    pub(super) fn in_use(&self) -> InUse {
        InUse { coefficients: self.in_use, source: self.source, seq: self.seq }
    }

    /// Unlocks writes with the challenge's answer.
    pub(super) fn unlock(&mut self, key: u32, now_ms: u32) -> Result<(), DeviceError> {
        self.lock.unlock(key, now_ms)
    }

    /// Stages a set: unlocked, outside mission mode, valid.
    pub(super) fn stage(&mut self, c: Coefficients, now_ms: u32) -> Result<(), DeviceError> {
        self.lock.check_write(now_ms)?;
        validate(&c)?;
        self.staged = Some(c);
        Ok(())
    }

    /// Checks a commit and encodes the staged set for the store (stored by
    /// the caller, then handed to [`Bank::finish_commit`]).
    pub(super) fn prepare_commit(&mut self, crc: u32, now_ms: u32) -> Result<PendingCommit, DeviceError> {
        self.lock.check_write(now_ms)?;
        let staged = self.staged.ok_or(DeviceError::NothingStaged)?;
        if staged.crc() != crc {
            return Err(DeviceError::CommitMismatch);
        }
        let calibration = validate(&staged)?;
        let mut bytes = [0u8; Coefficients::MAX_ENCODED_LEN];
        let len = encode_coefficients(&staged, &mut bytes).ok_or(DeviceError::Storage)?;
        Ok(PendingCommit { staged, calibration, bytes, len })
    }

    /// Ends a commit after the store: the set is used only once stored (and
    /// the lock is spent); a failed save keeps the old set in use. Returns
    /// the new set's sequence number.
    pub(super) fn finish_commit(&mut self, pending: &PendingCommit, saved: Result<u32, SaveFailed>) -> Result<u32, DeviceError> {
        let seq = saved.map_err(|SaveFailed| DeviceError::Storage)?;
        self.in_use = pending.staged;
        self.calibration = pending.calibration;
        self.source = CoefficientSource::Stored;
        self.seq = seq;
        self.staged = None;
        self.lock.relock();
        Ok(seq)
    }
}

impl Device {
    /// Ends a commit after the store ([`Bank::finish_commit`]); a new set
    /// in use restarts the integrity monitor on its field.
    pub fn finish_commit(&mut self, pending: PendingCommit, saved: Result<u32, SaveFailed>) -> ResponseBody {
        match self.bank.finish_commit(&pending, saved) {
            Ok(seq) => {
                self.pipeline.restart_integrity(pending.staged.field_nt, pending.staged.inclination());
                self.last_error = None;
                let committed: <Commit as Endpoint>::Response = Committed { seq };
                committed.into_body()
            }
            Err(e) => self.refuse(e),
        }
    }
}
