//! A calibration document in another stack's terms: ArduPilot's `COMPASS_*`
//! and PX4's `CAL_MAG0_*` parameters (`magcal export`).
//!
//! magcal's field is `h_nT = M · (raw − b − c·I)` (raw in the recording's
//! input units, `c` the current block's `bias_per_a`, `I` the motor current
//! in A). With `k` nT per input unit and `u` nT per stack unit (ArduPilot
//! works in milligauss, `u` = 100; PX4 in gauss, `u` = 1e5), the raw field
//! in stack units is `r = raw·k/u`, and magcal's field in stack units is
//!
//! `h/u = A · (r − b_s − c_s·I)` with `A = M/k`, `b_s = b·k/u`, `c_s = c·k/u`.
//!
//! The exported parameters make each stack's own correction give exactly
//! that: **the exported field is magcal's field in the stack's unit**
//! (1 mGauss = 100 nT, 1 gauss = 1e5 nT).
//!
//! * ArduPilot, `AP_Compass_Backend::correct_field`
//!   (libraries/AP_Compass/AP_Compass_Backend.cpp): `mag += offsets;
//!   mag *= scale_factor` (only when `COMPASS_SCALE` lies within
//!   `COMPASS_MIN_SCALE_FACTOR..COMPASS_MAX_SCALE_FACTOR`, 1/1.5..1.5, see
//!   `Compass::have_scale_factor` and CompassCalibrator.h); `mag = mat · mag`
//!   with `mat` symmetric from `DIA` (diagonal) and `ODI` (xy, xz, yz); then
//!   `mag += mot · current` after the matrix, with `COMPASS_MOTCT` = 2
//!   (`AP_COMPASS_MOT_COMP_CURRENT`). Offsets are **added**, in milligauss;
//!   `MOT` is mGauss per A. So `OFS = −b_s`, `SCALE·mat = A`, `MOT = −A·c_s`.
//! * PX4, `calibration::Magnetometer::Correct`
//!   (src/lib/sensor_calibration/Magnetometer.hpp):
//!   `_rotation * (_scale * ((data + _power * _power_compensation) - _offset))`,
//!   `_scale` symmetric with `CAL_MAG0_{X,Y,Z}SCALE` on the diagonal and
//!   `CAL_MAG0_{X,Y,Z}ODIAG` = (xy, xz, yz) off it (Magnetometer.cpp
//!   `set_scale`, `set_offdiagonal`); with `CAL_MAG_COMP_TYP` = 2 `_power`
//!   is the battery current in kA (`bat_stat.current_a * 0.001f`,
//!   VehicleMagnetometer.cpp `Run`), `COMP` in gauss per kA, added to the raw
//!   field before the offset is subtracted. So `OFF = b_s`, `SCALE/ODIAG = A`,
//!   `COMP = −1000·c_s`. The rotation `_rotation` (`CAL_MAG0_ROT`, the
//!   board's) is assumed to be the identity between the recording's axes and
//!   the axes PX4 applies the offsets in.
//!
//! Both stacks hold a **symmetric** matrix. A general one (the triangular
//! model, a gyro fit's) is split by the polar decomposition `A = R·P`
//! (`P` symmetric positive definite, `R` a rotation): `P` is exported, so
//! the stack's field is `Rᵀ·h`, magcal's field turned by `R`'s angle. That
//! rotation, the swing (Fourier heading) terms and the temperature block are
//! what the stacks cannot express; each is listed in [`Export::warnings`]
//! and written into the file, and a rotation above
//! [`ExportOptions::max_rotation_deg`] is refused.

use std::fmt::Write as _;
use std::path::Path;

use calib_core::linalg::Mat3;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

use crate::doc::CalDoc;

/// The stack a calibration is exported to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Stack {
    /// ArduPilot (ArduSub, ArduCopter, Rover, …): `COMPASS_*`, first compass.
    ArduPilot,
    /// PX4: `CAL_MAG0_*`.
    Px4,
}

impl Stack {
    /// nT per unit of the stack's magnetic field.
    pub fn unit_nt(self) -> f64 {
        match self {
            Stack::ArduPilot => 100.0, // milligauss
            Stack::Px4 => 1e5,         // gauss
        }
    }

    /// The name of the stack's unit.
    pub fn unit_name(self) -> &'static str {
        match self {
            Stack::ArduPilot => "mGauss",
            Stack::Px4 => "Gauss",
        }
    }

    /// The stack's name as `--format` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Stack::ArduPilot => "ardupilot",
            Stack::Px4 => "px4",
        }
    }
}

/// Units the raw field of a calibration may be in (the recording's input units).
pub const RAW_UNITS: [(&str, f64); 4] = [("nT", 1.0), ("µT", 1e3), ("mGauss", 100.0), ("Gauss", 1e5)];

/// How far the matrix's mean gain may be from a unit's for that unit to be
/// inferred (relative): sensor scale errors are a few per cent.
pub const UNIT_INFERENCE_TOLERANCE: f64 = 0.10;

/// ArduPilot applies `COMPASS_SCALE` only within this range
/// (`COMPASS_MIN_SCALE_FACTOR`, `COMPASS_MAX_SCALE_FACTOR` in
/// libraries/AP_Compass/CompassCalibrator.h: 1/1.5 and 1.5).
pub const ARDUPILOT_SCALE_RANGE: (f64, f64) = (1.0 / 1.5, 1.5);

/// ArduPilot's default `COMPASS_OFFS_MAX` (`AP_COMPASS_OFFSETS_MAX_DEFAULT`,
/// AP_Compass.cpp), mGauss: larger offsets fail the pre-arm check.
pub const ARDUPILOT_OFFSETS_MAX_MGAUSS: f64 = 1250.0;

/// What to export and how.
#[derive(Debug, Clone, Copy)]
pub struct ExportOptions {
    /// The target stack.
    pub stack: Stack,
    /// nT per raw input unit; `None` infers it from the matrix's gain
    /// (one of [`RAW_UNITS`] within [`UNIT_INFERENCE_TOLERANCE`]).
    pub raw_nt_per_unit: Option<f64>,
    /// Largest rotation part (polar decomposition) exported with a warning, degrees.
    pub max_rotation_deg: f64,
}

/// One parameter and its value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    /// The stack's parameter name.
    pub name: String,
    /// Its value (in the stack's unit for this parameter).
    pub value: f64,
    /// Integer parameter (written as such; MAVLink type INT32 for PX4).
    #[serde(default)]
    pub integer: bool,
}

/// Part of a calibration that the stack cannot express (or a note about one
/// it can), as a typed item of `--json` and a `WARNING` line of the file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Unexpressed {
    /// The rotation part of a non-symmetric matrix: the stack's field is
    /// magcal's turned by this rotation (angles of `R`, roll-pitch-yaw, degrees).
    Rotation {
        /// Rotation angle, degrees.
        angle_deg: f64,
        /// Roll of `R` (about x), degrees.
        roll_deg: f64,
        /// Pitch of `R` (about y), degrees.
        pitch_deg: f64,
        /// Yaw of `R` (about z), degrees: roughly the heading difference.
        yaw_deg: f64,
    },
    /// The swing (Fourier heading) correction, radians; the largest
    /// correction it makes over all headings in degrees.
    Swing {
        /// `[A, B, C, D, E]`, radians.
        coefficients_rad: [f64; 5],
        /// Largest |δψ| over headings, degrees.
        max_correction_deg: f64,
    },
    /// The temperature block (a gain that follows temperature; neither stack
    /// has a magnetometer gain against temperature).
    Temperature {
        /// Reference temperature, °C.
        ref_c: f64,
        /// Relative gain change per °C.
        gain_per_c: [f64; 3],
    },
    /// The document's declination: not a sensor coefficient; the stacks take
    /// it from their position.
    Declination {
        /// Degrees east.
        declination_deg: f64,
    },
    /// ArduPilot offsets beyond the default `COMPASS_OFFS_MAX`: exported,
    /// but the pre-arm check fails until `COMPASS_OFFS_MAX` is raised.
    OffsetsOverPrearmLimit {
        /// Largest |offset|, mGauss.
        max_offset_mgauss: f64,
        /// The default limit, mGauss.
        limit_mgauss: f64,
    },
}

impl Unexpressed {
    /// One line for the file and stderr.
    pub fn message(&self, stack: Stack) -> String {
        let who = match stack {
            Stack::ArduPilot => "ArduPilot",
            Stack::Px4 => "PX4",
        };
        match self {
            Unexpressed::Rotation { angle_deg, roll_deg, pitch_deg, yaw_deg } => format!(
                "the matrix is not symmetric: {who} holds only its symmetric part, so its field is magcal's turned by {angle_deg:.3}° (roll {roll_deg:.3}°, pitch {pitch_deg:.3}°, yaw {yaw_deg:.3}°); headings differ by about the yaw"
            ),
            Unexpressed::Swing { coefficients_rad: s, max_correction_deg } => format!(
                "the swing correction (A={:.5} B={:.5} C={:.5} D={:.5} E={:.5} rad, up to {max_correction_deg:.2}° of heading) has no {who} parameter and is not applied",
                s[0], s[1], s[2], s[3], s[4]
            ),
            Unexpressed::Temperature { ref_c, gain_per_c: k } => format!(
                "the temperature block (gain change [{:.3e}, {:.3e}, {:.3e}] per °C from {ref_c} °C) has no {who} parameter and is not applied",
                k[0], k[1], k[2]
            ),
            Unexpressed::Declination { declination_deg } => match stack {
                Stack::ArduPilot => format!("declination {declination_deg:.3}° not exported: ArduPilot takes it from its position (COMPASS_AUTODEC=1); to fix it instead set COMPASS_DEC={:.5} (rad) and COMPASS_AUTODEC=0", declination_deg.to_radians()),
                Stack::Px4 => format!("declination {declination_deg:.3}° not exported: PX4 takes it from its position (EKF2_DECL_TYPE)"),
            },
            Unexpressed::OffsetsOverPrearmLimit { max_offset_mgauss, limit_mgauss } => format!(
                "an offset of {max_offset_mgauss:.0} mGauss is beyond ArduPilot's default COMPASS_OFFS_MAX ({limit_mgauss:.0}): raise COMPASS_OFFS_MAX or the pre-arm check fails"
            ),
        }
    }
}

/// A calibration in a stack's parameters: what `magcal export --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Export {
    /// The stack.
    pub format: Stack,
    /// The stack's field unit (`mGauss`, `Gauss`).
    pub stack_unit: String,
    /// nT per raw input unit used.
    pub raw_nt_per_unit: f64,
    /// Whether [`Export::raw_nt_per_unit`] was inferred from the matrix's gain.
    pub raw_unit_inferred: bool,
    /// Angle of the rotation part that the stack cannot hold, degrees (0 for a symmetric matrix).
    pub rotation_deg: f64,
    /// The parameters, in the order written.
    pub params: Vec<Param>,
    /// What the stack cannot express (and notes), each also a `WARNING` line of the file.
    pub warnings: Vec<ExportWarning>,
}

/// A typed warning and its message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExportWarning {
    /// What it is about.
    #[serde(flatten)]
    pub what: Unexpressed,
    /// The line written to the file and stderr.
    pub message: String,
}

/// Why a calibration was not exported.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The raw units could not be inferred and were not given.
    #[error("the calibration's mean gain is {gain_nt_per_unit:.4} nT per raw unit, which is none of nT, µT, mGauss or Gauss (within {tol:.0} %): the raw units must be given", tol = UNIT_INFERENCE_TOLERANCE * 100.0)]
    UnknownUnits {
        /// cbrt(det M), nT per raw unit.
        gain_nt_per_unit: f64,
    },
    /// The given raw unit is not a positive number.
    #[error("nT per raw unit must be a positive number, not {0}")]
    BadUnit(f64),
    /// The rotation part is beyond what may be dropped.
    #[error("the matrix's rotation part is {angle_deg:.2}°, more than {max_deg}° that {stack} could not express (it holds only a symmetric matrix)")]
    Rotation {
        /// The rotation's angle, degrees.
        angle_deg: f64,
        /// The limit, degrees.
        max_deg: f64,
        /// The stack.
        stack: &'static str,
    },
    /// The gain in the stack's unit is far from 1: the raw units are wrong
    /// (and ArduPilot would ignore the scale factor).
    #[error("the calibration's gain in {stack}'s {unit} is {scale:.3}, outside the {:.3}..{:.3} of a calibration whose raw units are right ({consequence}): the raw units look wrong", ARDUPILOT_SCALE_RANGE.0, ARDUPILOT_SCALE_RANGE.1)]
    Gain {
        /// cbrt(det P).
        scale: f64,
        /// The stack.
        stack: &'static str,
        /// Its unit.
        unit: &'static str,
        /// What the stack would do with such a gain, in its own parameters' names.
        consequence: &'static str,
    },
    /// The matrix could not be decomposed.
    #[error("the matrix cannot be decomposed (singular or not finite)")]
    Singular,
}

/// `A = R·P`: the polar decomposition (by the SVD `A = U Σ Vᵀ`:
/// `R = U Vᵀ`, `P = V Σ Vᵀ`), row-major arrays.
pub fn polar(a: &Mat3<f64>) -> Result<(Mat3<f64>, Mat3<f64>), ExportError> {
    let m = Matrix3::from_fn(|i, j| a[i][j]);
    if !m.iter().all(|v| v.is_finite()) || m.determinant() <= 0.0 {
        return Err(ExportError::Singular);
    }
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else { return Err(ExportError::Singular) };
    let r = u * v_t;
    let p = v_t.transpose() * Matrix3::from_diagonal(&svd.singular_values) * v_t;
    // Symmetric to rounding; make it exactly so.
    let p = (p + p.transpose()) * 0.5;
    let arr = |x: Matrix3<f64>| [[x[(0, 0)], x[(0, 1)], x[(0, 2)]], [x[(1, 0)], x[(1, 1)], x[(1, 2)]], [x[(2, 0)], x[(2, 1)], x[(2, 2)]]];
    Ok((arr(r), arr(p)))
}

/// The raw unit a matrix's mean gain (`cbrt(det M)`, nT per raw unit) points to.
pub fn infer_raw_unit(matrix: &[[f64; 3]; 3]) -> Result<(&'static str, f64), ExportError> {
    let gain = Matrix3::from_fn(|i, j| matrix[i][j]).determinant().cbrt();
    RAW_UNITS
        .iter()
        .find(|(_, nt)| (gain / nt - 1.0).abs() <= UNIT_INFERENCE_TOLERANCE)
        .copied()
        .ok_or(ExportError::UnknownUnits { gain_nt_per_unit: gain })
}

fn mat_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// What the document holds that neither stack can express: the matrix's
/// rotation part (rotation `r` of `angle_deg`), the swing, the temperature
/// gains, the declination.
fn unexpressed(doc: &CalDoc, r: &[[f64; 3]; 3], angle_deg: f64) -> Vec<Unexpressed> {
    let mut warnings = Vec::new();
    // Asymmetry below rounding is no rotation worth a line.
    if angle_deg > 1e-6 {
        warnings.push(Unexpressed::Rotation {
            angle_deg,
            roll_deg: r[2][1].atan2(r[2][2]).to_degrees(),
            pitch_deg: (-r[2][0]).clamp(-1.0, 1.0).asin().to_degrees(),
            yaw_deg: r[1][0].atan2(r[0][0]).to_degrees(),
        });
    }
    if let Some(s) = doc.swing {
        let max = (0..360).map(|d| s.correction_rad((d as f64).to_radians()).abs()).fold(0.0, f64::max);
        warnings.push(Unexpressed::Swing { coefficients_rad: s.to_array(), max_correction_deg: max.to_degrees() });
    }
    if let Some(t) = doc.temperature {
        warnings.push(Unexpressed::Temperature { ref_c: t.ref_c, gain_per_c: t.gain_per_c });
    }
    if let Some(d) = doc.declination_deg {
        warnings.push(Unexpressed::Declination { declination_deg: d });
    }
    warnings
}

fn param(name: &str, value: f64) -> Param {
    Param { name: name.into(), value, integer: false }
}

fn int_param(name: &str, value: i32) -> Param {
    Param { name: name.into(), value: value.into(), integer: true }
}

const XYZ: [&str; 3] = ["X", "Y", "Z"];

/// ArduPilot's COMPASS_* parameters from the symmetric matrix `p`, the
/// offsets `b_s` and the per-ampere field `c_s` in the stack's unit; warns
/// when the offsets exceed its pre-arm limit.
fn ardupilot_params(p: &[[f64; 3]; 3], b_s: [f64; 3], c_s: Option<[f64; 3]>, warnings: &mut Vec<Unexpressed>) -> Result<Vec<Param>, ExportError> {
    // In range: `export` checked it for either stack.
    let scale = gain(p);
    let mut params = Vec::new();
    let ofs = b_s.map(|b| -b);
    for i in 0..3 {
        params.push(param(&format!("COMPASS_OFS_{}", XYZ[i]), ofs[i]));
    }
    for i in 0..3 {
        params.push(param(&format!("COMPASS_DIA_{}", XYZ[i]), p[i][i] / scale));
    }
    for (n, (i, j)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
        params.push(param(&format!("COMPASS_ODI_{}", XYZ[n]), p[i][j] / scale));
    }
    params.push(param("COMPASS_SCALE", scale));
    if let Some(c) = c_s {
        // Added after the matrix (correct_field): MOT = −P·c_s, mGauss per A.
        let mot = mat_vec(p, c).map(|v| -v);
        for i in 0..3 {
            params.push(param(&format!("COMPASS_MOT_{}", XYZ[i]), mot[i]));
        }
        params.push(int_param("COMPASS_MOTCT", 2));
    }
    let max_ofs = ofs.iter().fold(0.0f64, |m, o| m.max(o.abs()));
    if max_ofs > ARDUPILOT_OFFSETS_MAX_MGAUSS {
        warnings.push(Unexpressed::OffsetsOverPrearmLimit { max_offset_mgauss: max_ofs, limit_mgauss: ARDUPILOT_OFFSETS_MAX_MGAUSS });
    }
    Ok(params)
}

/// The symmetric matrix's mean gain, cbrt(det P).
fn gain(p: &[[f64; 3]; 3]) -> f64 {
    Matrix3::from_fn(|i, j| p[i][j]).determinant().cbrt()
}

/// PX4's CAL_MAG0_* parameters from the symmetric matrix `p`, the offsets
/// `b_s` and the per-ampere field `c_s` in the stack's unit.
fn px4_params(p: &[[f64; 3]; 3], b_s: [f64; 3], c_s: Option<[f64; 3]>) -> Vec<Param> {
    let mut params = Vec::new();
    for i in 0..3 {
        params.push(param(&format!("CAL_MAG0_{}OFF", XYZ[i]), b_s[i]));
    }
    for i in 0..3 {
        params.push(param(&format!("CAL_MAG0_{}SCALE", XYZ[i]), p[i][i]));
    }
    for (n, (i, j)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
        params.push(param(&format!("CAL_MAG0_{}ODIAG", XYZ[n]), p[i][j]));
    }
    if let Some(c) = c_s {
        // Added to the raw field before the offset, per kA: COMP = −1000·c_s gauss/kA.
        for i in 0..3 {
            params.push(param(&format!("CAL_MAG0_{}COMP", XYZ[i]), -1000.0 * c[i]));
        }
        params.push(int_param("CAL_MAG_COMP_TYP", 2));
    }
    params
}

/// Builds the stack's parameters for a document (its optional blocks included).
pub fn export(doc: &CalDoc, opts: &ExportOptions) -> Result<Export, ExportError> {
    let stack = opts.stack;
    let (k, inferred) = match opts.raw_nt_per_unit {
        Some(k) if k.is_finite() && k > 0.0 => (k, false),
        Some(k) => return Err(ExportError::BadUnit(k)),
        None => (infer_raw_unit(&doc.matrix)?.1, true),
    };
    let u = stack.unit_nt();
    let a = doc.matrix.map(|row| row.map(|m| m / k));
    let (r, p) = polar(&a)?;
    // The gain in the stack's unit: near 1 when the raw units are right,
    // for either stack (PX4 took XSCALE 5.1 or 0.00005 without a word).
    let scale = gain(&p);
    if !(scale >= ARDUPILOT_SCALE_RANGE.0 && scale <= ARDUPILOT_SCALE_RANGE.1) {
        let consequence = match stack {
            Stack::ArduPilot => "the range in which ArduPilot applies COMPASS_SCALE; outside it the scale is ignored",
            Stack::Px4 => "PX4 would take CAL_MAG0_XSCALE, YSCALE, ZSCALE as given and scale the field by it",
        };
        return Err(ExportError::Gain { scale, stack: stack.name(), unit: stack.unit_name(), consequence });
    }
    let angle_deg = ((r[0][0] + r[1][1] + r[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees();
    if angle_deg > opts.max_rotation_deg {
        return Err(ExportError::Rotation { angle_deg, max_deg: opts.max_rotation_deg, stack: stack.name() });
    }
    let b_s = doc.bias.map(|b| b * k / u);
    let c_s = doc.current.map(|c| c.bias_per_a.map(|c| c * k / u));

    let mut warnings = unexpressed(doc, &r, angle_deg);
    let params = match stack {
        Stack::ArduPilot => ardupilot_params(&p, b_s, c_s, &mut warnings)?,
        Stack::Px4 => px4_params(&p, b_s, c_s),
    };
    let warnings = warnings.into_iter().map(|w| ExportWarning { message: w.message(stack), what: w }).collect();
    Ok(Export {
        format: stack,
        stack_unit: stack.unit_name().into(),
        raw_nt_per_unit: k,
        raw_unit_inferred: inferred,
        rotation_deg: angle_deg,
        params,
        warnings,
    })
}

impl Export {
    /// The parameter file: ArduPilot's `NAME,VALUE` lines (Mission Planner
    /// and MAVProxy read them), PX4's QGroundControl tab-separated
    /// `1 1 NAME VALUE TYPE` lines; `#` comments, one `# WARNING:` line for
    /// each warning.
    pub fn to_file_text(&self, source: &Path, doc: &CalDoc) -> String {
        let mut s = String::new();
        let stack = self.format;
        let _ = writeln!(s, "# magcal export --format {} of {} (model {}, field {} nT)", stack.name(), source.display(), doc.model.name(), doc.field_nt);
        let unit = RAW_UNITS.iter().find(|(_, nt)| *nt == self.raw_nt_per_unit).map(|(n, _)| n.to_string()).unwrap_or_else(|| format!("{} nT per unit", self.raw_nt_per_unit));
        let _ = writeln!(
            s,
            "# raw units: {unit}{}; the field these parameters give is magcal's calibrated field in {} (1 {} = {} nT)",
            if self.raw_unit_inferred { " (inferred from the matrix's gain)" } else { "" },
            stack.unit_name(),
            stack.unit_name(),
            stack.unit_nt()
        );
        match stack {
            Stack::ArduPilot => {
                let _ = writeln!(s, "# first compass; the raw field is ArduPilot's after its orientation (COMPASS_ORIENT, AHRS_ORIENTATION)");
                if !self.params.iter().any(|p| p.name == "COMPASS_MOTCT") {
                    let _ = writeln!(s, "# no current block: COMPASS_MOT_* and COMPASS_MOTCT are not written");
                }
            }
            Stack::Px4 => {
                let _ = writeln!(s, "# magnetometer 0; keep the vehicle's CAL_MAG0_ID (the device the calibration is for); CAL_MAG0_ROT assumed to make no rotation between the recording's axes and the sensor's");
                if !self.params.iter().any(|p| p.name == "CAL_MAG_COMP_TYP") {
                    let _ = writeln!(s, "# no current block: CAL_MAG0_*COMP and CAL_MAG_COMP_TYP are not written");
                }
                let _ = writeln!(s, "#\n# Vehicle-Id Component-Id Name Value Type");
            }
        }
        for w in &self.warnings {
            let _ = writeln!(s, "# WARNING: {}", w.message);
        }
        for p in &self.params {
            // f32 is what both stacks store; its shortest form round-trips.
            let v = if p.integer { format!("{}", p.value as i64) } else { format!("{}", p.value as f32) };
            match stack {
                Stack::ArduPilot => {
                    let _ = writeln!(s, "{},{}", p.name, v);
                }
                Stack::Px4 => {
                    // MAV_PARAM_TYPE_REAL32 = 9, MAV_PARAM_TYPE_INT32 = 6.
                    let _ = writeln!(s, "1\t1\t{}\t{}\t{}", p.name, v, if p.integer { 6 } else { 9 });
                }
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_core::cal::{FieldCal, ModelKind};

    #[test]
    fn polar_decomposition_rebuilds_the_matrix() {
        let a = [[1.02, 0.03, 0.0], [-0.01, 0.97, 0.02], [0.0, 0.0, 1.05]];
        let (r, p) = polar(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let rp: f64 = (0..3).map(|k| r[i][k] * p[k][j]).sum();
                assert!((rp - a[i][j]).abs() < 1e-12);
                assert_eq!(p[i][j], p[j][i]);
                let rrt: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
                assert!((rrt - if i == j { 1.0 } else { 0.0 }).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn units_are_inferred_or_refused() {
        assert_eq!(infer_raw_unit(&[[103.0, 0.0, 0.0], [0.0, 98.0, 0.0], [0.0, 0.0, 101.0]]).unwrap().0, "mGauss");
        assert_eq!(infer_raw_unit(&[[1.0e5, 0.0, 0.0], [0.0, 1.0e5, 0.0], [0.0, 0.0, 1.0e5]]).unwrap().0, "Gauss");
        // 150 nT per count: a raw sensor's counts, no unit.
        let e = infer_raw_unit(&[[150.0, 0.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 150.0]]).unwrap_err();
        assert!(matches!(e, ExportError::UnknownUnits { gain_nt_per_unit } if (gain_nt_per_unit - 150.0).abs() < 1e-9) && e.to_string().contains("raw units must be given"), "{e}");
        let doc = CalDoc::new(ModelKind::Sphere, &FieldCal { bias: [0.0; 3], matrix: [[150.0, 0.0, 0.0], [0.0, 150.0, 0.0], [0.0, 0.0, 150.0]] }, 50_000.0, Default::default());
        let opts = ExportOptions { stack: Stack::ArduPilot, raw_nt_per_unit: Some(-1.0), max_rotation_deg: 2.0 };
        assert!(matches!(export(&doc, &opts), Err(ExportError::BadUnit(_))));
        // Given as 100 nT (mGauss) the gain of 1.5 is at ArduPilot's edge; 2 is beyond.
        let doc2 = CalDoc { matrix: [[200.0, 0.0, 0.0], [0.0, 200.0, 0.0], [0.0, 0.0, 200.0]], ..doc };
        let opts = ExportOptions { raw_nt_per_unit: Some(100.0), ..opts };
        assert!(matches!(export(&doc2, &opts), Err(ExportError::Gain { .. })));
        // PX4 is held to the same range (it took XSCALE 2 before, 5.1 with
        // a wrong --raw-unit): its gain in gauss is the same 2.
        let e = export(&doc2, &ExportOptions { stack: Stack::Px4, ..opts }).unwrap_err();
        assert!(matches!(e, ExportError::Gain { scale, .. } if (scale - 2.0).abs() < 1e-12), "{e}");
        // Each stack's message names its own parameters (PX4's named
        // ArduPilot's COMPASS_SCALE).
        assert!(e.to_string().contains("CAL_MAG0_XSCALE") && !e.to_string().contains("COMPASS"), "{e}");
        let e = export(&doc2, &opts).unwrap_err().to_string();
        assert!(e.contains("COMPASS_SCALE") && !e.contains("CAL_MAG"), "{e}");
    }
}
