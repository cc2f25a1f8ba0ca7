//! The joint refinement with the run's environment: thruster current,
//! temperature, the local field and the AHRS misalignment, and the heading
//! error its own covariance predicts.
//!
//! The model of a raw sample (the calibration document's formula,
//! `docs/INTERFACES.md`):
//!
//! ```text
//! h = M · (raw ⊘ (1 + k ⊙ (temp_c − ref_c)) − b − b_run − c · current_a)
//! ```
//!
//! with `M` (9), the resting bias `b` (3), a running-only bias `b_run` (3,
//! only when the current term is not estimated), the per-ampere vector `c`
//! (ArduPilot's compassmot model, raw units per A) and the per-axis gain
//! change `k` (per °C). Each run sample contributes its levelled vertical
//! component against the local `Z` and its levelled horizontal intensity
//! against the local `H`; each swing-test sample (thrusters off unless it
//! carries a current) its magnitude against the local `F`.
//!
//! **The local field is a nuisance, not truth.** What the data determine
//! is the field's *direction* in the magnetic meridian: the local
//! inclination, estimated as an offset `δI` to the reference's with
//! IGRF-14's published 1σ (87 nT north, 114 nT down) carried across `F` as
//! the prior. The intensity is not observable: a common scale of the field
//! and of `M` leaves every residual's shape unchanged, and a free scale is
//! pulled low by the noise (the residuals' noise scales with the calibrated
//! field: on the unit test's data a free offset along `F` came out 6 % low),
//! so the intensity stays the reference's, and its σ along `F`
//! ([`JointSolution::intensity_sigma_nt`]) is reported, not improved. The
//! local declination is not observable from the magnetometer either (it is
//! a heading offset: the swing fit against the GPS course takes it). A
//! constant NED offset thus shows as a changed inclination only. Headings
//! never depend on the intensity.
//!
//! **The field's gradient along the track.** A crustal anomaly makes the
//! local field change along the run by tens to hundreds of nT per km; against
//! a reference that does not, the trend goes into whatever correlates with
//! position (the temperature gains through the sensor's lag, the per-ampere
//! vector through the legs' speeds). The local `H` and `Z` therefore carry a
//! linear gradient in the distance `s` from the site along the track
//! (`∂H/∂s`, `∂Z/∂s`; `s` from each sample's logged position projected on the
//! principal axis of the run's positions), with a loose prior
//! ([`GRADIENT_PRIOR_NT_PER_M`]). Across the track it is left out: there the
//! positions are dead reckoning's drift between GPS fixes, a sawtooth with the
//! dives, and a gradient across it would fit what the dives do, not the field.
//! The swing test is at the site (`s = 0`). A note says when positions are
//! missing or the run stays near the site ([`JointConfig::min_gradient_span_m`]).
//! What is not linear in the anomaly stays in the residuals (their correlation
//! inflates the covariance).
//!
//! **Current and temperature** are estimated from the run itself where they
//! vary; [`JointConfig::min_current_spread_a`] and
//! [`JointConfig::min_temp_spread_c`] decide, and a [`JointNote`] says why a
//! term was not estimated (the running bias then stands in for the current
//! term; the gain is left at zero).
//!
//! **The AHRS misalignment** (roll and pitch offsets added in the levelling)
//! is, for a near-level run, the same as a rotation of the matrix about x
//! and y: a general `M` absorbs it and the headings come out right either
//! way. It is separable only where the prior holds the matrix's rotation
//! (a tight `matrix_prior_rel`) or the run's attitudes make the levelling's
//! non-linearity visible. It is estimated with a 2° prior and reported when
//! the data shrink its σ below half the prior's; otherwise a note says so and
//! it is held at zero.
//!
//! **The predicted heading error.** At the solution the normal matrix with
//! the priors, inverted and scaled by the residual variance, is the
//! parameters' covariance; [`crate::uncertainty::angle_sigma`] carries it to
//! the level heading at every 15° (field of the estimated local `H, Z`,
//! typical current and temperature of the run). [`JointSolution::predicted_with`]
//! adds the information of hypothetical samples (e.g. [`JointSolution::level_turn`])
//! to say what more coverage would buy.

// The parameters' layout, the residuals and their Jacobians.
mod model;
// The predicted heading error (`impl JointSolution`).
mod prediction;
// Which terms are estimated, and the priors.
mod priors;
// The normal equations, the solver, the covariance.
mod solve;

use super::{BackstepError, JointWeights, RunSample};
use crate::cal::{EnvTerms, FieldCal};
use crate::heading::Vec3;
use crate::Real;
use model::{Model, B0, BR0, C0, DI, GH, GZ, K0, MP, MR};
use priors::{choose_terms, initial_model, priors, reference_field};
use solve::{inflate_for_correlation, sigmas_of, spd_cov, JointData, Settled};

/// Number of parameters of the joint problem.
pub const NP: usize = 26;

/// Default prior 1σ of the local field's gradient along the track, nT/m
/// (0.5 nT/m = 500 nT/km: loose against crustal anomalies' tens to
/// hundreds of nT/km; chosen leave-one-out on the varied sites, see the
/// bench's "five effects on varied sites").
pub const GRADIENT_PRIOR_NT_PER_M: f64 = 0.5;

/// Headings at which the heading error is predicted (every 15°).
pub const HEADING_STEPS: usize = 24;

/// IGRF-14's published 1σ of the main field, nT: north, east, down.
pub const IGRF_SIGMA_NED_NT: Vec3<f64> = [87.0, 73.0, 114.0];

/// Where each kind of note stands in [`JointSolution::notes`].
pub const NOTE_CURRENT: usize = 0;
/// The temperature note's place in [`JointSolution::notes`].
pub const NOTE_TEMPERATURE: usize = 1;
/// The misalignment note's place in [`JointSolution::notes`].
pub const NOTE_MISALIGNMENT: usize = 2;
/// The gradient note's place in [`JointSolution::notes`].
pub const NOTE_GRADIENT: usize = 3;

/// A swing-test sample: its raw field with the conditions it was taken in.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SwingSample<T> {
    /// Raw magnetometer, counts.
    pub raw: Vec3<T>,
    /// Motor current, A (NaN: not recorded, taken as thrusters off).
    pub current_a: T,
    /// Temperature, °C (NaN: not recorded, no gain correction).
    pub temp_c: T,
}

/// How the joint refinement runs.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointConfig<T> {
    /// Residual and prior uncertainties.
    pub weights: JointWeights<T>,
    /// Reference temperature of the gains, °C (`None`: the middle of the
    /// data's range; the host passes the median).
    pub ref_c: Option<T>,
    /// The current term is estimated only when the motor current's standard
    /// deviation over the data reaches this, A.
    pub min_current_spread_a: T,
    /// The gains are estimated only when the temperature spans this, °C.
    pub min_temp_spread_c: T,
    /// Prior 1σ of the per-ampere vector, nT per A.
    pub current_prior_nt_per_a: T,
    /// Prior 1σ of each gain change, per °C.
    pub gain_prior_per_c: T,
    /// Prior 1σ of the reference field's down component, nT.
    pub field_prior_z_nt: T,
    /// Prior 1σ of the reference field's horizontal (north) component, nT.
    pub field_prior_h_nt: T,
    /// Prior 1σ of each misalignment angle, rad.
    pub misalignment_prior_rad: T,
    /// Prior 1σ of the local field's gradient along the track (H and Z
    /// each), nT/m.
    pub gradient_prior_nt_per_m: T,
    /// The gradient is estimated only when the run's positions span this
    /// far from the site, m.
    pub min_gradient_span_m: T,
    /// Which environment terms may be estimated at all (all by default):
    /// switching one off holds it at its neutral value, for comparisons.
    pub terms: JointTerms,
}

/// Which of the joint refinement's environment terms may be estimated. A
/// term switched on is still estimated only where the data allow (see
/// [`JointConfig::min_current_spread_a`], [`JointConfig::min_temp_spread_c`],
/// the misalignment's observability); a term switched off is held at its
/// neutral value (no per-ampere vector but a running bias, zero gains, the
/// reference's inclination, zero misalignment) without a note.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointTerms {
    /// The thrusters' per-ampere vector (the motors' electric current).
    pub motor_current: bool,
    /// The per-axis temperature gains.
    pub temperature: bool,
    /// The local field's inclination offset from the reference.
    pub local_field: bool,
    /// The AHRS roll/pitch misalignment.
    pub misalignment: bool,
    /// The local field's linear gradient along the track (the crustal
    /// anomaly seen as a gradient).
    pub field_gradient: bool,
}

impl Default for JointTerms {
    /// Every term switched on.
    fn default() -> Self {
        Self { motor_current: true, temperature: true, local_field: true, misalignment: true, field_gradient: true }
    }
}

impl<T: Real> Default for JointConfig<T> {
    /// Default weights; current estimated above 0.5 A standard deviation,
    /// gains above a 1 °C span; priors 1000 nT/A, 0.01/°C, IGRF-14's σ, 2°.
    fn default() -> Self {
        Self {
            weights: JointWeights::default(),
            ref_c: None,
            min_current_spread_a: T::from_f64(0.5),
            min_temp_spread_c: T::from_f64(1.0),
            current_prior_nt_per_a: T::from_f64(1000.0),
            gain_prior_per_c: T::from_f64(0.01),
            field_prior_z_nt: T::from_f64(IGRF_SIGMA_NED_NT[2]),
            field_prior_h_nt: T::from_f64(IGRF_SIGMA_NED_NT[0]),
            misalignment_prior_rad: T::from_f64(2.0f64.to_radians()),
            gradient_prior_nt_per_m: T::from_f64(GRADIENT_PRIOR_NT_PER_M),
            min_gradient_span_m: T::from_f64(1000.0),
            terms: JointTerms::default(),
        }
    }
}

/// Why an estimate was not made: each says what the data lacked.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JointNote<T> {
    /// The run has no motor current.
    NoCurrentColumn,
    /// The motor current hardly varied.
    CurrentNotVaried {
        /// Its standard deviation, A.
        spread_a: T,
        /// The threshold, A.
        min_a: T,
    },
    /// No temperature in the data.
    NoTemperatureColumn,
    /// The temperature hardly varied.
    TemperatureConstant {
        /// Its span, °C.
        spread_c: T,
        /// The threshold, °C.
        min_c: T,
    },
    /// The misalignment is not separable from the matrix.
    MisalignmentNotObservable {
        /// Its σ after the data relative to the prior's.
        sigma_ratio: T,
    },
    /// The run's positions are missing or do not go far enough from the
    /// site for the field's gradient.
    TrackTooShort {
        /// Farthest position from the site, m (0: no positions).
        span_m: T,
        /// The threshold, m.
        min_m: T,
    },
}

impl<T: Real> core::fmt::Display for JointNote<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            JointNote::NoCurrentColumn => {
                f.write_str("no motor current recorded: the thruster field is a constant running bias (no per-ampere vector)")
            }
            JointNote::CurrentNotVaried { spread_a, min_a } => write!(
                f,
                "the motor current never varied (σ {:.2} A < {:.2} A): the per-ampere vector cannot be separated from the bias; a constant running bias is used instead (add a thrust test: hold heading, step the thrusters)",
                spread_a.to_f64(),
                min_a.to_f64()
            ),
            JointNote::NoTemperatureColumn => f.write_str("no temperature recorded: the temperature gains are not estimated"),
            JointNote::TemperatureConstant { spread_c, min_c } => write!(
                f,
                "the temperature was constant (span {:.2} °C < {:.2} °C): the temperature gains are not estimated",
                spread_c.to_f64(),
                min_c.to_f64()
            ),
            JointNote::MisalignmentNotObservable { sigma_ratio } => write!(
                f,
                "the AHRS roll/pitch misalignment is not separable from the matrix's rotation on these data (its σ only fell to {:.0} % of the prior's): held at 0, the matrix absorbs it",
                100.0 * sigma_ratio.to_f64()
            ),
            JointNote::TrackTooShort { span_m, min_m } => write!(
                f,
                "the run's positions reach only {:.0} m from the site (< {:.0} m, or no lat/lon): the local field's gradient along the track is not estimated",
                span_m.to_f64(),
                min_m.to_f64()
            ),
        }
    }
}

/// 1σ of each estimate (from the covariance; 0 for a term held fixed).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointSigmas<T> {
    /// Matrix entries, row major.
    pub matrix: [T; 9],
    /// Resting bias, counts.
    pub bias: Vec3<T>,
    /// Running-only bias, counts.
    pub running_bias: Vec3<T>,
    /// Per-ampere vector, counts per A.
    pub bias_per_a: Vec3<T>,
    /// Gains, per °C.
    pub gain_per_c: Vec3<T>,
    /// Local inclination's offset to the reference's, rad.
    pub local_inclination_rad: T,
    /// Misalignment roll and pitch, rad.
    pub misalignment_rad: [T; 2],
    /// The field's gradient along the track (`∂H/∂s, ∂Z/∂s`), nT/m.
    pub gradient_nt_per_m: [T; 2],
}

/// What the joint refinement found.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSolution<T> {
    /// The calibration for the running vehicle at the reference conditions
    /// (bias includes `b_run`; use with [`Self::env`]).
    pub running: FieldCal<T>,
    /// Thrusters off.
    pub resting: FieldCal<T>,
    /// The running-only bias, counts (zero when the current term is used).
    pub running_bias: Vec3<T>,
    /// The current and temperature terms (zero where not estimated).
    pub env: EnvTerms<T>,
    /// Whether the per-ampere vector was estimated.
    pub current_estimated: bool,
    /// Whether the gains were estimated.
    pub temperature_estimated: bool,
    /// Whether the misalignment was estimated (observable).
    pub misalignment_estimated: bool,
    /// Whether the local field's gradient was estimated.
    pub gradient_estimated: bool,
    /// The local field's linear gradient along the track, `∂H/∂s, ∂Z/∂s`
    /// (H the horizontal intensity, Z down, `s` the distance from the site
    /// along [`Self::track_direction`]), nT/m, on top of the reference's own
    /// (zero where not estimated).
    pub field_gradient_nt_per_m: [T; 2],
    /// The track's direction (north, east; unit): the principal axis of the
    /// run's positions about the site.
    pub track_direction: [T; 2],
    /// AHRS misalignment added to roll and pitch, rad.
    pub misalignment_rad: [T; 2],
    /// Mean reference (IGRF) horizontal and down components over the run, nT.
    pub reference_hz_nt: [T; 2],
    /// The local inclination's offset to the reference's, rad.
    pub local_inclination_offset_rad: T,
    /// The local field's offset to the reference that it implies (the
    /// intensity held at the reference's): horizontal, down, nT.
    pub local_offset_hz_nt: [T; 2],
    /// 1σ of the reference intensity (IGRF's, along `F`; the data cannot
    /// improve it), nT.
    pub intensity_sigma_nt: T,
    /// 1σ of everything.
    pub sigma: JointSigmas<T>,
    /// 1σ heading error at level headings 0°, 15°, … 345°, rad.
    pub heading_sigma_rad: [T; HEADING_STEPS],
    /// Their RMS, rad.
    pub predicted_heading_rms_rad: T,
    /// RMS of the run and swing residuals, nT.
    pub residual_rms_nt: T,
    /// Iterations used.
    pub iterations: u8,
    /// Why terms were not estimated.
    pub notes: [Option<JointNote<T>>; 4],
    /// The factor the data's information was divided by for the
    /// correlation of neighbouring residuals, `(1 + ρ)/(1 − ρ)` (≥ 1).
    pub correlation_inflation: T,
    /// Typical conditions of the run (mean current, A; mean temperature, °C).
    pub typical_current_a: T,
    /// See `typical_current_a`.
    pub typical_temp_c: T,
    params: [T; NP],
    model: Model<T>,
    information: [[T; NP]; NP],
}

/// The joint refinement with the environment terms (see the module
/// documentation). `start` is the step-1 calibration (the prior); `swing`
/// optionally adds the swing test's samples with their reference intensity
/// `swing_field_nt` (IGRF at the site).
pub fn joint_refine_env<T: Real>(
    start: &FieldCal<T>,
    run: &[RunSample<T>],
    swing: &[SwingSample<T>],
    swing_field_nt: T,
    cfg: &JointConfig<T>,
) -> Result<JointSolution<T>, BackstepError> {
    let gain = (start.matrix[0][0].abs() + start.matrix[1][1].abs() + start.matrix[2][2].abs()) / T::from_f64(3.0);
    if !(gain > T::ZERO) || run.is_empty() {
        return Err(BackstepError::Diverged);
    }
    let mut terms = choose_terms(run, swing, cfg);
    let field = reference_field(run, cfg);
    let mut model = initial_model(&terms, swing_field_nt, cfg);
    let (prior, prior_w) = priors(start, gain, &field, cfg);
    let data = JointData { prior: &prior, prior_w: &prior_w, run, swing };
    let (p, iterations) = data.solve_reweighted(&mut model)?;
    let Settled { p, mut n, iterations: it2, estimated: misalignment_estimated, note } = data.settle_misalignment(&mut model, p, cfg)?;
    terms.notes[NOTE_MISALIGNMENT] = note;
    let inflation = inflate_for_correlation(&mut n, &model, &p, &prior_w, run);
    let cov = spd_cov(&n, &model)?;
    if !p.iter().all(|v| v.is_finite()) {
        return Err(BackstepError::Diverged);
    }
    let residual_rms_nt = ((n.run_ss.0 + n.swing_ss.0) / T::from_f64(f64::from((n.run_ss.1 + n.swing_ss.1).max(1)))).sqrt();
    let m = Model::matrix(&p);
    let b = [p[B0], p[B0 + 1], p[B0 + 2]];
    let br = [p[BR0], p[BR0 + 1], p[BR0 + 2]];
    let (h_mean, z_mean) = (field.h_nt, field.z_nt);
    let mut sol = JointSolution {
        running: FieldCal { bias: [b[0] + br[0], b[1] + br[1], b[2] + br[2]], matrix: m },
        resting: FieldCal { bias: b, matrix: m },
        running_bias: br,
        env: EnvTerms { bias_per_a: [p[C0], p[C0 + 1], p[C0 + 2]], ref_c: terms.ref_c, gain_per_c: [p[K0], p[K0 + 1], p[K0 + 2]] },
        current_estimated: terms.use_current,
        temperature_estimated: terms.use_temp,
        misalignment_estimated,
        gradient_estimated: terms.use_gradient,
        field_gradient_nt_per_m: [p[GH], p[GZ]],
        track_direction: model.track,
        misalignment_rad: [p[MR], p[MP]],
        reference_hz_nt: [h_mean, z_mean],
        local_inclination_offset_rad: p[DI],
        local_offset_hz_nt: {
            let (si, ci) = (p[DI].sin(), p[DI].cos());
            [h_mean * ci - z_mean * si - h_mean, z_mean * ci + h_mean * si - z_mean]
        },
        intensity_sigma_nt: field.sigma_along_nt,
        sigma: sigmas_of(&cov),
        heading_sigma_rad: [T::NAN; HEADING_STEPS],
        predicted_heading_rms_rad: T::NAN,
        residual_rms_nt,
        iterations: iterations.saturating_add(it2),
        notes: terms.notes,
        typical_current_a: if terms.use_current { terms.current_mean } else { T::ZERO },
        typical_temp_c: if terms.temp_n > 0 { terms.temp_mean } else { terms.ref_c },
        params: p,
        model,
        information: n.lin.jtj,
        correlation_inflation: inflation,
    };
    let (per, rms) = sol.heading_sigmas(&cov);
    sol.heading_sigma_rad = per;
    sol.predicted_heading_rms_rad = rms;
    Ok(sol)
}

#[cfg(test)]
mod tests;
