//! The host's model registry: every field-calibration model with its help,
//! the recording columns it needs beyond `mx, my, mz`, whether `fit --model
//! auto` tries it, how it is judged and how much of the sphere of field
//! directions it needs (its coverage gate). The command line, `fit --model
//! auto`, the document reader (through [`ModelKind::from_name`]) and the
//! bench iterate this list; a new model is one entry here plus its fit.
//! (The board's own models are the wire's `OnboardModel`, apart.)

use calib_core::cal::ModelKind;
use calib_core::quality::Gates;

use crate::data::table::col;
use crate::data::Recording;

/// One model as the tools know it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModelEntry {
    /// The model.
    pub kind: ModelKind,
    /// One line for `--help`.
    pub help: &'static str,
    /// Columns it needs beyond `mx, my, mz`.
    pub needs: &'static [&'static str],
    /// Tried by `fit --model auto`.
    pub auto_candidate: bool,
    /// Fitted from the levelled field (roll and pitch or the gyro), so its
    /// in-sample magnitudes are not its judge and its attitude columns must
    /// be degrees.
    pub levelled: bool,
    /// Least percentage of the direction bins its data must visit. The
    /// more parameters, the more of the sphere they need: a full
    /// ellipsoid (9 parameters) from a cap of directions is an
    /// extrapolation; the axis model is what paper 000 fits from an AUV's
    /// swing test (yaw all round, roll ±55°, pitch ±10°). A sphere's
    /// centre from a cap is an extrapolation too: on BROAD trial 05 (19 %
    /// of the bins, |roll|, |pitch| ≤ 25°) it gave 7.5° of heading error
    /// where the true calibration gives 2.2°. A levelled model does not
    /// rest on coverage (0): its own covariance says what the data
    /// determine.
    pub min_coverage_pct: u8,
}

/// Every model, in the order the tools list them ([`ModelKind::ALL`]).
pub const MODELS: [ModelEntry; 6] = [
    ModelEntry { kind: ModelKind::Sphere, help: "Bias and one scale", needs: &[], auto_candidate: true, levelled: false, min_coverage_pct: 30 },
    ModelEntry { kind: ModelKind::Axis, help: "Bias and three axis scales (paper 000, eqs 12–17)", needs: &[], auto_candidate: true, levelled: false, min_coverage_pct: 25 },
    ModelEntry { kind: ModelKind::Full, help: "Bias and a symmetric soft-iron matrix", needs: &[], auto_candidate: true, levelled: false, min_coverage_pct: 40 },
    ModelEntry { kind: ModelKind::Triangular, help: "Bias and paper 001's upper-triangular non-orthogonality and gains", needs: &[], auto_candidate: false, levelled: false, min_coverage_pct: 40 },
    ModelEntry {
        kind: ModelKind::Gyro,
        help: "Gyro-aided: bias and symmetric soft iron from how the readings rotate (needs t, gx, gy, gz; roll_deg, pitch_deg help) — for vehicles that cannot tumble",
        needs: &[col::T, col::GYRO[0], col::GYRO[1], col::GYRO[2]],
        auto_candidate: true,
        levelled: true,
        min_coverage_pct: 0,
    },
    ModelEntry {
        kind: ModelKind::Attitude,
        help: "Attitude-aided: bias and soft-iron matrix from the levelled field's constant vertical and horizontal parts (needs roll_deg, pitch_deg; no gyro) — for gliders, AUVs and boats that cannot tumble",
        needs: &[col::ROLL_DEG, col::PITCH_DEG],
        auto_candidate: true,
        levelled: true,
        min_coverage_pct: 0,
    },
];

/// The entry of a model.
pub fn entry(kind: ModelKind) -> &'static ModelEntry {
    // Every kind has an entry (the test below); the first is a safe fallback.
    MODELS.iter().find(|e| e.kind == kind).unwrap_or(&MODELS[0])
}

/// The quality gates a fit of `kind` must pass: its entry's coverage and
/// calib-core's residual limit.
pub fn gates(kind: ModelKind) -> Gates<f64> {
    Gates::with_coverage(entry(kind).min_coverage_pct)
}

/// The columns of `entry.needs` the recording lacks.
pub fn missing_columns(kind: ModelKind, rec: &Recording) -> Vec<&'static str> {
    entry(kind)
        .needs
        .iter()
        .copied()
        .filter(|c| match *c {
            col::T => rec.t_s.is_none(),
            col::ROLL_DEG => rec.roll_deg.is_none(),
            col::PITCH_DEG => rec.pitch_deg.is_none(),
            _ => rec.gyro_rad_s().is_none(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_model_has_one_entry_in_calib_cores_order() {
        let kinds: Vec<ModelKind> = MODELS.iter().map(|e| e.kind).collect();
        assert_eq!(kinds, ModelKind::ALL.to_vec());
        for k in ModelKind::ALL {
            assert_eq!(ModelKind::from_name(k.name()), Some(k));
            assert_eq!(entry(k).kind, k);
        }
        assert_eq!(ModelKind::from_name("ellipsoid"), None);
    }

    /// Exactly the levelled models (judged by their levelled field, not by
    /// how much of the sphere they saw) do not rest on coverage, and the
    /// gates a fit is held to are its entry's.
    #[test]
    fn the_coverage_gates_follow_the_registrys_levelled_flag() {
        for e in &MODELS {
            assert_eq!(e.min_coverage_pct == 0, e.levelled, "{}: gate {} %", e.kind.name(), e.min_coverage_pct);
            assert_eq!(gates(e.kind), Gates { min_coverage_pct: e.min_coverage_pct, max_residual_pct: 2.0 });
        }
    }

    #[test]
    fn a_recording_without_the_gyro_lacks_what_the_gyro_model_needs() {
        let rec = Recording { mag: vec![[1.0, 2.0, 3.0]], roll_deg: Some(vec![0.0]), pitch_deg: Some(vec![0.0]), ..Recording::default() };
        assert_eq!(missing_columns(ModelKind::Gyro, &rec), vec!["t", "gx", "gy", "gz"]);
        assert!(missing_columns(ModelKind::Attitude, &rec).is_empty());
        assert!(missing_columns(ModelKind::Full, &Recording::default()).is_empty());
    }

    /// `fit --model auto`'s table lists the richest models first, and not
    /// the triangular form (the full model re-expressed).
    #[test]
    fn auto_tries_the_richest_models_first() {
        let order: Vec<ModelKind> = crate::compute::auto::candidates().collect();
        assert_eq!(order, [ModelKind::Attitude, ModelKind::Gyro, ModelKind::Full, ModelKind::Axis, ModelKind::Sphere]);
    }
}
