//! `fit --model auto`'s dip-held candidates: each levelled model whose fit
//! takes the world model's inclination is tried a second time with the dip
//! held at it, and judged on held-out data like every other candidate.
//!
//! Where a recording cannot tell the dip from the vertical scale (a glider's
//! few dives at one pitch), the free dip absorbs what the data cannot
//! separate and the fit lands degrees off; held at the world model's, the
//! same data fit the rest. Which one generalises is the held-out judge's
//! call, not an assumption. Only with an independent inclination (a site):
//! without one there is nothing to hold the dip at.
//!
//! A held candidate whose data alone put the dip far from the held value
//! (beyond three of their σ, their scatter and, for the attitude-aided fit,
//! the tilt sensor's errors counted) is refused before it is judged: a
//! room's real dip or a wrong site, where holding it would head worse
//! while the held-out judge might still prefer it. A recording whose tilt
//! varies no more than its sensor's noise cannot tell the dip and
//! contradicts nothing (the fit's `contradicted_by_data`).

use calib_core::cal::ModelKind;

use super::fit::FitOptions;
use crate::doc::reference::{DipConstraint, Reference};

/// What the held candidates' rows add to the model's name in `auto`'s table.
pub const HELD_LABEL: &str = " (dip held at the world model's)";

/// Whether a model's fit takes the reference's inclination as a
/// measurement (and so can hold it): the attitude-aided and the
/// gyro-aided fits.
pub fn takes_dip(model: ModelKind) -> bool {
    matches!(model, ModelKind::Attitude | ModelKind::Gyro)
}

/// The options with the dip held at the reference's inclination, when the
/// model can hold it and the reference has an independent inclination.
pub fn held(model: ModelKind, opts: &FitOptions) -> Option<FitOptions> {
    let reference = opts.reference.as_ref().filter(|r| r.independent_inclination())?;
    takes_dip(model).then(|| FitOptions { reference: Some(Reference { constraint: Some(DipConstraint::held()), ..reference.clone() }), ..opts.clone() })
}

/// Every candidate `auto` tries, in its table's order: each model as it
/// is, then held at the world model's dip where it can be and the
/// recording's columns allow the model (`allowed`: a row that only repeats
/// the free row's "needs …" says nothing).
pub fn with_held(models: impl Iterator<Item = ModelKind>, opts: &FitOptions, allowed: impl Fn(ModelKind) -> bool) -> Vec<(ModelKind, FitOptions)> {
    models.flat_map(|m| std::iter::once((m, opts.clone())).chain(held(m, opts).filter(|_| allowed(m)).map(|o| (m, o)))).collect()
}

/// Whether a candidate's options hold the dip at the reference's.
pub fn is_held(opts: &FitOptions) -> bool {
    opts.reference.as_ref().is_some_and(|r| r.dip_held())
}

/// The row name of a candidate: the model's, marked when its dip is held.
pub fn row_name(model: ModelKind, opts: &FitOptions) -> String {
    let held = is_held(opts);
    format!("{}{}", model.name(), if held { HELD_LABEL } else { "" })
}

/// The name `auto` writes for the kept document: its model's, marked when
/// its dip was held.
pub fn chosen_name(doc: &crate::doc::CalDoc) -> String {
    let held = doc.reference.as_ref().is_some_and(|r| r.dip_held());
    format!("{}{}", doc.model.name(), if held { HELD_LABEL } else { "" })
}

/// The held-out dip and horizontal-intensity errors against the world
/// model with their common offsets removed (each error's mean over every
/// held-out sample): what is left is how consistent the calibrated field
/// is, the same measure for a candidate whose dip is free and one whose
/// dip is held. Against the world model itself, a free fit that finds a
/// room's true dip 1.6° from IGRF's would be charged 1.6° of dip and, at
/// 68°, 7 % of horizontal intensity for being right, and the held one
/// would win by construction; whether the dip agrees with the world model
/// is the reference check's to say.
pub fn remove_common_offset(pairs: &mut [(f64, f64)]) {
    let n = pairs.len().max(1) as f64;
    let (md, mh) = pairs.iter().fold((0.0, 0.0), |(a, b), (d, h)| (a + d / n, b + h / n));
    for (d, h) in pairs.iter_mut() {
        *d -= md;
        *h -= mh;
    }
}
