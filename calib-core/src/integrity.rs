//! Run-time integrity of the heading: is this sample's heading trustworthy,
//! and how good is it?
//!
//! Per sample, three checks against what the sample carries independently
//! of the calibration under test, each a normalised residual compared with
//! a gate (`Tuning::gate_sigma` for the field with a gyro,
//! `Tuning::no_gyro_gate_sigma` without, `Tuning::gyro_gate_sigma`; chosen
//! leave-one-trial-out on every real trial, `xtask/src/bench/integrity.rs`):
//!
//! - the calibrated field's **magnitude** against the reference intensity
//!   `F`: `z_F = (|h| − F) / σ_F`, with `σ_F` the scatter of `|h|` the
//!   calibration itself left (its fit residual);
//! - the **dip**: `z_I = (sin I_meas − sin I_ref) / cos I_ref · F / σ_F`
//!   (the field's noise perpendicular to it moves the dip by `σ_F / F`
//!   radians); `I_ref` is learned from the samples judged ok, within
//!   `Tuning::inclination_allowance_rad` of the document's reference
//!   inclination (the world model at the site: the local field differs from
//!   it, but a wrong calibration must not teach the monitor a dip of its
//!   own), freely when there is none;
//! - the field's **rotation against the gyro**: a two-state Kalman filter
//!   (heading, gyro yaw-rate bias) propagated with the yaw rate
//!   `ψ̇ = (sin φ ω_y + cos φ ω_z) / cos θ` and updated only with the samples
//!   judged ok; the innovation `ν = ψ_mag − ψ_pred` over its predicted
//!   `√(P + σ_ψ²)` is the third test. The magnitude and dip cannot see a
//!   disturbance perpendicular to the magnetic meridian, the one that moves
//!   the heading most; the gyro does.
//!
//! Time: a failing sample starts a disturbance, which ends after
//! `Tuning::exit_s` of passing samples (hysteresis). When the field passes
//! but the gyro prediction keeps disagreeing for `Tuning::reanchor_s` while
//! the vehicle turns at least `Tuning::reanchor_turn_rad`, the prediction,
//! not the field, is taken as wrong (the gyro's scale error) and the filter
//! is re-anchored on the field; without the turn the disagreement is a
//! disturbance across the meridian and stays one. A **sustained**
//! misfit of the field (an exponentially weighted fraction of failing
//! samples, time constant `Tuning::misfit_tau_s`, above
//! `Tuning::misfit_enter`) means the stored calibration no longer fits the
//! vehicle: [`IntegrityState::CalInvalid`], until the fraction falls below
//! `Tuning::misfit_exit`.
//!
//! The heading's 1σ of a sample is `√(σ_cal² + (σ_n / H_h)²)` when ok (the
//! calibration's own heading error and the field's noise `σ_n` across the
//! measured horizontal intensity `H_h`; `σ_n` is `σ_F` unless the
//! calibration knows better, [`Reference::noise_nt`]); a sample not ok adds
//! its innovation and the size of its field misfit across `H_h`.
//!
//! No allocation; the state is about 150 bytes in `f32`
//! (`size_of::<Monitor<f32>>()`, tested); the levelled field is the
//! heading's (`OnlineIntegrity::process` levels once), so with
//! `OnlineIntegrity`'s bookkeeping the integrity adds about 330 Cortex-M4F
//! instructions to a usual sample's heading (`cargo xtask bench`).

use crate::heading::{Tilt, Vec3};
use crate::Real;

/// The integrity of one sample's heading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum IntegrityState {
    /// The field fits the calibration's reference and the gyro: the heading
    /// may be used with its σ.
    Ok = 0,
    /// This sample's field does not fit (a nearby magnetic object, passing).
    Disturbed = 1,
    /// The field has not fitted for a sustained time: the stored
    /// calibration no longer fits this vehicle (new hard iron, payload).
    CalInvalid = 2,
    /// No attitude: no heading.
    NoAttitude = 3,
    /// The field passes every check, but the inclination it was judged by
    /// was learned from the very stream judged: no reference independent of
    /// it (a calibration without a reference inclination). The heading is
    /// given with its σ, but a wrong calibration can pass such checks, so
    /// it is not called `ok`.
    Unjudged = 4,
}

impl IntegrityState {
    /// The word used in CSV and JSON (`docs/INTERFACES.md`).
    pub fn name(self) -> &'static str {
        match self {
            IntegrityState::Ok => "ok",
            IntegrityState::Disturbed => "disturbed",
            IntegrityState::CalInvalid => "cal_invalid",
            IntegrityState::NoAttitude => "no_attitude",
            IntegrityState::Unjudged => "unjudged",
        }
    }

    /// From the wire byte (`self as u8`).
    pub fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(IntegrityState::Ok),
            1 => Some(IntegrityState::Disturbed),
            2 => Some(IntegrityState::CalInvalid),
            3 => Some(IntegrityState::NoAttitude),
            4 => Some(IntegrityState::Unjudged),
            _ => None,
        }
    }

    /// Every state, in wire order.
    pub const ALL: [IntegrityState; 5] = [
        IntegrityState::Ok,
        IntegrityState::Disturbed,
        IntegrityState::CalInvalid,
        IntegrityState::NoAttitude,
        IntegrityState::Unjudged,
    ];
}

/// What the calibration says the field should look like.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Reference<T> {
    /// Reference intensity `F` (the document's `field_nt`), nT.
    pub field_nt: T,
    /// Scatter of `|h|` about `F` the calibration left (its fit residual),
    /// nT: the magnitude and dip gates' σ.
    pub field_sigma_nt: T,
    /// Each component's noise after calibration, nT: the heading's σ
    /// across the horizontal field, `noise_nt / H_h`. The scatter of `|h|`
    /// when nothing better is known (the board); smaller when the
    /// calibration's own heading error (`heading_sigma_rad`) already holds
    /// its slowly varying residuals (a back-stepped calibration: its
    /// per-axis residual).
    pub noise_nt: T,
    /// Inclination (dip, positive down), radians; `None`: learned from the
    /// samples judged ok.
    pub inclination_rad: Option<T>,
    /// The calibration's own heading error, 1σ, radians (0 when unknown).
    pub heading_sigma_rad: T,
}

/// The field's scatter about `F` taken when a calibration reports none (the
/// board's stored coefficients; a document without a fit residual), as a
/// fraction of `F`: the RMS of `|h| − F` with the true calibration on the
/// four undisturbed BROAD validation trials (02, 03, 05, 09) is 476–638 nT
/// on about 44 000 nT, 1.1–1.45 %.
pub const DEFAULT_FIELD_SIGMA_REL: f64 = 0.012;

impl<T: Real> Reference<T> {
    /// The reference of a calibration that keeps only its intensity `F` —
    /// the board's stored coefficients, or a document without quality
    /// figures: scatter [`DEFAULT_FIELD_SIGMA_REL`] of `F`, the inclination
    /// learned, no heading σ of its own. The board and `magcal apply` both
    /// start from this, so they judge alike.
    pub fn from_field_nt(field_nt: T) -> Self {
        let sigma = T::from_f64(DEFAULT_FIELD_SIGMA_REL) * field_nt;
        Self {
            field_nt,
            field_sigma_nt: sigma,
            noise_nt: sigma,
            inclination_rad: None,
            heading_sigma_rad: T::ZERO,
        }
    }
}

/// The monitor's constants. [`Tuning::standard`] holds the values chosen on
/// real data (leave-one-dataset-out, see `xtask/src/bench/integrity.rs`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tuning<T> {
    /// Gate on the field's normalised residuals (magnitude and dip), in σ,
    /// when the gyro checks the heading too.
    pub gate_sigma: T,
    /// The same gate for a sample without body rates: the field checks
    /// alone then stand for the heading, so they are tighter.
    pub no_gyro_gate_sigma: T,
    /// Gate on the gyro innovation, in σ.
    pub gyro_gate_sigma: T,
    /// Random walk of the gyro-propagated heading, rad²/s.
    pub heading_walk_rad2_s: T,
    /// Gyro scale uncertainty: variance added per radian turned, rad² per rad.
    pub scale_var_per_rad: T,
    /// Random walk of the gyro yaw-rate bias, rad²/s³.
    pub bias_walk_rad2_s3: T,
    /// Initial 1σ of the gyro yaw-rate bias, rad/s.
    pub bias_sigma_rad_s: T,
    /// Longest step the gyro is integrated over, s; a longer gap re-anchors.
    pub max_gap_s: T,
    /// Passing time that ends a disturbance (strictly more than this), s.
    pub exit_s: T,
    /// Field passing but the gyro disagreeing this long re-anchors, s ...
    pub reanchor_s: T,
    /// ... if the gyro has turned at least this much meanwhile, rad (the
    /// gyro's scale error can then explain the disagreement; 0: always).
    pub reanchor_turn_rad: T,
    /// Time constant of the misfit fraction, s.
    pub misfit_tau_s: T,
    /// Misfit fraction above which the calibration is invalid.
    pub misfit_enter: T,
    /// Misfit fraction below which it is valid again.
    pub misfit_exit: T,
    /// Samples over which a learned inclination is averaged (its memory).
    pub inclination_memory: T,
    /// How far the inclination learned from the samples judged ok may move
    /// from a reference inclination, radians (the reference's allowance):
    /// the local field differs from the world model's (a building, the
    /// vehicle, the crust), so the dip is learned — but only within this of
    /// an independent reference, so a wrong calibration cannot teach the
    /// monitor a dip of its own.
    pub inclination_allowance_rad: T,
}

impl<T: Real> Tuning<T> {
    /// The constants used on the board and by `magcal apply`, chosen
    /// leave-one-trial-out on every real trial with an optical heading
    /// (`xtask/src/bench/integrity.rs`, issue 31) — except three safety
    /// floors: the misfit exit and time constant (a looser one lets a wrong
    /// calibration re-validate itself where it happens to fit) and the
    /// re-anchoring turn (without it a lasting disturbance across the
    /// meridian is taken as the truth).
    ///
    /// - field gates 5σ with a gyro (the gyro carries the fine check; the
    ///   BROAD lab's |F| has heavy tails), 3.5σ without (a two-sided
    ///   Gaussian tail of 5·10⁻⁴: the field checks alone); gyro gate 3σ;
    /// - the gyro model: a scale error of 8 % per √rad turned (the BROAD
    ///   trials' measured 0.3–2.8 % with their timing and attitude errors at
    ///   up to 290°/s) and a walk of about 1°/√s;
    /// - disturbances end after 0.1 s of passing samples; re-anchoring after
    ///   0.5 s and 45° of turning; the calibration is invalid when over half
    ///   of a 2 s window fails ("within seconds") and valid again below a
    ///   tenth; the dip learned within ±3.06° of the reference.
    pub fn standard() -> Self {
        let deg = core::f64::consts::PI / 180.0;
        Self {
            gate_sigma: T::from_f64(5.0),
            no_gyro_gate_sigma: T::from_f64(3.5),
            gyro_gate_sigma: T::from_f64(3.0),
            heading_walk_rad2_s: T::from_f64(deg * deg),
            scale_var_per_rad: T::from_f64(0.08 * 0.08),
            bias_walk_rad2_s3: T::from_f64((0.01 * deg) * (0.01 * deg)),
            bias_sigma_rad_s: T::from_f64(0.5 * deg),
            max_gap_s: T::from_f64(0.2),
            exit_s: T::from_f64(0.1),
            reanchor_s: T::from_f64(0.5),
            reanchor_turn_rad: T::from_f64(REANCHOR_TURN_DEG * deg),
            misfit_tau_s: T::from_f64(2.0),
            misfit_enter: T::from_f64(0.5),
            misfit_exit: T::from_f64(0.1),
            inclination_memory: T::from_f64(200.0),
            inclination_allowance_rad: T::from_f64(INCLINATION_ALLOWANCE_DEG * deg),
        }
    }
}

/// The turn over which a lasting gyro disagreement may re-anchor the
/// prediction on the field, degrees (`Tuning::reanchor_turn_rad`).
pub const REANCHOR_TURN_DEG: f64 = 45.0;

/// The reference inclination's allowance, degrees: three times its 1σ, the
/// world model's 0.2° (the WMM reports' error model, crustal field
/// included) ⊕ 1° local (a steel building, the vehicle; the BROAD lab's
/// trials show 67.5–70.0° against the lab's mean 69.0°). The host's
/// reference check refuses a fit beyond the same three σ
/// (`host_tools::compute::reference`).
pub const INCLINATION_ALLOWANCE_DEG: f64 = 3.06;

impl<T: Real> Tuning<T> {
    /// The field gate for a sample with body rates (`with_gyro`) or without.
    #[inline(always)]
    pub fn field_gate(&self, with_gyro: bool) -> T {
        if with_gyro {
            self.gate_sigma
        } else {
            self.no_gyro_gate_sigma
        }
    }
}

/// Why a monitor could not be set up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IntegrityError {
    /// The reference intensity, its scatter or the noise is not a positive
    /// finite number, the scatter or the noise is not below the intensity, or the inclination is
    /// not within ±90°, or the heading σ is negative.
    BadReference,
    /// A tuning constant is not positive and finite, or the misfit
    /// thresholds are not `0 < exit < enter < 1`.
    BadTuning,
}

/// The judgement of one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Verdict<T> {
    /// The integrity state.
    pub state: IntegrityState,
    /// The heading's 1σ, radians (NaN without attitude).
    pub heading_sigma_rad: T,
    /// Normalised magnitude residual `z_F`.
    pub field_z: T,
    /// Normalised dip residual `z_I` (0 before an inclination is known).
    pub dip_z: T,
}

/// Wraps an angle within (−3π, 3π] to (−π, π] with two compares instead of
/// `floor` (libm's is software on the Cortex-M4F): every angle here is a
/// heading in [0, 2π) or (−π, π] plus a small step, or a difference of two.
#[inline(always)]
fn wrap_near<T: Real>(a: T) -> T {
    if a > T::PI {
        a - T::TAU
    } else if a <= -T::PI {
        a + T::TAU
    } else {
        a
    }
}

/// The most one sample moves the misfit fraction (its weight in the
/// exponential average): at a slow sampling rate (a glider's 5–9 s, longer
/// than `Tuning::misfit_tau_s`) one misfitting sample would otherwise make
/// the calibration invalid; with it, three in a row do (0.25, 0.44, 0.58 >
/// 0.5), and eight passing ones clear it. At 10 Hz (a step of 0.05) it
/// changes nothing.
pub const MAX_MISFIT_STEP: f64 = 0.25;

/// Samples of a learned inclination averaged in at once.
pub const INCLINATION_BLOCK: u8 = 8;

/// The cosine of an angle in ±90° from its sine (clamped, never 0).
#[inline(always)]
pub(crate) fn cos_of_sin<T: Real>(sin: T) -> T {
    let s = sin.max(-T::ONE).min(T::ONE);
    (T::ONE - s * s).max(T::EPSILON).sqrt()
}

/// A time step, s: non-positive or non-finite taken as 0.
#[inline(always)]
pub(crate) fn positive_dt<T: Real>(dt_s: T) -> T {
    if dt_s.is_finite() && dt_s > T::ZERO {
        dt_s
    } else {
        T::ZERO
    }
}

/// The gyro-propagated heading: a two-state Kalman filter.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct GyroHeading<T> {
    heading_rad: T,
    bias_rad_s: T,
    p00: T,
    p01: T,
    p11: T,
    anchored: bool,
}

impl<T: Real> GyroHeading<T> {
    #[inline(always)]
    fn predict(&mut self, yaw_rate_rad_s: T, dt_s: T, tuning: &Tuning<T>) {
        self.heading_rad = wrap_near(self.heading_rad + (yaw_rate_rad_s - self.bias_rad_s) * dt_s);
        self.p00 += dt_s * (dt_s * self.p11 - T::from_f64(2.0) * self.p01)
            + tuning.heading_walk_rad2_s * dt_s
            + tuning.scale_var_per_rad * (yaw_rate_rad_s * dt_s).abs();
        self.p01 -= dt_s * self.p11;
        self.p11 += tuning.bias_walk_rad2_s3 * dt_s;
    }

    #[inline(always)]
    fn update(&mut self, innovation_rad: T, s: T) {
        let (k0, k1) = (self.p00 / s, self.p01 / s);
        self.heading_rad = wrap_near(self.heading_rad + k0 * innovation_rad);
        self.bias_rad_s += k1 * innovation_rad;
        let (p00, p01) = (self.p00, self.p01);
        self.p00 = p00 - k0 * p00;
        self.p01 = p01 - k0 * p01;
        self.p11 -= k1 * p01;
    }

    #[inline(never)]
    fn anchor(&mut self, heading_rad: T, var_rad2: T) {
        self.heading_rad = wrap_near(heading_rad);
        self.p00 = var_rad2;
        self.p01 = T::ZERO;
        self.anchored = true;
    }
}

/// The per-sample integrity monitor: fixed state, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Monitor<T> {
    reference: Reference<T>,
    tuning: Tuning<T>,
    /// sin of the reference (or learned) inclination, and the dip
    /// residual's gain `F / (σ_F cos I)`.
    sin_incl: T,
    dip_gain: T,
    /// Samples averaged into a learned inclination (0: none yet).
    incl_weight: T,
    /// The sines of the dip waiting to be averaged in, and their count (the
    /// mean is updated every [`INCLINATION_BLOCK`] samples).
    incl_sum: T,
    incl_pending: u8,
    /// The bounds of a learned sin I (the reference's allowance; ±1
    /// without a reference).
    sin_incl_lo: T,
    sin_incl_hi: T,
    gyro: GyroHeading<T>,
    /// Exponentially weighted fraction of samples whose field misfits, and
    /// the same average of 1 (their ratio is the bias-corrected fraction:
    /// right from the first samples, not only after a time constant).
    misfit: T,
    misfit_weight: T,
    /// Field passing while the gyro disagrees, s, and the turn meanwhile, rad.
    gyro_fail_s: T,
    gyro_fail_turn_rad: T,
    /// Passing time since the last failure, s.
    pass_s: T,
    disturbed: bool,
    cal_invalid: bool,
}

impl<T: Real> Monitor<T> {
    /// A monitor for a calibration with this reference.
    pub fn new(reference: Reference<T>, tuning: Tuning<T>) -> Result<Self, IntegrityError> {
        let pos = |v: T| v.is_finite() && v > T::ZERO;
        let r = &reference;
        let incl_ok = r
            .inclination_rad
            .is_none_or(|i| i.is_finite() && i.abs() < T::PI / T::from_f64(2.0));
        if !(pos(r.field_nt)
            && pos(r.field_sigma_nt)
            && r.field_sigma_nt < r.field_nt
            && pos(r.noise_nt)
            && r.noise_nt < r.field_nt
            && incl_ok
            && r.heading_sigma_rad.is_finite()
            && r.heading_sigma_rad >= T::ZERO)
        {
            return Err(IntegrityError::BadReference);
        }
        let t = &tuning;
        let all_pos = [
            t.gate_sigma,
            t.no_gyro_gate_sigma,
            t.gyro_gate_sigma,
            t.heading_walk_rad2_s,
            t.scale_var_per_rad,
            t.bias_walk_rad2_s3,
            t.bias_sigma_rad_s,
            t.max_gap_s,
            t.exit_s,
            t.reanchor_s,
            t.misfit_tau_s,
            t.inclination_memory,
            t.inclination_allowance_rad,
        ]
        .iter()
        .all(|&v| pos(v));
        let turn_ok = t.reanchor_turn_rad.is_finite() && t.reanchor_turn_rad >= T::ZERO;
        if !(all_pos
            && turn_ok
            && t.misfit_exit > T::ZERO
            && t.misfit_exit < t.misfit_enter
            && t.misfit_enter < T::ONE)
        {
            return Err(IntegrityError::BadTuning);
        }
        let (sin_incl, cos_incl, incl_weight) = match r.inclination_rad {
            Some(i) => (i.sin(), i.cos(), t.inclination_memory),
            None => (T::ZERO, T::ONE, T::ZERO),
        };
        // No inclination yet: no dip test (a zero gain) until one is learned.
        let dip_gain = if r.inclination_rad.is_some() {
            r.field_nt / (r.field_sigma_nt * cos_incl)
        } else {
            T::ZERO
        };
        let bias_var = t.bias_sigma_rad_s * t.bias_sigma_rad_s;
        let half_pi = T::PI / T::from_f64(2.0);
        let (sin_incl_lo, sin_incl_hi) = match r.inclination_rad {
            Some(i) => (
                (i - t.inclination_allowance_rad).max(-half_pi).sin(),
                (i + t.inclination_allowance_rad).min(half_pi).sin(),
            ),
            None => (-T::ONE, T::ONE),
        };
        Ok(Self {
            reference,
            tuning,
            sin_incl,
            dip_gain,
            incl_weight,
            incl_sum: T::ZERO,
            incl_pending: 0,
            sin_incl_lo,
            sin_incl_hi,
            gyro: GyroHeading {
                heading_rad: T::ZERO,
                bias_rad_s: T::ZERO,
                p00: T::ZERO,
                p01: T::ZERO,
                p11: bias_var,
                anchored: false,
            },
            misfit: T::ZERO,
            misfit_weight: T::ZERO,
            gyro_fail_s: T::ZERO,
            gyro_fail_turn_rad: T::ZERO,
            pass_s: T::ZERO,
            disturbed: false,
            cal_invalid: false,
        })
    }

    /// The reference the monitor checks against.
    pub fn reference(&self) -> &Reference<T> {
        &self.reference
    }

    /// The inclination in use, radians (`None` before one is learned).
    pub fn inclination_rad(&self) -> Option<T> {
        (self.incl_weight > T::ZERO).then(|| self.sin_incl.atan2(cos_of_sin(self.sin_incl)))
    }

    /// sin of the inclination in use (`None` before one is learned).
    pub fn sin_inclination(&self) -> Option<T> {
        (self.incl_weight > T::ZERO).then_some(self.sin_incl)
    }

    /// The tuning in use.
    pub fn tuning(&self) -> &Tuning<T> {
        &self.tuning
    }

    /// Restarts the time logic on a new field (the on-line hard iron applied
    /// or withdrawn): the misfit fraction becomes `misfit` (what the new
    /// field's shadow check measured), the calibration's validity follows
    /// it, and the gyro heading re-anchors. The learned inclination stays.
    pub fn switch_field(&mut self, misfit: T) {
        self.misfit = misfit * self.misfit_weight;
        self.cal_invalid = misfit > self.tuning.misfit_enter;
        self.gyro.anchored = false;
        self.gyro_fail_s = T::ZERO;
        self.gyro_fail_turn_rad = T::ZERO;
        self.pass_s = T::ZERO;
        self.disturbed = true;
    }

    /// The misfit fraction (0…1) behind [`IntegrityState::CalInvalid`]
    /// (0 before any sample).
    pub fn misfit_fraction(&self) -> T {
        if self.misfit_weight > T::ZERO {
            self.misfit / self.misfit_weight
        } else {
            T::ZERO
        }
    }

    /// The gyro yaw-rate bias the heading filter estimated, rad/s.
    pub fn gyro_bias_rad_s(&self) -> T {
        self.gyro.bias_rad_s
    }

    /// Whether the stored calibration is judged invalid.
    pub fn cal_invalid(&self) -> bool {
        self.cal_invalid
    }

    /// The heading variance of a sample with horizontal intensity `hh_nt`.
    #[inline(always)]
    pub(crate) fn sample_var(&self, hh_nt: T) -> T {
        let s = self.reference.noise_nt / hh_nt.max(self.reference.noise_nt);
        s * s + self.reference.heading_sigma_rad * self.reference.heading_sigma_rad
    }

    /// Judges one sample: the calibrated field (nT, body frame), the heading
    /// computed from it (radians), the attitude (`None`: no attitude), the
    /// body rates (rad/s; `None`: no gyro) and the time since the previous
    /// sample (s).
    pub fn step(
        &mut self,
        field_nt: Vec3<T>,
        heading_rad: T,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt_s: T,
    ) -> Verdict<T> {
        let dt = positive_dt(dt_s);
        match tilt {
            Some(t) => {
                let l = t.level(field_nt);
                let hh = (l[0] * l[0] + l[1] * l[1]).sqrt();
                self.judge_levelled(l, hh, heading_rad, t, rate_rad_s, dt)
            }
            None => self.judge_without_attitude(field_nt, dt),
        }
    }

    /// Judges a sample without attitude (`dt` already checked,
    /// [`positive_dt`]): only its magnitude counts towards the misfit; the
    /// state is [`IntegrityState::NoAttitude`].
    pub(crate) fn judge_without_attitude(&mut self, field_nt: Vec3<T>, dt: T) -> Verdict<T> {
        let mag =
            (field_nt[0] * field_nt[0] + field_nt[1] * field_nt[1] + field_nt[2] * field_nt[2])
                .sqrt();
        let field_z = (mag - self.reference.field_nt) / self.reference.field_sigma_nt;
        self.track_misfit(!(field_z.abs() < self.tuning.no_gyro_gate_sigma), dt);
        self.gyro.anchored = false;
        Verdict {
            state: IntegrityState::NoAttitude,
            heading_sigma_rad: T::NAN,
            field_z,
            dip_z: T::ZERO,
        }
    }

    /// [`Monitor::step`] for a caller that has levelled the field already
    /// (the heading needs it too) and checked the time step
    /// ([`positive_dt`]): the calibrated field levelled with the attitude
    /// `tilt` ([`Tilt::level`]), its horizontal intensity `√(l₀² + l₁²)`,
    /// the heading, the body rates and the time step. The per-sample path
    /// (`OnlineIntegrity::process`) calls it; inlined there.
    #[inline(always)]
    pub(crate) fn judge_levelled(
        &mut self,
        levelled_nt: Vec3<T>,
        horizontal_nt: T,
        heading_rad: T,
        tilt: &Tilt<T>,
        rate_rad_s: Option<Vec3<T>>,
        dt: T,
    ) -> Verdict<T> {
        let g = self.tuning.field_gate(rate_rad_s.is_some());
        let (f, sigma_f) = (self.reference.field_nt, self.reference.field_sigma_nt);
        let (l, hh) = (levelled_nt, horizontal_nt);
        // |h| = |levelled h|.
        let mag = (hh * hh + l[2] * l[2]).sqrt();
        let field_z = (mag - f) / sigma_f;
        let sin_dip = l[2] / mag.max(sigma_f);
        // 0 before an inclination is known (the gain is 0 then).
        let dip_z = (sin_dip - self.sin_incl) * self.dip_gain;
        let var_m = self.sample_var(hh);
        // The gyro prediction, and the turn it integrated.
        let turn = match rate_rad_s {
            Some(w) if self.gyro.anchored && dt <= self.tuning.max_gap_s => {
                let yaw_rate = tilt.yaw_rate(w);
                self.gyro.predict(yaw_rate, dt, &self.tuning);
                (yaw_rate * dt).abs()
            }
            _ => {
                self.gyro.anchored = false;
                T::ZERO
            }
        };
        let anchored = self.gyro.anchored;
        let (innovation, s) = if anchored {
            (
                wrap_near(heading_rad - self.gyro.heading_rad),
                self.gyro.p00 + var_m,
            )
        } else {
            (T::ZERO, var_m)
        };
        // |innovation| / √s < g, without the square root.
        let field_ok = field_z.abs() < g && dip_z.abs() < g;
        let gg = self.tuning.gyro_gate_sigma;
        let pass = field_ok && innovation * innovation < gg * gg * s;
        let fraction = self.track_misfit(!field_ok, dt);
        let turn = rate_rad_s.map(|_| turn);
        self.track_gyro(turn, field_ok, pass, heading_rad, var_m, dt);
        if pass && anchored {
            self.gyro.update(innovation, s);
        }
        if pass && !self.disturbed && fraction < self.tuning.misfit_exit {
            self.learn_inclination(sin_dip);
        }
        if pass {
            self.pass_s += dt;
            if self.pass_s > self.tuning.exit_s {
                self.disturbed = false;
            }
        } else {
            self.pass_s = T::ZERO;
            self.disturbed = true;
        }
        let state = if self.cal_invalid {
            IntegrityState::CalInvalid
        } else if self.disturbed || !(fraction <= self.tuning.misfit_enter) {
            IntegrityState::Disturbed
        } else {
            IntegrityState::Ok
        };
        let heading_sigma_rad = if state == IntegrityState::Ok {
            var_m.sqrt()
        } else {
            self.misfit_sigma(var_m, innovation, mag, dip_z, hh)
        };
        Verdict {
            state,
            heading_sigma_rad,
            field_z,
            dip_z,
        }
    }

    /// The heading σ of a sample not `ok`: its own variance, the gyro
    /// innovation, and the field misfit's size across the horizontal field.
    #[inline(never)]
    fn misfit_sigma(&self, var_m: T, innovation: T, mag: T, dip_z: T, hh: T) -> T {
        let (f, sigma_f) = (self.reference.field_nt, self.reference.field_sigma_nt);
        let hh = hh.max(sigma_f);
        let dip_nt = dip_z * sigma_f;
        let e_nt = (mag - f) * (mag - f) + dip_nt * dip_nt;
        (var_m + innovation * innovation + e_nt / (hh * hh)).sqrt()
    }

    /// The sustained-misfit fraction and the calibration's validity.
    #[inline(always)]
    fn track_misfit(&mut self, misfit: bool, dt: T) -> T {
        let tau = self.tuning.misfit_tau_s;
        let a = (dt / tau).min(T::from_f64(MAX_MISFIT_STEP));
        // At least one sample's weight, so the first samples count.
        let a = a.max(T::from_f64(1e-3));
        let x = if misfit { T::ONE } else { T::ZERO };
        self.misfit += a * (x - self.misfit);
        self.misfit_weight += a * (T::ONE - self.misfit_weight);
        let fraction = self.misfit / self.misfit_weight;
        // Judged only once a third of a time constant has been seen.
        let seen = self.misfit_weight > T::from_f64(0.28);
        if !self.cal_invalid && fraction > self.tuning.misfit_enter && seen {
            self.cal_invalid = true;
        } else if self.cal_invalid && fraction < self.tuning.misfit_exit {
            self.cal_invalid = false;
        }
        fraction
    }

    /// Anchors the gyro heading when it is not, and re-anchors it when the
    /// field passes but the prediction has disagreed for too long while
    /// turning enough for the gyro's own error to explain it (`turn`: this
    /// step's integrated turn, rad, 0 when the prediction was not
    /// propagated; `None` without body rates). Without the turn a disagreement that
    /// lasts is a field that passes the field checks but not the gyro's —
    /// a disturbance across the magnetic meridian — and stays disturbed
    /// until the prediction's own walk makes it agree.
    #[inline(always)]
    fn track_gyro(&mut self, turn: Option<T>, field_ok: bool, pass: bool, heading_rad: T, var_m: T, dt: T) {
        if !self.gyro.anchored {
            if turn.is_some() && field_ok && heading_rad.is_finite() {
                self.gyro.anchor(heading_rad, var_m);
            }
            self.gyro_fail_s = T::ZERO;
            self.gyro_fail_turn_rad = T::ZERO;
        } else if pass {
            self.gyro_fail_s = T::ZERO;
            self.gyro_fail_turn_rad = T::ZERO;
        } else if field_ok {
            self.gyro_fail_s += dt;
            self.gyro_fail_turn_rad += turn.unwrap_or(T::ZERO);
            if self.gyro_fail_s > self.tuning.reanchor_s
                && self.gyro_fail_turn_rad >= self.tuning.reanchor_turn_rad
                && heading_rad.is_finite()
            {
                self.gyro.anchor(heading_rad, var_m);
                self.gyro_fail_s = T::ZERO;
                self.gyro_fail_turn_rad = T::ZERO;
            }
        }
    }

    /// Running mean of the sine of the dip over the samples judged ok,
    /// taken in blocks of [`INCLINATION_BLOCK`] samples (the same mean,
    /// a tenth of the per-sample cost).
    #[inline(always)]
    fn learn_inclination(&mut self, sin_dip: T) {
        self.incl_sum += sin_dip;
        self.incl_pending += 1;
        if self.incl_pending >= INCLINATION_BLOCK {
            self.absorb_inclination();
        }
    }

    /// Adds the pending block to the running mean (weight capped at
    /// `Tuning::inclination_memory` samples) and updates the dip gain.
    #[inline(never)]
    fn absorb_inclination(&mut self) {
        let n = T::from_u32(u32::from(self.incl_pending));
        self.incl_weight = (self.incl_weight + n).min(self.tuning.inclination_memory.max(n));
        // A weighted mean of values in [−1, 1] stays there (up to rounding,
        // which `cos_of_sin` absorbs).
        self.sin_incl += (self.incl_sum - n * self.sin_incl) / self.incl_weight;
        self.sin_incl = self.sin_incl.max(self.sin_incl_lo).min(self.sin_incl_hi);
        self.dip_gain =
            self.reference.field_nt / (self.reference.field_sigma_nt * cos_of_sin(self.sin_incl));
        self.incl_sum = T::ZERO;
        self.incl_pending = 0;
    }
}

#[cfg(test)]
mod tests;
