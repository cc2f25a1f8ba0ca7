//! `fit --model auto` (the default): every model the recording's columns
//! allow, each judged on held-out stretches of the same recording, the one
//! with the best held-out consistency kept.
//!
//! The recording is cut into [`FOLDS`] contiguous blocks of rows (time
//! blocks, so correlated neighbours do not leak from the fit into its
//! judge). Each candidate is fitted [`FOLDS`] times with one block's
//! readings blanked (rows kept, so the gyro fit's time windows stay whole)
//! and judged on that block only:
//!
//! * with a reference heading column (`ref_heading_deg`): the heading error
//!   against it, one constant offset removed (a declination or a mounting
//!   offset);
//! * otherwise, by the field against the reference: each held-out sample's
//!   dip against the reference inclination (the world model's at the site,
//!   else the fold's own fitted dip) and its horizontal intensity against
//!   `F cos I` (relative, in radians: a hard-iron or scale error moves the
//!   heading by about as much as it moves the horizontal intensity, over
//!   the headings visited); without roll and pitch, `|h|` against `F`.
//!
//! The held-out RMS (degrees) ranks the candidates and is the expected
//! heading error written into the document when it exceeds the one from the
//! covariance and the heading noise
//! ([`crate::doc::results::Quality::expected_heading_rms_deg`]). A model
//! whose full fit is refused keeps its reason in the table; when no
//! candidate's held-out error is below [`MAX_HELD_OUT_DEG`] the fit is
//! refused.

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::heading::{level, magnetic_heading_rad};
use rayon::prelude::*;

use super::error::ComputeError;
use super::fit::{fit_with, Checks, FitOptions};
use super::truth::heading_rms_after_offset_deg;
use crate::data::Recording;
use crate::doc::auto::{AutoChoice, CandidateRow, HeldOutBasis, MAX_HELD_OUT_DEG};
use crate::doc::CalDoc;

/// Contiguous blocks of the held-out judgement.
pub const FOLDS: usize = 5;

/// The models `auto` tries, in the order of its table: the registry's
/// candidates, richest first (the triangular form is the full model
/// re-expressed, so it is not tried apart).
pub fn candidates() -> impl Iterator<Item = ModelKind> {
    super::models::MODELS.iter().rev().filter(|e| e.auto_candidate).map(|e| e.kind)
}

fn basis_of(rec: &Recording) -> HeldOutBasis {
    if rec.ref_heading_deg.as_ref().is_some_and(|r| r.iter().any(|v| v.is_finite())) && rec.roll_deg.is_some() && rec.pitch_deg.is_some() {
        HeldOutBasis::ReferenceHeading
    } else if rec.roll_deg.is_some() && rec.pitch_deg.is_some() {
        HeldOutBasis::FieldAndDip
    } else {
        HeldOutBasis::Intensity
    }
}

/// Whether the recording's columns allow a model at all.
fn allowed(model: ModelKind, rec: &Recording) -> Result<(), String> {
    let missing = super::models::missing_columns(model, rec);
    if missing.is_empty() {
        Ok(())
    } else {
        Err(format!("needs {}", super::models::entry(model).needs.join(", ")))
    }
}

/// The recording with the readings of rows `lo..hi` blanked.
fn without_block(rec: &Recording, lo: usize, hi: usize) -> Recording {
    let mut r = rec.clone();
    for m in &mut r.mag[lo..hi] {
        *m = [f64::NAN; 3];
    }
    r
}

/// Per-row held-out errors (radians) of `cal` on rows `lo..hi`; `dip_deg`
/// the reference inclination, `field_nt` the intensity. For the reference
/// heading basis the raw heading differences are returned (the offset is
/// removed over all folds together).
fn held_out_errors(cal: &FieldCal<f64>, rec: &Recording, lo: usize, hi: usize, basis: HeldOutBasis, dip_deg: Option<f64>, field_nt: f64, out: &mut Vec<(f64, f64)>) {
    let at = |c: &Option<Vec<f64>>, i: usize| c.as_ref().and_then(|v| v.get(i).copied()).filter(|v| v.is_finite());
    for i in lo..hi {
        let raw = rec.mag[i];
        if !raw.iter().all(|v| v.is_finite()) {
            continue;
        }
        let h = cal.apply(raw);
        match basis {
            HeldOutBasis::ReferenceHeading => {
                if let (Some(r), Some(p), Some(reference)) = (at(&rec.roll_deg, i), at(&rec.pitch_deg, i), at(&rec.ref_heading_deg, i)) {
                    out.push((magnetic_heading_rad(h, r.to_radians(), p.to_radians()), reference));
                }
            }
            HeldOutBasis::FieldAndDip => {
                let (Some(r), Some(p), Some(dip)) = (at(&rec.roll_deg, i), at(&rec.pitch_deg, i), dip_deg) else { continue };
                let l = level(h, r.to_radians(), p.to_radians());
                let hh = l[0].hypot(l[1]);
                let e_dip = l[2].atan2(hh) - dip.to_radians();
                let e_h = hh / (field_nt * dip.to_radians().cos()) - 1.0;
                out.push((e_dip, e_h));
            }
            HeldOutBasis::Intensity => {
                let m = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
                out.push((m / field_nt - 1.0, 0.0));
            }
        }
    }
}

/// The held-out RMS of a candidate, degrees; why not, when a fold's fit is refused.
fn held_out_deg(model: ModelKind, rec: &Recording, opts: &FitOptions, basis: HeldOutBasis) -> Result<f64, String> {
    let n = rec.len();
    // The folds are independent: fitted side by side, their errors taken
    // in fold order (the first refused fold named, as one by one).
    let folds: Vec<Result<Vec<(f64, f64)>, String>> = (0..FOLDS)
        .into_par_iter()
        .map(|k| {
            let (lo, hi) = (k * n / FOLDS, (k + 1) * n / FOLDS);
            let train = without_block(rec, lo, hi);
            let fold_opts = FitOptions { model, allow_weak: true, ..opts.clone() };
            let doc = fit_with(&train, &fold_opts, Checks { attitude_units: false, magnitude_gate: false }).map_err(|e| format!("fold {} of {FOLDS}: {e}", k + 1))?;
            let dip = doc.reference.as_ref().and_then(|r| r.inclination_deg);
            let mut pairs = Vec::new();
            held_out_errors(&doc.field_cal(), rec, lo, hi, basis, dip, opts.field_nt, &mut pairs);
            Ok(pairs)
        })
        .collect();
    let mut pairs = Vec::new();
    for fold in folds {
        pairs.extend(fold?);
    }
    if pairs.is_empty() {
        return Err("no held-out sample could be judged".into());
    }
    if basis == HeldOutBasis::FieldAndDip && opts.reference.as_ref().is_some_and(|r| r.independent_inclination()) {
        super::dip_held::remove_common_offset(&mut pairs);
    }
    Ok(match basis {
        HeldOutBasis::ReferenceHeading => heading_rms_after_offset_deg(pairs.into_iter()).0.rms,
        // The dip's error and the horizontal intensity's (the part of a
        // calibration error that turns the heading) in quadrature.
        HeldOutBasis::FieldAndDip => trimmed_rms(pairs.iter().map(|(d, h)| d * d + h * h).collect()).to_degrees(),
        HeldOutBasis::Intensity => trimmed_rms(pairs.iter().map(|(m, _)| m * m).collect()).to_degrees(),
    })
}

/// The share of the largest squared errors left out of the field's
/// held-out RMS: samples whose attitude is a glitch (a real glider's roll
/// sample at −122°, the surface's wave motion) say nothing of the
/// calibration, and one of them outweighs a thousand good ones.
pub const TRIM_FRACTION: f64 = 0.05;

/// RMS of the smallest `1 − TRIM_FRACTION` of squared errors.
fn trimmed_rms(mut squares: Vec<f64>) -> f64 {
    squares.sort_by(f64::total_cmp);
    let keep = ((squares.len() as f64 * (1.0 - TRIM_FRACTION)).ceil() as usize).clamp(1, squares.len());
    (squares[..keep].iter().sum::<f64>() / keep as f64).sqrt()
}

/// Fits every candidate, judges each on held-out blocks, keeps the best.
/// `opts.model` is ignored. The kept document's expected heading error is
/// the larger of its own and its held-out error.
pub fn fit_auto(rec: &Recording, opts: &FitOptions) -> Result<(CalDoc, AutoChoice), ComputeError> {
    let basis = basis_of(rec);
    // Roll and pitch in radians refuse every levelling candidate: checked
    // once here, not in each candidate's and fold's fit.
    let units = crate::data::intake::check_attitude_units(rec, opts.field_nt).map_err(|e| e.to_string());
    let mut rows = Vec::new();
    let mut best: Option<(f64, CalDoc)> = None;
    // Each levelled model also with the dip held at the world model's.
    for (model, opts) in super::dip_held::with_held(candidates(), opts) {
        let opts = &opts;
        let mut row = CandidateRow { model: super::dip_held::row_name(model, opts), held_out_deg: None, predicted_deg: None, refused: None, note: None };
        let levelling = super::models::entry(model).levelled;
        if let Err(why) = allowed(model, rec).and(if levelling { units.clone() } else { Ok(()) }) {
            row.refused = Some(why);
            rows.push(row);
            continue;
        }
        // The full fit and the held-out folds side by side (the folds'
        // judgement is only read when the full fit is accepted).
        let (full, held_out) = rayon::join(|| fit_candidate(rec, model, opts), || held_out_deg(model, rec, opts, basis));
        match full {
            Err(e) => row.refused = Some(e.to_string()),
            Ok((doc, note)) => {
                row.note = note;
                row.predicted_deg = doc.quality.predicted_heading_rms_deg;
                match held_out {
                    Err(why) => row.refused = Some(format!("not judged on held-out data: {why}")),
                    Ok(h) => {
                        row.held_out_deg = Some(h);
                        if best.as_ref().is_none_or(|(b, _)| h < *b) {
                            best = Some((h, doc));
                        }
                    }
                }
            }
        }
        rows.push(row);
    }
    let Some((held_out, mut doc)) = best else {
        return Err(ComputeError::NoModel { limit_deg: MAX_HELD_OUT_DEG, table: table_text(&rows) });
    };
    if !(held_out <= MAX_HELD_OUT_DEG) && !opts.allow_weak {
        return Err(ComputeError::NoModel { limit_deg: MAX_HELD_OUT_DEG, table: table_text(&rows) });
    }
    let expected = doc.quality.expected_heading_rms_deg.map_or(held_out, |p| p.max(held_out));
    doc.quality.expected_heading_rms_deg = Some(expected);
    let choice = AutoChoice { chosen: super::dip_held::chosen_name(&doc), basis, candidates: rows };
    doc.quality.auto = Some(choice.clone());
    Ok((doc, choice))
}

/// One candidate's fit on the whole recording. The models that do not rest
/// on the field's magnitude (gyro-aided, attitude-aided) are not refused
/// for their in-sample magnitude scatter: a real room's or hull's field
/// varies along the path more than the 2 % gate allows, and their held-out
/// error is the judge here (the fit says so in its warnings and the row's
/// note). Every other refusal stands (coverage, the world model's
/// disagreement, unusable coefficients); the attitude columns' units were
/// checked once for all ([`fit_auto`]).
fn fit_candidate(rec: &Recording, model: ModelKind, opts: &FitOptions) -> Result<(CalDoc, Option<String>), ComputeError> {
    let magnitude_gate = !super::models::entry(model).levelled;
    let doc = fit_with(rec, &FitOptions { model, ..opts.clone() }, Checks { attitude_units: false, magnitude_gate })?;
    let note = doc.quality.fit.as_ref().and_then(|f| f.warnings.iter().find(|w| w.contains("judged on held-out data instead")).cloned());
    Ok((doc, note))
}

/// The candidates' table in words, one line each.
pub fn table_text(rows: &[CandidateRow]) -> String {
    rows.iter()
        .map(|r| match (&r.refused, r.held_out_deg) {
            (Some(why), _) => format!("{}: {why}", r.model),
            (None, Some(h)) => format!("{}: held-out {h:.2}°", r.model),
            (None, None) => format!("{}: not judged", r.model),
        })
        .collect::<Vec<_>>()
        .join("; ")
}
