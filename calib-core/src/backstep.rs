//! Back-stepping refinement on an out-and-back run: ALGORITHMS.md §4
//! (paper 000, eqs 22–30), and a joint least-squares refinement of ours.
//!
//! The swing test (step 1) cannot roll or pitch the vehicle fully, so its fit
//! leaves the vertical channel poorly determined; on the run, thrusters and
//! electronics add a bias the swing test never saw. Driving out and back
//! exposes both: with the step-1 coefficients the field magnitude jumps at the
//! turnaround, and the levelled horizontal and vertical channels disagree
//! with IGRF.
//!
//! * [`paper_iteration`] — the paper's corrections, in its order: scale
//!   `sx, sy` by measured/reference `Hh` (Table 3); change `sz` until the
//!   turnaround step vanishes (Table 4); solve `bz` from the magnitude
//!   (eqs 29–30, Table 5); repeat (Table 6).
//! * [`joint_refine`] — ours: one Gauss–Newton/Levenberg–Marquardt problem
//!   over the full matrix `M`, the bias `b` and a running-only bias `b_run`,
//!   fitting every run sample's levelled vertical component to IGRF's `Z` and
//!   its levelled horizontal intensity to IGRF's `H` (vectors, not just the
//!   magnitude), optionally with the swing test's magnitudes, and with the
//!   step-1 coefficients as a prior for what the run cannot see;
//!   [`joint::joint_refine_env`] adds the thruster current, the temperature
//!   gains, the local field as a nuisance and the AHRS misalignment, and
//!   predicts its own heading error.

use crate::cal::FieldCal;
use crate::heading::{horizontal, level, Vec3};
use crate::linalg::Mat3;
use crate::Real;

/// Which part of the run a sample belongs to, for the turnaround step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Leg {
    /// The window before the turnaround.
    Out,
    /// The window after it.
    Back,
    /// Elsewhere (used by the fits, not by the step).
    Other,
}

/// One sample of the run.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RunSample<T> {
    /// Raw magnetometer, counts.
    pub raw: Vec3<T>,
    /// AHRS roll, radians.
    pub roll_rad: T,
    /// AHRS pitch, radians.
    pub pitch_rad: T,
    /// Reference horizontal intensity (IGRF) here, nT.
    pub h_ref_nt: T,
    /// Reference down component (IGRF) here, nT.
    pub z_ref_nt: T,
    /// Where on the run.
    pub leg: Leg,
    /// Motor (thruster) current, A (NaN: not recorded).
    pub current_a: T,
    /// Temperature at the magnetometer, °C (NaN: not recorded).
    pub temp_c: T,
    /// Where the sample was taken: north and east of the reference site
    /// (the swing test's place), m, from GPS fixes or dead reckoning (NaN:
    /// unknown). Only the joint refinement's field gradient uses it.
    pub position_m: [T; 2],
}

/// The paper's axis coefficients: `H_i = (Ĥ_i − b_i)/s_i` (eq 18).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AxisCoefficients<T> {
    /// `bx, by, bz`, counts.
    pub bias: Vec3<T>,
    /// `sx, sy, sz`, counts per nT.
    pub scale: Vec3<T>,
}

impl<T: Real> AxisCoefficients<T> {
    /// As a field calibration (`matrix = diag(1/s)`).
    pub fn field_cal(&self) -> FieldCal<T> {
        let z = T::ZERO;
        FieldCal {
            bias: self.bias,
            matrix: [[T::ONE / self.scale[0], z, z], [z, T::ONE / self.scale[1], z], [z, z, T::ONE / self.scale[2]]],
        }
    }

    /// From a diagonal field calibration; `None` if the matrix is not diagonal
    /// with positive entries.
    pub fn from_field_cal(cal: &FieldCal<T>) -> Option<Self> {
        let m = &cal.matrix;
        let off = [m[0][1], m[0][2], m[1][0], m[1][2], m[2][0], m[2][1]];
        if off.iter().any(|v| *v != T::ZERO) || !(m[0][0] > T::ZERO && m[1][1] > T::ZERO && m[2][2] > T::ZERO) {
            return None;
        }
        Some(Self { bias: cal.bias, scale: [T::ONE / m[0][0], T::ONE / m[1][1], T::ONE / m[2][2]] })
    }
}

/// What the run shows with a calibration: the paper's table columns.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RunStats<T> {
    /// Mean |H| after the turnaround minus before, nT.
    pub step_nt: T,
    /// Mean levelled horizontal intensity, nT.
    pub hh_nt: T,
    /// Mean levelled vertical component, nT.
    pub hz_nt: T,
    /// Mean |H|, nT.
    pub f_nt: T,
    /// RMS of |H| − reference F, nT.
    pub f_error_rms_nt: T,
    /// Mean raw z, counts.
    pub raw_z_mean: T,
}

/// Why a refinement could not run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BackstepError {
    /// No samples on one side of the turnaround (or none at all).
    NoTurnaroundWindows,
    /// The reference or the data give a non-positive `H² − Hh²`.
    BadReference,
    /// The joint problem is singular even with the prior.
    Singular,
    /// The result is not a usable calibration.
    Diverged,
}

impl core::fmt::Display for BackstepError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            BackstepError::NoTurnaroundWindows => "the run has no samples on one side of the turnaround",
            BackstepError::BadReference => "the reference field gives no vertical component (H² ≤ Hh²)",
            BackstepError::Singular => "the refinement problem is singular",
            BackstepError::Diverged => "the refinement did not converge to a usable calibration",
        })
    }
}

/// Evaluates a calibration on the run.
pub fn run_stats<T: Real>(cal: &FieldCal<T>, samples: &[RunSample<T>]) -> Result<RunStats<T>, BackstepError> {
    let (mut n, mut hh, mut hz, mut f, mut fe, mut rz) = (0u32, T::ZERO, T::ZERO, T::ZERO, T::ZERO, T::ZERO);
    let (mut n_out, mut f_out, mut n_back, mut f_back) = (0u32, T::ZERO, 0u32, T::ZERO);
    for s in samples {
        let h = cal.apply(s.raw);
        let l = level(h, s.roll_rad, s.pitch_rad);
        let mag = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let f_ref = (s.h_ref_nt * s.h_ref_nt + s.z_ref_nt * s.z_ref_nt).sqrt();
        if !mag.is_finite() {
            continue;
        }
        n += 1;
        hh += horizontal(l);
        hz += l[2];
        f += mag;
        fe += (mag - f_ref) * (mag - f_ref);
        rz += s.raw[2];
        match s.leg {
            Leg::Out => {
                n_out += 1;
                f_out += mag;
            }
            Leg::Back => {
                n_back += 1;
                f_back += mag;
            }
            Leg::Other => {}
        }
    }
    if n_out == 0 || n_back == 0 {
        return Err(BackstepError::NoTurnaroundWindows);
    }
    let c = |v: u32| T::from_f64(f64::from(v));
    Ok(RunStats {
        step_nt: f_back / c(n_back) - f_out / c(n_out),
        hh_nt: hh / c(n),
        hz_nt: hz / c(n),
        f_nt: f / c(n),
        f_error_rms_nt: (fe / c(n)).sqrt(),
        raw_z_mean: rz / c(n),
    })
}

/// Mean reference horizontal intensity and total intensity over the run.
pub fn reference_means<T: Real>(samples: &[RunSample<T>]) -> (T, T) {
    let n = T::from_f64(samples.len().max(1) as f64);
    let (mut h, mut f) = (T::ZERO, T::ZERO);
    for s in samples {
        h += s.h_ref_nt;
        f += (s.h_ref_nt * s.h_ref_nt + s.z_ref_nt * s.z_ref_nt).sqrt();
    }
    (h / n, f / n)
}

/// Correction 1 (Table 3): scale `sx, sy` by measured over reference `Hh`.
pub fn scale_horizontal<T: Real>(c: &AxisCoefficients<T>, hh_measured_nt: T, hh_reference_nt: T) -> AxisCoefficients<T> {
    let k = hh_measured_nt / hh_reference_nt;
    AxisCoefficients { bias: c.bias, scale: [c.scale[0] * k, c.scale[1] * k, c.scale[2]] }
}

/// Correction 3 (eqs 29–30, Table 5): `Hh² + ((Ĥz − bz)/sz)² = H²` solved
/// for `bz`, with the mean raw z of the run.
pub fn z_bias_from_magnitude<T: Real>(c: &AxisCoefficients<T>, raw_z_mean: T, hh_nt: T, f_reference_nt: T) -> Result<AxisCoefficients<T>, BackstepError> {
    let v2 = f_reference_nt * f_reference_nt - hh_nt * hh_nt;
    if !(v2 > T::ZERO) {
        return Err(BackstepError::BadReference);
    }
    let mut out = *c;
    out.bias[2] = raw_z_mean - c.scale[2] * v2.sqrt();
    Ok(out)
}

/// Correction 2 (Table 4): the `sz` in `[sz/4, 4·sz]` that makes the
/// turnaround step smallest (zero where it can be), by a scan and a golden
/// section search on |step|.
pub fn zero_step_sz<T: Real>(c: &AxisCoefficients<T>, samples: &[RunSample<T>]) -> Result<AxisCoefficients<T>, BackstepError> {
    let step_at = |sz: T| {
        let mut cc = *c;
        cc.scale[2] = sz;
        run_stats(&cc.field_cal(), samples).map(|s| s.step_nt.abs())
    };
    let (lo0, hi0) = (c.scale[2] / T::from_f64(4.0), c.scale[2] * T::from_f64(4.0));
    // Coarse scan on a log grid for the basin of the smallest |step|.
    let steps: u8 = 40;
    let ratio = T::from_f64(libm::pow(16.0, 1.0 / f64::from(steps)));
    let (mut best_sz, mut best) = (c.scale[2], step_at(c.scale[2])?);
    let mut sz = lo0;
    for _ in 0..=steps {
        let v = step_at(sz)?;
        if v < best {
            best = v;
            best_sz = sz;
        }
        sz *= ratio;
    }
    let (mut a, mut b) = ((best_sz / ratio).max(lo0), (best_sz * ratio).min(hi0));
    let g = T::from_f64(0.618_033_988_749_895);
    for _ in 0..60 {
        let (x1, x2) = (b - g * (b - a), a + g * (b - a));
        if step_at(x1)? < step_at(x2)? {
            b = x2;
        } else {
            a = x1;
        }
    }
    let mid = (a + b) / T::from_f64(2.0);
    let mut out = *c;
    out.scale[2] = if step_at(mid)? < best { mid } else { best_sz };
    Ok(out)
}

/// One row of the back-stepping trace (paper Tables 3–6).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TraceEntry<T> {
    /// Iteration (1-based; 0 = the step-1 coefficients).
    pub iteration: u8,
    /// Which correction: 0 = start, 1 = horizontal scale, 2 = sz, 3 = bz.
    pub correction: u8,
    /// Coefficients after it.
    pub coefficients: AxisCoefficients<T>,
    /// What the run shows with them.
    pub stats: RunStats<T>,
}

/// One iteration of the paper's back-stepping (corrections 1, 2, 3), calling
/// `trace` after each correction.
pub fn paper_iteration<T: Real>(
    c: &AxisCoefficients<T>,
    samples: &[RunSample<T>],
    iteration: u8,
    trace: &mut impl FnMut(TraceEntry<T>),
) -> Result<AxisCoefficients<T>, BackstepError> {
    let (hh_ref, f_ref) = reference_means(samples);
    let s0 = run_stats(&c.field_cal(), samples)?;
    let c1 = scale_horizontal(c, s0.hh_nt, hh_ref);
    let s1 = run_stats(&c1.field_cal(), samples)?;
    trace(TraceEntry { iteration, correction: 1, coefficients: c1, stats: s1 });
    let c2 = zero_step_sz(&c1, samples)?;
    let s2 = run_stats(&c2.field_cal(), samples)?;
    trace(TraceEntry { iteration, correction: 2, coefficients: c2, stats: s2 });
    let c3 = z_bias_from_magnitude(&c2, s2.raw_z_mean, s2.hh_nt, f_ref)?;
    let s3 = run_stats(&c3.field_cal(), samples)?;
    trace(TraceEntry { iteration, correction: 3, coefficients: c3, stats: s3 });
    Ok(c3)
}

/// The paper's algorithm: iterate until the turnaround step is below
/// `step_tol_nt` and the mean magnitude is within `f_tol_nt` of the
/// reference, or `max_iterations`.
pub fn paper_backstep<T: Real>(
    start: &AxisCoefficients<T>,
    samples: &[RunSample<T>],
    max_iterations: u8,
    step_tol_nt: T,
    f_tol_nt: T,
    trace: &mut impl FnMut(TraceEntry<T>),
) -> Result<AxisCoefficients<T>, BackstepError> {
    let s = run_stats(&start.field_cal(), samples)?;
    trace(TraceEntry { iteration: 0, correction: 0, coefficients: *start, stats: s });
    let (_, f_ref) = reference_means(samples);
    let mut c = *start;
    for it in 1..=max_iterations {
        c = paper_iteration(&c, samples, it, trace)?;
        let s = run_stats(&c.field_cal(), samples)?;
        if s.step_nt.abs() < step_tol_nt && (s.f_nt - f_ref).abs() < f_tol_nt {
            break;
        }
    }
    Ok(c)
}

/// Prior uncertainties of the joint refinement (1σ).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointWeights<T> {
    /// Noise of a levelled run residual (IGRF error, AHRS error), nT.
    pub run_sigma_nt: T,
    /// Noise of a swing-test magnitude residual, nT.
    pub swing_sigma_nt: T,
    /// Prior on each matrix entry, relative to the matrix's mean diagonal.
    pub matrix_prior_rel: T,
    /// Prior on the bias, nT (converted to counts with the matrix).
    pub bias_prior_nt: T,
    /// Prior on the running-only bias, nT.
    pub running_bias_prior_nt: T,
}

impl<T: Real> Default for JointWeights<T> {
    fn default() -> Self {
        Self {
            run_sigma_nt: T::from_f64(20.0),
            swing_sigma_nt: T::from_f64(20.0),
            matrix_prior_rel: T::from_f64(0.05),
            bias_prior_nt: T::from_f64(2000.0),
            running_bias_prior_nt: T::from_f64(5000.0),
        }
    }
}

/// Result of the joint refinement.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JointResult<T> {
    /// The calibration for the running vehicle (bias includes `b_run`).
    pub running: FieldCal<T>,
    /// The calibration with thrusters off (bias without `b_run`).
    pub resting: FieldCal<T>,
    /// The running-only bias, counts.
    pub running_bias: Vec3<T>,
    /// Gauss–Newton iterations used.
    pub iterations: u8,
}

/// Levelling matrix `C2ᵀ(θ) C1ᵀ(φ)` rows.
fn level_matrix<T: Real>(roll: T, pitch: T) -> Mat3<T> {
    crate::heading::Tilt::new(roll, pitch).matrix()
}

/// Ours: the joint refinement without current, temperature or misalignment
/// estimates beyond what the samples carry ([`joint::joint_refine_env`] with
/// [`JointConfig`] from `weights`). `start` is the step-1 calibration (the
/// prior); `swing` optionally adds the swing test's samples with their
/// reference intensity.
pub fn joint_refine<T: Real>(
    start: &FieldCal<T>,
    run: &[RunSample<T>],
    swing: &[SwingSample<T>],
    swing_field_nt: T,
    weights: &JointWeights<T>,
) -> Result<JointResult<T>, BackstepError> {
    let cfg = JointConfig { weights: *weights, ..JointConfig::default() };
    let s = joint_refine_env(start, run, swing, swing_field_nt, &cfg)?;
    Ok(JointResult { running: s.running, resting: s.resting, running_bias: s.running_bias, iterations: s.iterations })
}

pub mod joint;
pub use joint::{joint_refine_env, JointConfig, JointNote, JointSolution, JointTerms, SwingSample};

#[cfg(test)]
mod tests;
