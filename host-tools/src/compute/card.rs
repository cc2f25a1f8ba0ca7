//! The compass deviation card (`magcal card`): the residual heading error
//! (reference heading minus the magnetometer's heading) by heading, before
//! (the raw field, no calibration) and after (the calibration document's
//! heading: field, tilt, swing, declination), per sector of the reference
//! heading and per compass point.
//!
//! The heading with and without the calibration is calib-core's
//! [`Calibration::apply`] (the after column is [`super::truth::true_headings_rad`]);
//! the before column applies no field calibration and no swing, only the
//! document's declination, so both compare with the same true reference.
//! Rows are binned by the reference heading: a cell centred on ψ holds the
//! rows whose reference lies within ±step/2 of ψ. Each cell's mean is the
//! circular mean of its errors, its RMS that of the wrapped errors; a cell
//! with no rows is empty (`None`), not zero.

use std::path::Path;

use calib_core::cal::Calibration;
use calib_core::heading::wrap_pi;
use serde::{Deserialize, Serialize};

use super::truth::true_headings_rad;
use super::units::check_units;
use super::error::ComputeError;
use crate::data::table::{column_spec, read_column, write_cells, Cell as TableCell, Quantity, TableError};
use crate::data::compass::CompassLog;
use crate::doc::compass::CompassDoc;
use crate::data::Recording;
use crate::doc::CalDoc;
use super::compass::compass_pairs;

/// The 16 compass points from north, clockwise.
pub const POINTS_16: [&str; 16] = ["N", "NNE", "NE", "ENE", "E", "ESE", "SE", "SSE", "S", "SSW", "SW", "WSW", "W", "WNW", "NW", "NNW"];

/// The sector widths a card takes, degrees: at least 0.1° (3 600 sectors,
/// the most a card allocates whatever it is given), at most 180°.
pub const STEP_DEG_RANGE: std::ops::RangeInclusive<f64> = 0.1..=180.0;

/// Why a card could not be made.
#[derive(Debug, thiserror::Error)]
pub enum CardError {
    /// The output could not be written ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
    /// The recording has no reference heading to compare with.
    #[error("the recording has no `{0}` column: the deviation card compares the magnetometer's heading with a reference (or truth) heading, so the recording needs one (`ref_heading_deg`, or name another column)")]
    NoReferenceColumn(String),
    /// The reference column could not be read (a cell not a number, a
    /// ragged row, malformed CSV).
    #[error(transparent)]
    Table(#[from] TableError),
    /// The reference column is empty everywhere.
    #[error("no row has both a reference heading (`ref_heading_deg`) and the heading (the magnetometer with roll and pitch, or a compass heading at its time): nothing to put on the card")]
    NoUsableRows,
    /// The sector width does not divide the circle or is outside
    /// [`STEP_DEG_RANGE`].
    #[error("sectors of {0}° must divide 360° into whole sectors and be 0.1° to 180° wide (e.g. 5, 10, 15, 22.5, 30, 45)")]
    BadStep(f64),
    /// The reference column is one of the project's columns that is not a
    /// heading (`mx` holds the field in counts or nT).
    #[error("column `{column}` is {what}, not a heading: the card's reference must be a heading or course column (e.g. ref_heading_deg, true_heading_deg, compass_heading_deg, course_deg)")]
    NotAHeading {
        /// The column named.
        column: String,
        /// What it holds.
        what: &'static str,
    },
    /// The number of compass points is not 8 or 16.
    #[error("compass points must be 8 or 16, not {0}")]
    BadPoints(usize),
    /// The recording does not fit the calibration or lacks a column.
    #[error("{0}")]
    Compute(#[from] ComputeError),
}

/// The errors of one cell, degrees.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Cell {
    /// Rows behind the cell.
    pub samples: usize,
    /// Circular mean of reference − heading, degrees (`None` when empty).
    pub mean_deg: Option<f64>,
    /// RMS of the wrapped reference − heading, degrees (`None` when empty).
    pub rms_deg: Option<f64>,
}

/// One line of the card: a sector of reference heading.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CardRow {
    /// `15°` or a compass point (`NNE`).
    pub label: String,
    /// Centre of the sector, degrees from north.
    pub centre_deg: f64,
    /// Width of the sector, degrees (centre ± half of it).
    pub width_deg: f64,
    /// Without the calibration.
    pub before: Cell,
    /// With the calibration.
    pub after: Cell,
}

/// The deviation card: what `magcal card --json` prints.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeviationCard {
    /// The column the headings are compared with (`ref_heading_deg`: the
    /// navigation's heading or GPS course; `true_heading_deg`: the truth).
    #[serde(default = "default_reference")]
    pub reference: String,
    /// Rows used (reference, magnetometer, roll and pitch all present).
    pub samples: usize,
    /// Rows left out for a missing value.
    pub skipped_rows: usize,
    /// The declination added to both headings, degrees (the document's, 0 without).
    pub declination_deg: f64,
    /// Everything, before.
    pub before: Cell,
    /// Everything, after.
    pub after: Cell,
    /// By sector of `step_deg`.
    pub by_heading: Vec<CardRow>,
    /// By compass point.
    pub by_point: Vec<CardRow>,
}

fn default_reference() -> String {
    "ref_heading_deg".to_string()
}

/// Whether a column's name says it holds the true heading (`true_heading_deg`,
/// `TRUE_HEADING`, `truth`: any case).
pub fn is_truth_column(column: &str) -> bool {
    let c = column.to_ascii_lowercase();
    c.contains("true") || c.contains("truth")
}

/// What the card's numbers measure, said beside them: against a truth column
/// the calibration's own error; against `ref_heading_deg` (GPS course over
/// ground or the navigation's heading) also the reference's own errors.
pub fn reference_note(column: &str) -> &'static str {
    if is_truth_column(column) {
        "the true heading: the calibration's own error"
    } else {
        "a reference heading, not the truth: a GPS course over ground also holds the water current's crab angle and the GPS delay, so these are not the calibration's error alone"
    }
}

#[derive(Default, Clone, Copy)]
struct Acc {
    n: usize,
    sin: f64,
    cos: f64,
    sq: f64,
}

impl Acc {
    fn add(&mut self, e: f64) {
        self.n += 1;
        self.sin += e.sin();
        self.cos += e.cos();
        self.sq += e * e;
    }
    fn cell(&self) -> Cell {
        if self.n == 0 {
            return Cell::default();
        }
        Cell { samples: self.n, mean_deg: Some(self.sin.atan2(self.cos).to_degrees()), rms_deg: Some((self.sq / self.n as f64).sqrt().to_degrees()) }
    }
}

/// The sector of a heading among `count` sectors centred on multiples of `360/count`.
fn sector(heading_deg: f64, count: usize) -> usize {
    let width = 360.0 / count as f64;
    (((heading_deg + width / 2.0).rem_euclid(360.0) / width) as usize).min(count - 1)
}

fn rows_of(count: usize, label: impl Fn(usize) -> String, before: &[Acc], after: &[Acc]) -> Vec<CardRow> {
    let width = 360.0 / count as f64;
    (0..count).map(|i| CardRow { label: label(i), centre_deg: i as f64 * width, width_deg: width, before: before[i].cell(), after: after[i].cell() }).collect()
}

/// Makes the card for a recording and a calibration. `step_deg` must divide
/// 360; `points` is 16 or 8.
pub fn deviation_card(rec: &Recording, doc: &CalDoc, step_deg: f64, points: usize) -> Result<DeviationCard, CardError> {
    let sectors = check_layout(step_deg, points)?;
    let reference = rec.ref_heading_deg.as_ref().ok_or_else(|| CardError::NoReferenceColumn("ref_heading_deg".into()))?;
    let roll = rec.roll_deg.as_ref().ok_or(ComputeError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(ComputeError::NeedsColumn("pitch_deg"))?;
    check_units(rec, doc)?;
    if let Some(column) = doc.needed_columns().into_iter().find(|c| match *c {
        "motor_current_a" => rec.motor_current_a.is_none(),
        _ => rec.temp_c.is_none(),
    }) {
        return Err(CardError::Compute(ComputeError::NeedsColumn(column)));
    }
    let after = true_headings_rad(doc, rec);
    let declination_deg = doc.declination_deg.unwrap_or(0.0);
    let raw = Calibration { declination_rad: declination_deg.to_radians(), ..Calibration::identity() };
    let rows = (0..rec.len()).map(|i| (reference[i], raw.apply(rec.mag[i], roll[i].to_radians(), pitch[i].to_radians()).true_heading_rad, after[i]));
    card_from_rows(rows, 0, declination_deg, sectors, points)
}

/// The checked number of sectors for `step_deg`, and `points`.
fn check_layout(step_deg: f64, points: usize) -> Result<usize, CardError> {
    let sectors = 360.0 / step_deg;
    // The range first: it bounds the sectors (and their allocation) to 3 600.
    if !(STEP_DEG_RANGE.contains(&step_deg) && (sectors - sectors.round()).abs() < 1e-9) {
        return Err(CardError::BadStep(step_deg));
    }
    if points != 16 && points != 8 {
        return Err(CardError::BadPoints(points));
    }
    Ok(sectors.round() as usize)
}

/// Makes the card for a heading-only compass's log and its document: each
/// reference sample against the compass heading at its time (less the
/// document's delay), before (the compass plus the declination) and after
/// the swing.
pub fn compass_card(log: &CompassLog, doc: &CompassDoc, step_deg: f64, points: usize) -> Result<DeviationCard, CardError> {
    let sectors = check_layout(step_deg, points)?;
    let (pairs, missing) = compass_pairs(log, doc)?;
    let rows = pairs.iter().map(|p| (p.reference_deg, p.before_rad, p.after_rad));
    card_from_rows(rows, missing, doc.declination_deg.unwrap_or(0.0), sectors, points)
}

/// The card from (reference °, heading before, heading after, rad) rows;
/// rows with a value missing are counted as skipped, beside `skipped`.
fn card_from_rows(rows: impl Iterator<Item = (f64, f64, f64)>, mut skipped: usize, declination_deg: f64, sectors: usize, points: usize) -> Result<DeviationCard, CardError> {
    let (mut hb, mut ha, mut pb, mut pa) = (vec![Acc::default(); sectors], vec![Acc::default(); sectors], vec![Acc::default(); points], vec![Acc::default(); points]);
    let (mut all_b, mut all_a) = (Acc::default(), Acc::default());
    for (r, before, after) in rows {
        let (eb, ea) = (wrap_pi(r.to_radians() - before), wrap_pi(r.to_radians() - after));
        if !(eb.is_finite() && ea.is_finite()) {
            skipped += 1;
            continue;
        }
        let (s, p) = (sector(r, sectors), sector(r, points));
        hb[s].add(eb);
        ha[s].add(ea);
        pb[p].add(eb);
        pa[p].add(ea);
        all_b.add(eb);
        all_a.add(ea);
    }
    if all_b.n == 0 {
        return Err(CardError::NoUsableRows);
    }
    let stride = 16 / points;
    let step_deg = 360.0 / sectors as f64;
    Ok(DeviationCard {
        reference: default_reference(),
        samples: all_b.n,
        skipped_rows: skipped,
        declination_deg,
        before: all_b.cell(),
        after: all_a.cell(),
        by_heading: rows_of(sectors, |i| format!("{}°", fmt_deg(i as f64 * step_deg)), &hb, &ha),
        by_point: rows_of(points, |i| POINTS_16[i * stride].to_string(), &pb, &pa),
    })
}

/// One named column of a recording's CSV as the heading reference (a
/// simulator's `true_heading_deg`, a lab's optical heading): the recording
/// reader's rules ([`crate::data::table`]), an empty cell or `nan` is "not available". `Ok(None)`
/// when the header has no such column. One of the project's columns that
/// is not a heading (`mx`, `roll_deg`, `t`) is refused, naming what it holds;
/// a column the project does not know (a lab's `optical_heading`) is taken.
pub fn read_reference_column(path: &Path, column: &str) -> Result<Option<Vec<f64>>, CardError> {
    check_reference_column(column)?;
    Ok(read_column(path, column)?)
}

/// Refuses a reference column that the column registry knows as something
/// other than a heading ([`Quantity::Heading`]).
pub fn check_reference_column(column: &str) -> Result<(), CardError> {
    let what = match column_spec(column).map(|c| c.quantity) {
        None | Some(Quantity::Heading) => return Ok(()),
        Some(Quantity::Field) => "the magnetic field (nT, µT, gauss or counts)",
        Some(Quantity::Angle) => "an attitude or position angle",
        Some(Quantity::Rate) => "a body rate",
        Some(Quantity::Time) => "a time",
        Some(Quantity::Other) => "a quantity that is not an angle",
    };
    Err(CardError::NotAHeading { column: column.into(), what })
}

fn fmt_deg(v: f64) -> String {
    if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

/// One cell's columns of the text card: samples, mean and RMS (the count
/// blank when zero and `blank_empty`).
fn text_cells(c: &Cell, blank_empty: bool) -> String {
    let samples = if blank_empty && c.samples == 0 { String::new() } else { c.samples.to_string() };
    format!("{samples:>6} {:>8} {:>8}", opt(c.mean_deg, 2), opt(c.rms_deg, 2))
}

fn opt(v: Option<f64>, prec: usize) -> String {
    v.map(|v| format!("{v:.prec$}")).unwrap_or_default()
}

impl DeviationCard {
    /// The card as a text table (heading sectors, then compass points);
    /// empty cells are blank.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        s.push_str(&format!(
            "deviation card: reference − heading (before: uncorrected, after: calibrated), degrees; {} rows ({} skipped); declination {:.2}°\nreference: `{}`, {}\n",
            self.samples, self.skipped_rows, self.declination_deg, self.reference, reference_note(&self.reference)
        ));
        for (title, rows) in [("heading", &self.by_heading), ("point", &self.by_point)] {
            s.push_str(&format!("\n{title:>8} | {:>6} {:>8} {:>8} | {:>6} {:>8} {:>8}\n", "n", "before", "rms", "n", "after", "rms"));
            for r in rows.iter() {
                s.push_str(&format!("{:>8} | {} | {}\n", r.label, text_cells(&r.before, true), text_cells(&r.after, true)));
            }
        }
        s.push_str(&format!("\n     all | {} | {}\n", text_cells(&self.before, false), text_cells(&self.after, false)));
        s
    }

    /// Writes the card as CSV: `table,label,centre_deg,width_deg,before_n,
    /// before_mean_deg,before_rms_deg,after_n,after_mean_deg,after_rms_deg`
    /// (`table` is `heading` or `point`; empty cells are empty strings).
    pub fn write_csv(&self, path: &Path) -> Result<(), CardError> {
        let header = ["table", "label", "centre_deg", "width_deg", "before_n", "before_mean_deg", "before_rms_deg", "after_n", "after_mean_deg", "after_rms_deg"];
        write_cells(path, &header, |w| {
            for (table, rows) in [("heading", &self.by_heading), ("point", &self.by_point)] {
                for r in rows.iter() {
                    let cell = |c: &Cell| [TableCell::Count(c.samples as u64), TableCell::opt_fixed(c.mean_deg, 4), TableCell::opt_fixed(c.rms_deg, 4)];
                    let mut cells = vec![TableCell::Text(table), TableCell::Text(&r.label), TableCell::Number(r.centre_deg), TableCell::Number(r.width_deg)];
                    cells.extend(cell(&r.before));
                    cells.extend(cell(&r.after));
                    w.row(&cells)?;
                }
            }
            Ok(())
        })?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_core::cal::{FieldCal, ModelKind};

    fn level_recording(headings_deg: &[f64], bias_nt: [f64; 3]) -> Recording {
        // Level vehicle, horizontal field 20 000 nT north, 40 000 nT down.
        let mag = headings_deg.iter().map(|h| {
            let r = h.to_radians();
            [20_000.0 * r.cos() + bias_nt[0], -20_000.0 * r.sin() + bias_nt[1], 40_000.0 + bias_nt[2]]
        });
        Recording {
            mag: mag.collect(),
            roll_deg: Some(vec![0.0; headings_deg.len()]),
            pitch_deg: Some(vec![0.0; headings_deg.len()]),
            ref_heading_deg: Some(headings_deg.to_vec()),
            ..Recording::default()
        }
    }

    fn identity_doc() -> CalDoc {
        CalDoc::new(ModelKind::Sphere, &FieldCal::identity(), 44_721.0, Default::default())
    }

    #[test]
    fn cells_are_binned_by_reference_and_empty_ones_stay_empty() {
        // Headings only in the northern half; 1000 nT of east bias.
        let h: Vec<f64> = (0..180).map(|i| (i as f64 - 90.0).rem_euclid(360.0)).collect();
        let card = deviation_card(&level_recording(&h, [0.0, 1000.0, 0.0]), &identity_doc(), 15.0, 16).unwrap();
        assert_eq!(card.by_heading.len(), 24);
        assert_eq!(card.by_point.len(), 16);
        // 0° holds 352.5 … 7.5: headings 353…359, 0…7 = 15 rows.
        assert_eq!(card.by_heading[0].before.samples, 15);
        // 180° is never visited: empty, not zero.
        assert_eq!(card.by_heading[12].before, Cell { samples: 0, mean_deg: None, rms_deg: None });
        assert!(card.to_text().lines().any(|l| l.trim_start().starts_with("180° |") && !l.contains("0.00")));
        // By physics: east bias b in a field H turns the compass towards east
        // at north: heading atan2(H sin ψ − b, H cos ψ) at ψ = 0 is −atan(b/H),
        // so reference − heading = +atan(1000/20000) = 2.862°; the N cell
        // averages that physics over its headings −11…11°.
        let physics = |psi: f64| psi - (20_000.0 * psi.sin() - 1000.0).atan2(20_000.0 * psi.cos());
        let expected = (-11..=11).map(|d| physics((d as f64).to_radians())).sum::<f64>().to_degrees() / 23.0;
        assert!((expected - 2.844).abs() < 0.001, "{expected}");
        let n = card.by_point[0].before.mean_deg.unwrap();
        assert!((n - expected).abs() < 1e-6, "{n} vs {expected}");
        assert_eq!(card.by_point[0].label, "N");
        assert_eq!(deviation_card(&level_recording(&h, [0.0; 3]), &identity_doc(), 15.0, 8).unwrap().by_point[1].label, "NE");
        // The card names its reference and says what a GPS course holds
        // (errors against GPS course were once printed as the calibration's).
        let mut card = deviation_card(&level_recording(&h, [0.0; 3]), &identity_doc(), 15.0, 16).unwrap();
        let text = card.to_text();
        assert!(text.contains("reference: `ref_heading_deg`, a reference heading, not the truth") && text.contains("crab angle"), "{text}");
        card.reference = "true_heading_deg".into();
        assert!(card.to_text().contains("the calibration's own error"));
    }

    #[test]
    fn refusals() {
        let h = [0.0, 90.0];
        let mut rec = level_recording(&h, [0.0; 3]);
        let doc = identity_doc();
        assert!(matches!(deviation_card(&rec, &doc, 7.0, 16), Err(CardError::BadStep(_))));
        // 1e-300° divides 360 (3.6e302 sectors, a whole number in f64):
        // refused, not allocated (a capacity overflow once); 0.05°
        // (7 200 sectors) is below the range.
        for step in [1e-300, 1e-7, 0.05, 360.0, f64::NAN] {
            assert!(matches!(deviation_card(&rec, &doc, step, 16), Err(CardError::BadStep(_))), "{step}");
        }
        assert_eq!(deviation_card(&level_recording(&h, [0.0; 3]), &doc, 0.1, 16).unwrap().by_heading.len(), 3600);
        // A registry column that is not a heading is no reference.
        for (column, what) in [("mx", "magnetic field"), ("roll_deg", "attitude"), ("t", "time"), ("temp_c", "not an angle")] {
            let e = check_reference_column(column).unwrap_err();
            assert!(e.to_string().starts_with(&format!("column `{column}` is")) && e.to_string().contains(what), "{e}");
        }
        for column in ["ref_heading_deg", "true_heading_deg", "course_deg", "optical_heading"] {
            check_reference_column(column).unwrap();
        }
        assert!(matches!(deviation_card(&rec, &doc, 15.0, 4), Err(CardError::BadPoints(4))));
        rec.ref_heading_deg = Some(vec![f64::NAN; 2]);
        assert!(matches!(deviation_card(&rec, &doc, 15.0, 16), Err(CardError::NoUsableRows)));
        rec.ref_heading_deg = None;
        let e = deviation_card(&rec, &doc, 15.0, 16).unwrap_err();
        assert!(matches!(e, CardError::NoReferenceColumn(_)) && e.to_string().contains("ref_heading_deg"), "{e}");
    }
}
