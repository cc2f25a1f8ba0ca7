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

use super::{level_matrix, BackstepError, JointWeights, RunSample};
use crate::cal::{EnvTerms, FieldCal};
use crate::heading::Vec3;
use crate::linalg::{inverse3, mul_mat_vec, Mat3};
use crate::lsq::lm::{self, Damping, LmOptions, LmProblem, LmStop, Linearisation, OnSingular};
use crate::Real;

/// Number of parameters of the joint problem.
pub const NP: usize = 26;
const M0: usize = 0;
const B0: usize = 9;
const BR0: usize = 12;
const C0: usize = 15;
const K0: usize = 18;
const DI: usize = 21;
const MR: usize = 22;
const MP: usize = 23;
/// The local field's gradient along the track: `∂H/∂s`, `∂Z/∂s`, nT/m.
const GH: usize = 24;
const GZ: usize = 25;

/// Default prior 1σ of the local field's gradient along the track, nT/m
/// (0.5 nT/m = 500 nT/km: loose against crustal anomalies' tens to
/// hundreds of nT/km; chosen leave-one-out on the varied sites, see the
/// bench's "five effects on varied sites").
pub const GRADIENT_PRIOR_NT_PER_M: f64 = 0.5;

/// Largest variance inflation for correlated residuals.
const MAX_INFLATION: f64 = 1000.0;

/// Lag-1 autocorrelation of the run's residuals (vertical and horizontal
/// channels each with its predecessor), in [0, 1).
fn residual_autocorrelation<T: Real>(model: &Model<T>, p: &[T; NP], run: &[RunSample<T>]) -> T {
    let (mut prev, mut cross, mut square) = ([T::NAN; 2], T::ZERO, T::ZERO);
    for s in run {
        let mut k = 0usize;
        let mut now = [T::NAN; 2];
        model.run_residuals(p, s, &mut |r, _, _| {
            if k < 2 {
                now[k] = r;
            }
            k += 1;
        });
        for c in 0..2 {
            if now[c].is_finite() {
                square += now[c] * now[c];
                if prev[c].is_finite() {
                    cross += now[c] * prev[c];
                }
            }
        }
        prev = now;
    }
    if !(square > T::ZERO) {
        return T::ZERO;
    }
    (cross / square).max(T::ZERO).min(T::from_f64(0.999))
}

/// Smallest residual σ the re-weighting uses, nT.
const MIN_RESIDUAL_SIGMA_NT: f64 = 0.5;

/// Headings at which the heading error is predicted (every 15°).
pub const HEADING_STEPS: usize = 24;

/// IGRF-14's published 1σ of the main field, nT: north, east, down.
pub const IGRF_SIGMA_NED_NT: Vec3<f64> = [87.0, 73.0, 114.0];

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

/// Which terms are in, and the conditions.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Model<T> {
    active: [bool; NP],
    ref_c: T,
    w_run: T,
    w_swing: T,
    swing_field_nt: T,
    /// The track's direction (north, east; unit).
    track: [T; 2],
}

/// What a residual looks at, and its context.
struct Row<T> {
    raw: Vec3<T>,
    current_a: T,
    dt_c: T,
    running: bool,
}

impl<T: Real> Model<T> {
    fn matrix(p: &[T; NP]) -> Mat3<T> {
        [[p[0], p[1], p[2]], [p[3], p[4], p[5]], [p[6], p[7], p[8]]]
    }

    /// `d` of the model and the gain factors.
    fn corrected(&self, p: &[T; NP], row: &Row<T>) -> (Vec3<T>, Vec3<T>) {
        let mut d = [T::ZERO; 3];
        let mut g = [T::ONE; 3];
        for k in 0..3 {
            g[k] = T::ONE + p[K0 + k] * row.dt_c;
            d[k] = row.raw[k] / g[k] - p[B0 + k] - p[C0 + k] * row.current_a;
            if row.running {
                d[k] -= p[BR0 + k];
            }
        }
        (d, g)
    }

    /// The Jacobian row of a residual that depends on `h = M d` through `v·h`.
    fn jacobian(&self, p: &[T; NP], row: &Row<T>, d: Vec3<T>, g: Vec3<T>, v: Vec3<T>) -> [T; NP] {
        let m = Self::matrix(p);
        let mut j = [T::ZERO; NP];
        for i in 0..3 {
            for k in 0..3 {
                j[M0 + 3 * i + k] = v[i] * d[k];
            }
        }
        for k in 0..3 {
            let gk = v[0] * m[0][k] + v[1] * m[1][k] + v[2] * m[2][k];
            j[B0 + k] = -gk;
            if row.running {
                j[BR0 + k] = -gk;
            }
            j[C0 + k] = -gk * row.current_a;
            j[K0 + k] = -gk * row.raw[k] * row.dt_c / (g[k] * g[k]);
        }
        j
    }

    fn run_row(&self, s: &RunSample<T>) -> Row<T> {
        let current_a = if self.active[C0] { s.current_a } else { T::ZERO };
        let dt_c = if self.active[K0] && s.temp_c.is_finite() { s.temp_c - self.ref_c } else { T::ZERO };
        Row { raw: s.raw, current_a, dt_c, running: self.active[BR0] }
    }

    fn swing_row(&self, s: &SwingSample<T>) -> Row<T> {
        let current_a = if self.active[C0] && s.current_a.is_finite() { s.current_a } else { T::ZERO };
        let dt_c = if self.active[K0] && s.temp_c.is_finite() { s.temp_c - self.ref_c } else { T::ZERO };
        Row { raw: s.raw, current_a, dt_c, running: false }
    }

    /// A sample's distance from the site along the track, m (0 where its
    /// position is unknown: the site).
    fn along_track_m(&self, s: &RunSample<T>) -> T {
        let [n, e] = s.position_m;
        if n.is_finite() && e.is_finite() {
            n * self.track[0] + e * self.track[1]
        } else {
            T::ZERO
        }
    }

    /// Calls `out(residual, weight, jacobian)` for each residual of a run sample.
    fn run_residuals(&self, p: &[T; NP], s: &RunSample<T>, out: &mut impl FnMut(T, T, &[T; NP])) {
        if self.active[C0] && !s.current_a.is_finite() {
            return;
        }
        let row = self.run_row(s);
        let (d, g) = self.corrected(p, &row);
        let m = Self::matrix(p);
        let h = mul_mat_vec(&m, d);
        let (roll, pitch) = (s.roll_rad + p[MR], s.pitch_rad + p[MP]);
        let lm = level_matrix(roll, pitch);
        let l = mul_mat_vec(&lm, h);
        let (sr, cr, sp, cp) = (roll.sin(), roll.cos(), pitch.sin(), pitch.cos());
        let z = T::ZERO;
        let dl_dr: Mat3<T> = [[z, sp * cr, -sp * sr], [z, -sr, -cr], [z, cp * cr, -cp * sr]];
        let dl_dp: Mat3<T> = [[-sp, cp * sr, cp * cr], [z, z, z], [-cp, -sp * sr, -sp * cr]];
        let dot = |a: &Vec3<T>, b: &Vec3<T>| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        // The local field: the reference turned by δI in the vertical plane
        // of the magnetic meridian, its intensity kept.
        let (si, ci) = (p[DI].sin(), p[DI].cos());
        let (h_loc, z_loc) = (s.h_ref_nt * ci - s.z_ref_nt * si, s.z_ref_nt * ci + s.h_ref_nt * si);
        // Plus the linear gradient from the site to where the sample was,
        // along the track.
        let along_m = if self.active[GH] { self.along_track_m(s) } else { T::ZERO };
        let (h_grad, z_grad) = (p[GH] * along_m, p[GZ] * along_m);
        // Vertical: l_z − Z_local.
        let mut j = self.jacobian(p, &row, d, g, lm[2]);
        j[DI] = -h_loc;
        j[MR] = dot(&dl_dr[2], &h);
        j[MP] = dot(&dl_dp[2], &h);
        j[GZ] = -along_m;
        out(l[2] - z_loc - z_grad, self.w_run, &j);
        // Horizontal intensity: |(l_x, l_y)| − H_local.
        let hh = (l[0] * l[0] + l[1] * l[1]).sqrt();
        if hh > T::ZERO {
            let (ux, uy) = (l[0] / hh, l[1] / hh);
            let v = [ux * lm[0][0] + uy * lm[1][0], ux * lm[0][1] + uy * lm[1][1], ux * lm[0][2] + uy * lm[1][2]];
            let mut j = self.jacobian(p, &row, d, g, v);
            j[DI] = z_loc;
            j[MR] = ux * dot(&dl_dr[0], &h) + uy * dot(&dl_dr[1], &h);
            j[MP] = ux * dot(&dl_dp[0], &h) + uy * dot(&dl_dp[1], &h);
            j[GH] = -along_m;
            out(hh - h_loc - h_grad, self.w_run, &j);
        }
    }

    /// The magnitude residual of a swing sample.
    fn swing_residual(&self, p: &[T; NP], s: &SwingSample<T>, out: &mut impl FnMut(T, T, &[T; NP])) {
        let row = self.swing_row(s);
        let (d, g) = self.corrected(p, &row);
        let h = mul_mat_vec(&Self::matrix(p), d);
        let mag = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        if !(mag > T::ZERO) {
            return;
        }
        let j = self.jacobian(p, &row, d, g, [h[0] / mag, h[1] / mag, h[2] / mag]);
        out(mag - self.swing_field_nt, self.w_swing, &j);
    }
}

/// The normal equations (the crate's one builder, [`Linearisation`], with
/// the priors added), the priors' part of the cost, and the residuals'
/// unweighted sums of squares.
#[derive(Clone)]
struct Normal<T> {
    /// `JᵀWJ`, `JᵀWr` and the data's cost `Σ w r²`.
    lin: Linearisation<T, NP>,
    prior_cost: T,
    /// Σ unweighted r² and count of the run's residuals, and of the swing's.
    run_ss: (T, u32),
    swing_ss: (T, u32),
}

impl<T: Real> Normal<T> {
    fn new(jtj: [[T; NP]; NP]) -> Self {
        let mut lin = Linearisation::zero();
        lin.jtj = jtj;
        Self { lin, prior_cost: T::ZERO, run_ss: (T::ZERO, 0), swing_ss: (T::ZERO, 0) }
    }

    /// Adds a residual `r` with its square-root weight `w` (`w·r` is
    /// unit-variance); the held terms' columns are left out.
    fn add(&mut self, active: &[bool; NP], r: T, w: T, j: &[T; NP]) {
        let j = core::array::from_fn(|a| if active[a] { j[a] } else { T::ZERO });
        self.lin.add_weighted_row(&j, r, w * w);
    }

    /// The whole cost: the data's and the priors'.
    fn cost(&self) -> T {
        self.lin.cost + self.prior_cost
    }
}

fn normal_equations<T: Real>(model: &Model<T>, p: &[T; NP], prior: &[T; NP], prior_w: &[T; NP], run: &[RunSample<T>], swing: &[SwingSample<T>]) -> Normal<T> {
    let mut n = Normal::new([[T::ZERO; NP]; NP]);
    let active = model.active;
    for s in run {
        model.run_residuals(p, s, &mut |r, w, j| {
            n.run_ss = (n.run_ss.0 + r * r, n.run_ss.1 + 1);
            n.add(&active, r, w, j)
        });
    }
    for s in swing {
        model.swing_residual(p, s, &mut |r, w, j| {
            n.swing_ss = (n.swing_ss.0 + r * r, n.swing_ss.1 + 1);
            n.add(&active, r, w, j)
        });
    }
    n.lin.symmetrise();
    for a in 0..NP {
        if active[a] {
            let r = (p[a] - prior[a]) * prior_w[a];
            n.prior_cost += r * r;
            n.lin.jtr[a] += prior_w[a] * r;
            n.lin.jtj[a][a] += prior_w[a] * prior_w[a];
        } else {
            // Held: an identity row keeps the system regular, the step zero.
            n.lin.jtj[a][a] = T::ONE;
        }
    }
    n
}

/// Mean, standard deviation, min and max of the finite values, and their count.
fn spread<T: Real>(values: impl Iterator<Item = T>) -> (T, T, T, T, u32) {
    let (mut n, mut s, mut s2, mut lo, mut hi) = (0u32, T::ZERO, T::ZERO, T::from_f64(f64::INFINITY), T::from_f64(f64::NEG_INFINITY));
    for v in values.filter(|v| v.is_finite()) {
        n += 1;
        s += v;
        s2 += v * v;
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if n == 0 {
        return (T::NAN, T::ZERO, T::NAN, T::NAN, 0);
    }
    let c = T::from_f64(f64::from(n));
    let mean = s / c;
    (mean, (s2 / c - mean * mean).max(T::ZERO).sqrt(), lo, hi, n)
}

/// Where each kind of note stands in [`JointSolution::notes`].
pub const NOTE_CURRENT: usize = 0;
/// The temperature note's place in [`JointSolution::notes`].
pub const NOTE_TEMPERATURE: usize = 1;
/// The misalignment note's place in [`JointSolution::notes`].
pub const NOTE_MISALIGNMENT: usize = 2;
/// The gradient note's place in [`JointSolution::notes`].
pub const NOTE_GRADIENT: usize = 3;

/// Which environment terms the data allow, and the run's typical values.
struct TermChoice<T> {
    use_current: bool,
    use_temp: bool,
    use_gradient: bool,
    track: [T; 2],
    current_mean: T,
    temp_mean: T,
    temp_n: u32,
    ref_c: T,
    notes: [Option<JointNote<T>>; 4],
}

/// Decides the current and temperature terms from their spread over the
/// run and the swing test (a note says why a term is not estimated).
fn choose_terms<T: Real>(run: &[RunSample<T>], swing: &[SwingSample<T>], cfg: &JointConfig<T>) -> TermChoice<T> {
    let mut notes = [None; 4];
    // Current: observable when it varies.
    let (current_mean, current_sd, _, _, current_n) = spread(run.iter().map(|s| s.current_a).chain(swing.iter().map(|s| s.current_a)));
    let use_current = if !cfg.terms.motor_current {
        false
    } else if current_n == 0 {
        notes[NOTE_CURRENT] = Some(JointNote::NoCurrentColumn);
        false
    } else if !(current_sd >= cfg.min_current_spread_a) {
        notes[NOTE_CURRENT] = Some(JointNote::CurrentNotVaried { spread_a: current_sd, min_a: cfg.min_current_spread_a });
        false
    } else {
        true
    };
    let (temp_mean, _, t_lo, t_hi, temp_n) = spread(run.iter().map(|s| s.temp_c).chain(swing.iter().map(|s| s.temp_c)));
    let use_temp = if !cfg.terms.temperature {
        false
    } else if temp_n == 0 {
        notes[NOTE_TEMPERATURE] = Some(JointNote::NoTemperatureColumn);
        false
    } else if !(t_hi - t_lo >= cfg.min_temp_spread_c) {
        notes[NOTE_TEMPERATURE] = Some(JointNote::TemperatureConstant { spread_c: t_hi - t_lo, min_c: cfg.min_temp_spread_c });
        false
    } else {
        true
    };
    let ref_c = match cfg.ref_c {
        Some(r) if r.is_finite() => r,
        _ if temp_n > 0 => (t_lo + t_hi) / T::from_f64(2.0),
        _ => EnvTerms::<T>::none().ref_c,
    };
    // The gradient: where the run goes far enough from the site, along
    // the principal axis of its positions. (Across the track the positions
    // are dead reckoning's drift between fixes, a sawtooth with the dives:
    // a gradient across it would fit what the dives do, not the field.)
    let (track, span_m) = track_axis(run);
    let use_gradient = if !cfg.terms.field_gradient {
        false
    } else if !(span_m >= cfg.min_gradient_span_m) {
        notes[NOTE_GRADIENT] = Some(JointNote::TrackTooShort { span_m, min_m: cfg.min_gradient_span_m });
        false
    } else {
        true
    };
    TermChoice { use_current, use_temp, use_gradient, track, current_mean, temp_mean, temp_n, ref_c, notes }
}

/// The principal axis (north, east; unit) of the run's positions about the
/// site (second moments), and the farthest distance from the site along
/// it, m (0 without positions).
fn track_axis<T: Real>(run: &[RunSample<T>]) -> ([T; 2], T) {
    let (mut snn, mut see, mut sne) = (T::ZERO, T::ZERO, T::ZERO);
    for s in run {
        let [n, e] = s.position_m;
        if n.is_finite() && e.is_finite() {
            snn += n * n;
            see += e * e;
            sne += n * e;
        }
    }
    // The larger eigenvector of [[snn, sne], [sne, see]]: angle ½·atan2(2 sne, snn − see).
    let angle = (T::from_f64(2.0) * sne).atan2(snn - see) / T::from_f64(2.0);
    let axis = [angle.cos(), angle.sin()];
    let span = run
        .iter()
        .map(|s| s.position_m)
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .fold(T::ZERO, |a, p| a.max((p[0] * axis[0] + p[1] * axis[1]).abs()));
    (axis, span)
}

/// The run's mean reference field and IGRF's σ along and across it.
struct ReferenceField<T> {
    h_nt: T,
    z_nt: T,
    f_nt: T,
    sigma_along_nt: T,
    sigma_across_nt: T,
}

fn reference_field<T: Real>(run: &[RunSample<T>], cfg: &JointConfig<T>) -> ReferenceField<T> {
    let (h_mean, z_mean) = {
        let c = T::from_f64(run.len() as f64);
        (run.iter().fold(T::ZERO, |a, s| a + s.h_ref_nt) / c, run.iter().fold(T::ZERO, |a, s| a + s.z_ref_nt) / c)
    };
    let f_mean = (h_mean * h_mean + z_mean * z_mean).sqrt();
    // IGRF's σ along F (the intensity) and across it (the inclination).
    let (sh, sz) = (cfg.field_prior_h_nt, cfg.field_prior_z_nt);
    let sigma_along_nt = ((sh * h_mean / f_mean) * (sh * h_mean / f_mean) + (sz * z_mean / f_mean) * (sz * z_mean / f_mean)).sqrt();
    let sigma_across_nt = ((sh * z_mean / f_mean) * (sh * z_mean / f_mean) + (sz * h_mean / f_mean) * (sz * h_mean / f_mean)).sqrt();
    ReferenceField { h_nt: h_mean, z_nt: z_mean, f_nt: f_mean, sigma_along_nt, sigma_across_nt }
}

/// The model with the chosen terms active and the assumed residual σ.
fn initial_model<T: Real>(terms: &TermChoice<T>, swing_field_nt: T, cfg: &JointConfig<T>) -> Model<T> {
    let mut active = [true; NP];
    for k in 0..3 {
        active[BR0 + k] = !terms.use_current;
        active[C0 + k] = terms.use_current;
        active[K0 + k] = terms.use_temp;
    }
    active[DI] = cfg.terms.local_field;
    active[MR] = cfg.terms.misalignment;
    active[MP] = cfg.terms.misalignment;
    active[GH] = terms.use_gradient;
    active[GZ] = terms.use_gradient;
    Model {
        active,
        ref_c: terms.ref_c,
        w_run: T::ONE / cfg.weights.run_sigma_nt,
        w_swing: T::ONE / cfg.weights.swing_sigma_nt,
        swing_field_nt,
        track: terms.track,
    }
}

/// The prior (the step-1 calibration, neutral environment terms) and its
/// weight per parameter.
fn priors<T: Real>(start: &FieldCal<T>, gain: T, field: &ReferenceField<T>, cfg: &JointConfig<T>) -> ([T; NP], [T; NP]) {
    let mut prior = [T::ZERO; NP];
    for i in 0..3 {
        for k in 0..3 {
            prior[M0 + 3 * i + k] = start.matrix[i][k];
        }
        prior[B0 + i] = start.bias[i];
    }
    let w = &cfg.weights;
    let mut prior_w = [T::ZERO; NP];
    for a in 0..NP {
        prior_w[a] = match a {
            _ if a < B0 => T::ONE / (w.matrix_prior_rel * gain),
            _ if a < BR0 => gain / w.bias_prior_nt,
            _ if a < C0 => gain / w.running_bias_prior_nt,
            _ if a < K0 => gain / cfg.current_prior_nt_per_a,
            _ if a < DI => T::ONE / cfg.gain_prior_per_c,
            DI => field.f_nt / field.sigma_across_nt,
            MR | MP => T::ONE / cfg.misalignment_prior_rad,
            _ => T::ONE / cfg.gradient_prior_nt_per_m,
        };
    }
    (prior, prior_w)
}

/// The data and the prior of one joint problem.
struct JointData<'a, T> {
    prior: &'a [T; NP],
    prior_w: &'a [T; NP],
    run: &'a [RunSample<T>],
    swing: &'a [SwingSample<T>],
}

impl<T: Real> JointData<'_, T> {
    fn solve(&self, model: &Model<T>, p0: &[T; NP]) -> Result<([T; NP], u8), BackstepError> {
        solve(model, p0, self.prior, self.prior_w, self.run, self.swing)
    }

    fn normal(&self, model: &Model<T>, p: &[T; NP]) -> Normal<T> {
        normal_equations(model, p, self.prior, self.prior_w, self.run, self.swing)
    }

    /// Solves from the prior, replaces the assumed residual σ by the
    /// residuals' own scatter (so that the priors weigh what they should
    /// against the data), and solves again.
    fn solve_reweighted(&self, model: &mut Model<T>) -> Result<([T; NP], u8), BackstepError> {
        let (p, iterations) = self.solve(model, self.prior)?;
        let n0 = self.normal(model, &p);
        let floor = T::from_f64(MIN_RESIDUAL_SIGMA_NT);
        let rms = |(ss, k): (T, u32)| if k > 0 { (ss / T::from_f64(f64::from(k))).sqrt() } else { T::NAN };
        let (run_rms, swing_rms) = (rms(n0.run_ss), rms(n0.swing_ss));
        if run_rms.is_finite() {
            model.w_run = T::ONE / run_rms.max(floor);
        }
        if swing_rms.is_finite() {
            model.w_swing = T::ONE / swing_rms.max(floor);
        }
        let (p1, it1) = self.solve(model, &p)?;
        Ok((p1, iterations.saturating_add(it1)))
    }

    /// Keeps the misalignment only where the data shrink its σ below half
    /// the prior's; otherwise holds it at zero, solves again and returns the
    /// note. Returns the parameters, their normal equations, the added
    /// iterations and whether the misalignment is estimated.
    fn settle_misalignment(&self, model: &mut Model<T>, p: [T; NP], cfg: &JointConfig<T>) -> Result<Settled<T>, BackstepError> {
        let n = self.normal(model, &p);
        let first = spd_cov(&n, model)?;
        let ratio = first[MR][MR].max(first[MP][MP]).sqrt() / cfg.misalignment_prior_rad;
        if !cfg.terms.misalignment || ratio < T::from_f64(0.5) {
            return Ok(Settled { p, n, iterations: 0, estimated: cfg.terms.misalignment, note: None });
        }
        model.active[MR] = false;
        model.active[MP] = false;
        let mut start_p = p;
        start_p[MR] = T::ZERO;
        start_p[MP] = T::ZERO;
        let (p2, it2) = self.solve(model, &start_p)?;
        let n = self.normal(model, &p2);
        Ok(Settled { p: p2, n, iterations: it2, estimated: false, note: Some(JointNote::MisalignmentNotObservable { sigma_ratio: ratio }) })
    }
}

/// The solution after the misalignment's decision.
struct Settled<T> {
    p: [T; NP],
    n: Normal<T>,
    iterations: u8,
    estimated: bool,
    note: Option<JointNote<T>>,
}

/// Divides the data's part of the information by the AR(1) variance
/// inflation (1 + ρ)/(1 − ρ) of the run's residuals (neighbouring samples
/// are not independent: slow AHRS errors, the field's gradient along the
/// track); the priors' part stays. Returns the inflation.
fn inflate_for_correlation<T: Real>(n: &mut Normal<T>, model: &Model<T>, p: &[T; NP], prior_w: &[T; NP], run: &[RunSample<T>]) -> T {
    let rho = residual_autocorrelation(model, p, run);
    let inflation = ((T::ONE + rho) / (T::ONE - rho)).max(T::ONE).min(T::from_f64(MAX_INFLATION));
    for a in 0..NP {
        if !model.active[a] {
            continue;
        }
        let pa = prior_w[a] * prior_w[a];
        for b in 0..NP {
            if model.active[b] {
                let prior_part = if a == b { pa } else { T::ZERO };
                n.lin.jtj[a][b] = (n.lin.jtj[a][b] - prior_part) / inflation + prior_part;
            }
        }
    }
    inflation
}

/// Each parameter's 1σ from the covariance.
fn sigmas_of<T: Real>(cov: &[[T; NP]; NP]) -> JointSigmas<T> {
    let sd = |a: usize| cov[a][a].max(T::ZERO).sqrt();
    JointSigmas {
        matrix: core::array::from_fn(|a| sd(M0 + a)),
        bias: core::array::from_fn(|k| sd(B0 + k)),
        running_bias: core::array::from_fn(|k| sd(BR0 + k)),
        bias_per_a: core::array::from_fn(|k| sd(C0 + k)),
        gain_per_c: core::array::from_fn(|k| sd(K0 + k)),
        local_inclination_rad: sd(DI),
        misalignment_rad: [sd(MR), sd(MP)],
        gradient_nt_per_m: [sd(GH), sd(GZ)],
    }
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

/// The covariance (inverse of the normal matrix with the priors, fixed terms
/// zeroed) and its scale factor (1: the residual weights were set from the
/// residuals' scatter before).
fn spd_cov<T: Real>(n: &Normal<T>, model: &Model<T>) -> Result<[[T; NP]; NP], BackstepError> {
    let mut cov = crate::uncertainty::spd_inverse(&n.lin.jtj).ok_or(BackstepError::Singular)?;
    for a in 0..NP {
        if !model.active[a] {
            for b in 0..NP {
                cov[a][b] = T::ZERO;
                cov[b][a] = T::ZERO;
            }
        }
    }
    // The weights are the residuals' own scatter: no further scale.
    Ok(cov)
}

/// The joint problem for the crate's Levenberg–Marquardt. A candidate's
/// normal equations are kept, so that an accepted step is not linearised
/// twice.
struct JointProblem<'a, T> {
    model: &'a Model<T>,
    prior: &'a [T; NP],
    prior_w: &'a [T; NP],
    run: &'a [RunSample<T>],
    swing: &'a [SwingSample<T>],
    last: Option<([T; NP], Normal<T>)>,
}

impl<T: Real> JointProblem<'_, T> {
    fn normal(&mut self, p: &[T; NP]) -> Normal<T> {
        match &self.last {
            Some((at, n)) if at == p => n.clone(),
            _ => {
                let n = normal_equations(self.model, p, self.prior, self.prior_w, self.run, self.swing);
                self.last = Some((*p, n.clone()));
                n
            }
        }
    }
}

impl<T: Real> LmProblem<T, NP> for JointProblem<'_, T> {
    fn linearise(&mut self, p: &[T; NP]) -> Option<Linearisation<T, NP>> {
        let n = self.normal(p);
        let cost = n.cost();
        Some(Linearisation { cost, ..n.lin })
    }

    fn cost(&mut self, p: &[T; NP]) -> Option<T> {
        let n = self.normal(p);
        Some(n.cost())
    }
}

/// Levenberg–Marquardt from `p0` with Jacobi scaling (matrix entries,
/// counts-sized biases and their gradients differ by many orders of
/// magnitude): damping 1e-4, strict decrease, at most 50 iterations of 20
/// tries, stopped when the cost settles to 1e-10 of itself.
fn solve<T: Real>(
    model: &Model<T>,
    p0: &[T; NP],
    prior: &[T; NP],
    prior_w: &[T; NP],
    run: &[RunSample<T>],
    swing: &[SwingSample<T>],
) -> Result<([T; NP], u8), BackstepError> {
    let mut problem = JointProblem { model, prior, prior_w, run, swing, last: None };
    let mut opts = LmOptions::marquardt(T::from_f64(1e-4));
    opts.damping = Damping::JacobiScaled;
    opts.on_singular = OnSingular::Stop;
    opts.max_iterations = 50;
    opts.max_tries = 20;
    opts.cost_tolerance = Some(T::from_f64(1e-10));
    let out = lm::solve(&mut problem, p0, &opts);
    if out.stop == LmStop::Singular {
        return Err(BackstepError::Singular);
    }
    if !out.params.iter().all(|v| v.is_finite()) {
        return Err(BackstepError::Diverged);
    }
    Ok((out.params, out.iterations.min(u32::from(u8::MAX)) as u8))
}

impl<T: Real> JointSolution<T> {
    /// The raw reading, at the typical conditions of the run, of a level
    /// vehicle at `heading_rad` in the estimated local field.
    fn raw_at(&self, heading_rad: T) -> Option<Vec3<T>> {
        let p = &self.params;
        let h = self.reference_hz_nt[0] + self.local_offset_hz_nt[0];
        let z = self.reference_hz_nt[1] + self.local_offset_hz_nt[1];
        let body = [h * heading_rad.cos(), -h * heading_rad.sin(), z];
        let inv = inverse3(&Model::matrix(p))?;
        let d = mul_mat_vec(&inv, body);
        let current = if self.model.active[C0] { self.typical_current_a } else { T::ZERO };
        let dt = if self.model.active[K0] { self.typical_temp_c - self.model.ref_c } else { T::ZERO };
        let running = if self.model.active[BR0] { T::ONE } else { T::ZERO };
        Some(core::array::from_fn(|k| (T::ONE + p[K0 + k] * dt) * (d[k] + p[B0 + k] + running * p[BR0 + k] + p[C0 + k] * current)))
    }

    /// The level heading that parameters `p` give a raw reading.
    fn heading_of(&self, p: &[T; NP], raw: Vec3<T>) -> T {
        let s = RunSample {
            raw,
            roll_rad: T::ZERO,
            pitch_rad: T::ZERO,
            h_ref_nt: T::ZERO,
            z_ref_nt: T::ZERO,
            leg: super::Leg::Other,
            current_a: self.typical_current_a,
            temp_c: self.typical_temp_c,
            position_m: [T::ZERO; 2],
        };
        let row = self.model.run_row(&s);
        let (d, _) = self.model.corrected(p, &row);
        let h = mul_mat_vec(&Model::matrix(p), d);
        // The AHRS reads −δ̂ on a level vehicle; `p`'s δ is added to it.
        let l = crate::heading::level(h, p[MR] - self.params[MR], p[MP] - self.params[MP]);
        (-l[1]).atan2(l[0])
    }

    fn heading_sigmas(&self, cov: &[[T; NP]; NP]) -> ([T; HEADING_STEPS], T) {
        let mut per = [T::NAN; HEADING_STEPS];
        let mut total = T::ZERO;
        for (i, out) in per.iter_mut().enumerate() {
            let psi = T::from_f64((i as f64 * 15.0).to_radians());
            let Some(raw) = self.raw_at(psi) else { return ([T::NAN; HEADING_STEPS], T::NAN) };
            *out = crate::uncertainty::angle_sigma(&self.params, cov, |p| self.heading_of(p, raw));
            total += *out * *out;
        }
        (per, (total / T::from_f64(HEADING_STEPS as f64)).sqrt())
    }

    /// The predicted heading error (per 15° and RMS, rad) if the samples
    /// `extra` were added to the data (same noise as the fit's residuals):
    /// what more coverage would buy.
    pub fn predicted_with(&self, extra: impl Iterator<Item = RunSample<T>>) -> Option<([T; HEADING_STEPS], T)> {
        let mut n = Normal::new(self.information);
        let active = self.model.active;
        for s in extra {
            let k = self.correlation_inflation.sqrt();
            self.model.run_residuals(&self.params, &s, &mut |r, w, j| n.add(&active, r, w / k, j));
        }
        n.lin.symmetrise();
        let cov = spd_cov(&n, &self.model).ok()?;
        Some(self.heading_sigmas(&cov))
    }

    /// `samples` run samples of one level 360° turn at the run's typical
    /// current and temperature, read through the estimated model (a
    /// hypothetical surface circle for [`Self::predicted_with`]).
    pub fn level_turn(&self, samples: usize) -> impl Iterator<Item = RunSample<T>> + '_ {
        let n = samples.max(1);
        (0..n).filter_map(move |i| {
            let psi = T::from_f64(i as f64 * core::f64::consts::TAU / n as f64);
            let raw = self.raw_at(psi)?;
            Some(RunSample {
                raw,
                roll_rad: -self.params[MR],
                pitch_rad: -self.params[MP],
                h_ref_nt: self.reference_hz_nt[0],
                z_ref_nt: self.reference_hz_nt[1],
                leg: super::Leg::Other,
                current_a: self.typical_current_a,
                temp_c: self.typical_temp_c,
                position_m: [T::ZERO; 2],
            })
        })
    }
}

#[cfg(test)]
mod tests;
