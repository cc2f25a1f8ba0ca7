//! The coefficients applied to every sample: `h = M·(raw − b)`, then the
//! tilt-compensated heading, the swing correction (eq 31) and declination.
//!
//! Cheap enough for every output sample on the MCU: 9 multiply-adds for the
//! field, two sin/cos pairs and an atan2 for the heading, and the five-term
//! Fourier correction.

use crate::heading::{heading_of_levelled, wrap_two_pi, Tilt, Vec3};
use crate::linalg::{det3, identity3, mul_mat_vec, Mat3};
use crate::Real;

/// Which model produced a field calibration. One type for the whole stack:
/// the fits, the wire (on-board fit) and the calibration document.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
pub enum ModelKind {
    /// Bias and one scale (sphere).
    Sphere,
    /// Bias and three axis scales (paper 000's axis-aligned ellipsoid).
    Axis,
    /// Bias and a symmetric 3×3 soft-iron/scale matrix (full ellipsoid).
    Full,
    /// Upper-triangular non-orthogonality and gain (paper 001).
    Triangular,
    /// Bias and a symmetric soft-iron matrix from the gyro-aided fit
    /// ([`crate::gyro`]): for vehicles that cannot tumble.
    Gyro,
    /// Bias and a general soft-iron matrix from the attitude-aided fit
    /// ([`crate::attitude_fit`]): for vehicles with an AHRS but no gyro
    /// that cannot tumble.
    Attitude,
}

impl ModelKind {
    /// Every model, in the order the tools list them.
    pub const ALL: [ModelKind; 6] = [ModelKind::Sphere, ModelKind::Axis, ModelKind::Full, ModelKind::Triangular, ModelKind::Gyro, ModelKind::Attitude];

    /// The model of a document name (`None` when no model has it).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The name used in the calibration document (`docs/INTERFACES.md`).
    pub fn name(self) -> &'static str {
        match self {
            ModelKind::Sphere => "sphere",
            ModelKind::Axis => "axis",
            ModelKind::Full => "full",
            ModelKind::Triangular => "triangular",
            ModelKind::Gyro => "gyro",
            ModelKind::Attitude => "attitude",
        }
    }
}

/// Field calibration: the calibrated field in nT is `matrix · (raw − bias)`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FieldCal<T> {
    /// Hard-iron bias, in raw sensor units.
    pub bias: Vec3<T>,
    /// Raw units → nT, including soft iron, scale and non-orthogonality.
    pub matrix: Mat3<T>,
}

/// Why a set of coefficients is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CalError {
    /// A coefficient is NaN or infinite.
    NonFinite,
    /// The matrix is singular or mirrors the field (det ≤ 0): headings would
    /// turn the wrong way.
    NotOrientationPreserving,
    /// The matrix stretches one direction far more than another (ratio of
    /// largest to smallest column norm above the limit): not a plausible
    /// sensor, more likely a bad fit.
    Implausible,
    /// The bias exceeds the sensor's range.
    BiasOutOfRange,
}

/// Largest plausible ratio between the strongest and weakest column of the
/// matrix (a steel hull distorts, but not by an order of magnitude).
pub const MAX_ANISOTROPY: f64 = 4.0;

impl<T: Real> FieldCal<T> {
    /// No correction: raw units are taken as nT.
    pub fn identity() -> Self {
        Self { bias: [T::ZERO; 3], matrix: identity3() }
    }

    /// The calibrated field, `matrix · (raw − bias)`.
    #[inline(always)]
    pub fn apply(&self, raw: Vec3<T>) -> Vec3<T> {
        let d = [raw[0] - self.bias[0], raw[1] - self.bias[1], raw[2] - self.bias[2]];
        mul_mat_vec(&self.matrix, d)
    }

    /// Checks the coefficients before use or storage. `max_bias_abs` is the
    /// sensor's range in raw units.
    pub fn validate(&self, max_bias_abs: T) -> Result<(), CalError> {
        if !self.bias.iter().chain(self.matrix.iter().flatten()).all(|v| v.is_finite()) {
            return Err(CalError::NonFinite);
        }
        if !(det3(&self.matrix) > T::ZERO) {
            return Err(CalError::NotOrientationPreserving);
        }
        let col = |j: usize| {
            let (a, b, c) = (self.matrix[0][j], self.matrix[1][j], self.matrix[2][j]);
            (a * a + b * b + c * c).sqrt()
        };
        let norms = [col(0), col(1), col(2)];
        let (lo, hi) = norms.iter().fold((norms[0], norms[0]), |(lo, hi), &n| (lo.min(n), hi.max(n)));
        if !(hi <= T::from_f64(MAX_ANISOTROPY) * lo) {
            return Err(CalError::Implausible);
        }
        if self.bias.iter().any(|b| !(b.abs() <= max_bias_abs)) {
            return Err(CalError::BiasOutOfRange);
        }
        Ok(())
    }
}

/// The five-term Fourier heading correction of paper 000 (eqs 19, 31), in
/// radians: `δψ = A + B sin ψ + C cos ψ + D sin 2ψ + E cos 2ψ`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Swing<T> {
    /// Constant offset.
    pub a: T,
    /// sin ψ term.
    pub b: T,
    /// cos ψ term.
    pub c: T,
    /// sin 2ψ term.
    pub d: T,
    /// cos 2ψ term.
    pub e: T,
}

impl<T: Real> Swing<T> {
    /// No correction.
    pub fn zero() -> Self {
        Self { a: T::ZERO, b: T::ZERO, c: T::ZERO, d: T::ZERO, e: T::ZERO }
    }

    /// The correction δψ at heading ψ.
    pub fn correction_rad(&self, heading_rad: T) -> T {
        self.correction_of_phasor(heading_rad.sin(), heading_rad.cos())
    }

    /// The correction δψ from sin ψ and cos ψ (e.g. the normalised levelled
    /// field, with no trigonometry); sin 2ψ and cos 2ψ by the double angle.
    pub fn correction_of_phasor(&self, sin_heading: T, cos_heading: T) -> T {
        let (s1, c1) = (sin_heading, cos_heading);
        let (s2, c2) = (T::from_f64(2.0) * s1 * c1, c1 * c1 - s1 * s1);
        self.a + self.b * s1 + self.c * c1 + self.d * s2 + self.e * c2
    }

    /// Corrected heading in [0, 2π) (eq 31).
    pub fn apply(&self, heading_rad: T) -> T {
        wrap_two_pi(heading_rad + self.correction_rad(heading_rad))
    }

    /// The coefficients as an array `[A, B, C, D, E]`.
    pub fn to_array(&self) -> [T; 5] {
        [self.a, self.b, self.c, self.d, self.e]
    }

    /// From `[A, B, C, D, E]`.
    pub fn from_array(x: [T; 5]) -> Self {
        Self { a: x[0], b: x[1], c: x[2], d: x[3], e: x[4] }
    }
}

/// The thruster-current and temperature terms (the calibration document's
/// `current` and `temperature` blocks, `docs/INTERFACES.md`): the raw sample
/// corrected for them is `raw ⊘ (1 + gain_per_c ⊙ (temp_c − ref_c)) −
/// bias_per_a · current_a` (per axis), before the field calibration's
/// `matrix · (· − bias)`. The sensor's gain changes with temperature for
/// everything it sees, the hull's hard iron included; the thrusters add a
/// field proportional to their current.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EnvTerms<T> {
    /// Field the thrusters add per ampere of motor current, raw units per A.
    pub bias_per_a: Vec3<T>,
    /// Temperature at which the field calibration holds, °C.
    pub ref_c: T,
    /// Relative gain change per °C, per axis.
    pub gain_per_c: Vec3<T>,
}

/// The conditions of one sample that the [`EnvTerms`] correct for.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Environment<T> {
    /// Thruster (motor) current, A.
    pub current_a: T,
    /// Temperature at the magnetometer, °C.
    pub temp_c: T,
}

/// Largest relative gain change per °C accepted (the HMC100x drifts about
/// 0.003 per °C; ten times that is no sensor).
pub const MAX_GAIN_PER_C: f64 = 0.03;

impl<T: Real> EnvTerms<T> {
    /// No current or temperature terms (reference 20 °C).
    pub fn none() -> Self {
        Self { bias_per_a: [T::ZERO; 3], ref_c: T::from_f64(20.0), gain_per_c: [T::ZERO; 3] }
    }

    /// True when the terms change nothing.
    pub fn is_none(&self) -> bool {
        self.bias_per_a.iter().chain(self.gain_per_c.iter()).all(|v| *v == T::ZERO)
    }

    /// The raw sample with the temperature gain and the thruster field
    /// removed: `raw ⊘ (1 + k ⊙ (temp_c − ref_c)) − bias_per_a · current_a`.
    pub fn correct_raw(&self, raw: Vec3<T>, env: &Environment<T>) -> Vec3<T> {
        let dt = env.temp_c - self.ref_c;
        let mut out = [T::ZERO; 3];
        for i in 0..3 {
            out[i] = raw[i] / (T::ONE + self.gain_per_c[i] * dt) - self.bias_per_a[i] * env.current_a;
        }
        out
    }

    /// Checks the terms before use or storage: finite, each gain below
    /// [`MAX_GAIN_PER_C`] per °C, the current term below `max_bias_per_a`
    /// raw units per A.
    pub fn validate(&self, max_bias_per_a: T) -> Result<(), CalError> {
        if !self.bias_per_a.iter().chain(self.gain_per_c.iter()).chain(core::iter::once(&self.ref_c)).all(|v| v.is_finite()) {
            return Err(CalError::NonFinite);
        }
        if self.gain_per_c.iter().any(|k| !(k.abs() < T::from_f64(MAX_GAIN_PER_C))) || !(self.ref_c.abs() < T::from_f64(100.0)) {
            return Err(CalError::Implausible);
        }
        if self.bias_per_a.iter().any(|b| !(b.abs() <= max_bias_per_a)) {
            return Err(CalError::BiasOutOfRange);
        }
        Ok(())
    }
}

/// Everything the board applies to a sample.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Calibration<T> {
    /// Field calibration.
    pub field: FieldCal<T>,
    /// Heading correction from swinging (zero when absent).
    pub swing: Swing<T>,
    /// Magnetic declination, east positive.
    pub declination_rad: T,
    /// Thruster-current and temperature terms ([`EnvTerms::none`] when absent).
    pub env: EnvTerms<T>,
}

/// One calibrated output sample.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Output<T> {
    /// Calibrated field, body frame, nT.
    pub field_nt: Vec3<T>,
    /// True heading in [0, 2π) (magnetic + swing + declination).
    pub true_heading_rad: T,
}

impl<T: Real> Calibration<T> {
    /// No correction at all.
    pub fn identity() -> Self {
        Self { field: FieldCal::identity(), swing: Swing::zero(), declination_rad: T::ZERO, env: EnvTerms::none() }
    }

    /// Calibrated field only.
    pub fn field_nt(&self, raw: Vec3<T>) -> Vec3<T> {
        self.field.apply(raw)
    }

    /// Magnetic heading after field and swing calibration, [0, 2π).
    pub fn magnetic_heading_rad(&self, raw: Vec3<T>, roll_rad: T, pitch_rad: T) -> T {
        wrap_two_pi(self.apply(raw, roll_rad, pitch_rad).true_heading_rad - self.declination_rad)
    }

    /// Field and true heading for one sample with the AHRS attitude.
    pub fn apply(&self, raw: Vec3<T>, roll_rad: T, pitch_rad: T) -> Output<T> {
        self.apply_tilt(raw, &Tilt::new(roll_rad, pitch_rad))
    }

    /// [`Calibration::apply`] with the attitude's sines and cosines already
    /// computed: the per-sample path of the firmware. The swing correction
    /// takes sin ψ and cos ψ from the levelled field itself, so a sample
    /// costs one square root, one division and one `atan2`.
    pub fn apply_tilt(&self, raw: Vec3<T>, tilt: &Tilt<T>) -> Output<T> {
        self.heading_of_field(self.field.apply(raw), tilt)
    }

    /// [`Calibration::apply_tilt`] with the current and temperature terms
    /// applied first ([`EnvTerms::correct_raw`]).
    pub fn apply_tilt_env(&self, raw: Vec3<T>, tilt: &Tilt<T>, env: &Environment<T>) -> Output<T> {
        self.heading_of_field(self.field.apply(self.env.correct_raw(raw, env)), tilt)
    }

    // Inlined, as `FieldCal::apply` and `mul_mat_vec`: outlined, the three
    // cost the Cortex-M4F's per-sample path 36 instructions of argument and
    // result copies (263 → 299 with the terms, `cargo xtask bench`).
    /// The heading of an already calibrated field (the second half of
    /// [`Calibration::apply_tilt`], for a caller that has the field).
    #[inline(always)]
    pub fn heading_of_field(&self, field_nt: Vec3<T>, tilt: &Tilt<T>) -> Output<T> {
        let l = tilt.level(field_nt);
        let hh = (l[0] * l[0] + l[1] * l[1]).sqrt();
        Output { field_nt, true_heading_rad: self.true_heading_of_levelled(l, hh) }
    }

    /// The true heading of a calibrated field already levelled (`levelled_nt`,
    /// [`Tilt::level`]) with its horizontal intensity `horizontal_nt`
    /// (`√(l₀² + l₁²)`): the swing correction and the declination added. For
    /// a caller that needs the levelled field too (the integrity monitor).
    #[inline(always)]
    pub fn true_heading_of_levelled(&self, levelled_nt: Vec3<T>, horizontal_nt: T) -> T {
        let (l, hh) = (levelled_nt, horizontal_nt);
        let psi = heading_of_levelled(l);
        let correction = if hh > T::ZERO { self.swing.correction_of_phasor(-l[1] / hh, l[0] / hh) } else { self.swing.correction_rad(psi) };
        wrap_two_pi(psi + correction + self.declination_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::heading::{ned_field, ned_to_body, wrap_pi};
    use core::f64::consts::PI;

    #[test]
    fn apply_undoes_a_known_distortion_and_heading_is_true() {
        // raw = D·h + b with D a soft-iron matrix; the calibration is D⁻¹.
        let d = [[1.2, 0.05, 0.0], [0.05, 0.9, 0.02], [0.0, 0.02, 1.1]];
        let m = crate::linalg::inverse3(&d).unwrap();
        let b = [300.0, -150.0, 80.0];
        let cal = Calibration { field: FieldCal { bias: b, matrix: m }, swing: Swing::zero(), declination_rad: 0.1, env: EnvTerms::none() };
        let h = ned_to_body(ned_field(48730.0, 0.97, 0.1), 0.3, -0.1, 1.0);
        let raw = mul_mat_vec(&d, h);
        let raw = [raw[0] + b[0], raw[1] + b[1], raw[2] + b[2]];
        let out = cal.apply(raw, 0.3, -0.1);
        for i in 0..3 {
            assert!((out.field_nt[i] - h[i]).abs() < 1e-9);
        }
        // Field built with declination 0.1 rad: true heading is the yaw.
        assert!(wrap_pi(out.true_heading_rad - 1.0).abs() < 1e-12);
    }

    #[test]
    fn current_and_temperature_terms_follow_the_document_formula() {
        // A sensor whose gain is 1 + k·(T − T0) (the HMC100x's −0.3 %/°C
        // order) sees the hull's hard iron and the thrusters' field through
        // that gain: raw = g ⊙ (D·h + b + c·I). Written here from that
        // physics, not from correct_raw.
        let (k, t0, t) = ([-0.003, -0.0028, -0.0031], 15.0, 27.0);
        let (b, c, current) = ([2000.0, -800.0, 400.0], [12.0, -3.0, 25.0], 14.0);
        let d = [[1.2, 0.05, 0.0], [0.05, 0.9, 0.02], [0.0, 0.02, 1.1]];
        let h = [21_000.0, -3_000.0, 42_000.0];
        let dh = mul_mat_vec(&d, h);
        let raw: [f64; 3] = core::array::from_fn(|i| (1.0 + k[i] * (t - t0)) * (dh[i] + b[i] + c[i] * current));
        let cal = Calibration {
            field: FieldCal { bias: b, matrix: crate::linalg::inverse3(&d).unwrap() },
            swing: Swing::zero(),
            declination_rad: 0.0,
            env: EnvTerms { bias_per_a: c, ref_c: t0, gain_per_c: k },
        };
        let out = cal.apply_tilt_env(raw, &Tilt::new(0.0, 0.0), &Environment { current_a: current, temp_c: t });
        for i in 0..3 {
            assert!((out.field_nt[i] - h[i]).abs() < 1e-8, "{i}: {} vs {}", out.field_nt[i], h[i]);
        }
        // Without the terms the same sample is hundreds of nT off (the
        // gain change alone moves the 2 000-unit bias by 72 units).
        let plain = cal.apply_tilt(raw, &Tilt::new(0.0, 0.0));
        assert!((plain.field_nt[2] - h[2]).abs() > 500.0);
        assert_eq!(cal.env.validate(100.0), Ok(()));
        let mut bad = cal.env;
        bad.gain_per_c[1] = 0.05;
        assert_eq!(bad.validate(100.0), Err(CalError::Implausible));
        bad = cal.env;
        bad.bias_per_a[0] = f64::NAN;
        assert_eq!(bad.validate(100.0), Err(CalError::NonFinite));
        assert_eq!(cal.env.validate(10.0), Err(CalError::BiasOutOfRange));
        assert!(EnvTerms::<f64>::none().is_none() && !cal.env.is_none());
    }

    #[test]
    fn swing_double_angle_identities_hold() {
        let s = Swing { a: 0.14199, b: -0.01101, c: 0.01071, d: 0.00610, e: 0.05528 };
        for k in 0..36 {
            let psi = k as f64 * PI / 18.0;
            let want = s.a + s.b * psi.sin() + s.c * psi.cos() + s.d * (2.0 * psi).sin() + s.e * (2.0 * psi).cos();
            assert!((s.correction_rad(psi) - want).abs() < 1e-15);
        }
    }

    #[test]
    fn validation_refuses_bad_coefficients() {
        let good = FieldCal { bias: [10.0, 0.0, 0.0], matrix: identity3::<f64>() };
        assert_eq!(good.validate(1e5), Ok(()));
        let mut c = good;
        c.matrix[1][1] = -1.0;
        assert_eq!(c.validate(1e5), Err(CalError::NotOrientationPreserving));
        let mut c = good;
        c.matrix[2][2] = 10.0;
        assert_eq!(c.validate(1e5), Err(CalError::Implausible));
        let mut c = good;
        c.bias[0] = f64::NAN;
        assert_eq!(c.validate(1e5), Err(CalError::NonFinite));
        assert_eq!(good.validate(5.0), Err(CalError::BiasOutOfRange));
    }
}
