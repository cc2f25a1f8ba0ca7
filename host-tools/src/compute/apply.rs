//! `magcal apply` (`docs/INTERFACES.md`): a calibration document applied to
//! any recording row by row, with the heading's integrity, by the board's
//! own per-sample code (calib-core's [`OnlineIntegrity`]: the stored
//! calibration, the integrity monitor, the on-line hard iron and its guard),
//! so a mission's log is post-processed exactly as the board would have
//! judged it.

use std::collections::BTreeMap;
use std::path::Path;

use calib_core::cal::Environment;
use calib_core::hardiron::HardIron;
use calib_core::heading::{wrap_pi, Tilt};
use calib_core::integrity::{decide, Evidence, IntegrityError, IntegrityState, Reference, Tuning};
use calib_core::online::{Health, OnlineIntegrity};
use serde::Serialize;

use crate::data::table::{col, write_cells, Cell};
use crate::data::Recording;
use crate::doc::CalDoc;
use crate::doc::integrity::{IntegrityCounts, StateCounts};

/// The field's scatter about `F` taken when the document reports none, as a
/// fraction of `F` (the board's: calib-core's
/// [`calib_core::integrity::DEFAULT_FIELD_SIGMA_REL`]).
pub use calib_core::integrity::DEFAULT_FIELD_SIGMA_REL;

/// Why a recording could not be applied.
#[derive(Debug, thiserror::Error)]
pub enum ApplyError {
    /// The recording has no rows.
    #[error("the recording has no rows")]
    Empty,
    /// The document's reference cannot be checked against.
    #[error("the calibration's reference cannot be used for integrity: {0}")]
    Reference(&'static str),
    /// The output could not be written ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
}

/// Options beyond the document.
#[derive(Debug, Clone, Copy, Default)]
pub struct ApplyOptions {
    /// The reference intensity the calibration reproduces, nT (otherwise
    /// the document's `field_nt`): for a calibration from another tool
    /// whose scale is its own.
    pub field_nt: Option<f64>,
    /// The local inclination, degrees (otherwise the document's, or learned).
    pub inclination_deg: Option<f64>,
    /// The field's expected scatter, nT (otherwise the document's fit
    /// residual, or [`DEFAULT_FIELD_SIGMA_REL`] of `F`).
    pub field_sigma_nt: Option<f64>,
    /// The monitor's constants (otherwise [`Tuning::standard`], the
    /// board's); for studies such as the bench's leave-one-out choice.
    pub tuning: Option<Tuning<f64>>,
}

/// One row's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AppliedRow {
    /// Calibrated field, nT (NaN for a row without a complete sample).
    pub field_nt: [f64; 3],
    /// Heading, degrees in [0, 360) (`None` without attitude): true when
    /// the calibration holds a declination, else magnetic ([`North`]).
    pub heading_deg: Option<f64>,
    /// Its 1σ, degrees (`None` without attitude).
    pub heading_sigma_deg: Option<f64>,
    /// The integrity state.
    pub integrity: IntegrityState,
}

/// The whole recording's result.
#[derive(Debug, Clone)]
pub struct Applied {
    /// One per input row.
    pub rows: Vec<AppliedRow>,
    /// The reference the monitor checked against.
    pub reference: Reference<f64>,
    /// The inclination in use at the end (given or learned), degrees.
    pub inclination_deg: Option<f64>,
    /// The on-line hard-iron estimate at the end.
    pub hard_iron: Option<HardIron<f64>>,
    /// The hard iron applied at the end, nT.
    pub applied_offset_nt: Option<[f64; 3]>,
    /// The health counters.
    pub health: Health<f64>,
}

impl Applied {
    /// What the "recalibrate" rule reads of this run
    /// ([`crate::doc::integrity::recalibrate_evidence`]): the rows per
    /// state, the monitor's longest disturbance, whether the on-line hard
    /// iron was applied (ever, or at the end) and its estimate. The longest
    /// `cal_invalid` stretch is left out (the rows carry no clock).
    pub fn integrity_counts(&self) -> IntegrityCounts {
        let mut states = StateCounts::default();
        for r in &self.rows {
            states.add(r.integrity);
        }
        IntegrityCounts {
            states,
            longest_disturbance_s: self.health.longest_disturbance_s,
            longest_cal_invalid_s: None,
            hard_iron_applied: Some(
                self.health.hard_iron_applied > 0 || self.applied_offset_nt.is_some(),
            ),
            hard_iron_nt: self.hard_iron.map(|h| h.offset_nt),
        }
    }
}

/// Where the monitor's inclination came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum InclinationSource {
    /// `--inclination-deg`.
    User,
    /// The document's: the back-stepping's local field, the dip the
    /// calibration showed on its own recording (checked against the world
    /// model when the site was given), or the gyro fit's vertical.
    Document,
    /// The world model at the site given to `apply` (`--lat/--lon/--date`).
    Site,
    /// None independent of the recording judged: learned from its samples
    /// judged ok.
    Learned,
}

/// The inclination a document holds, degrees: the back-stepping's local
/// field, else the dip the calibration showed on its recording (its
/// `reference.check`), else the reference's own, else the gyro fit's
/// vertical over `field_nt`.
pub fn document_inclination_deg(doc: &CalDoc, field_nt: f64) -> Option<f64> {
    let q = &doc.quality;
    q.backstep
        .as_ref()
        .and_then(|b| b.estimates.as_ref())
        .map(|e| e.local_hz_nt[1].atan2(e.local_hz_nt[0]).to_degrees())
        .or_else(|| {
            doc.reference.as_ref().and_then(|r| {
                r.check
                    .as_ref()
                    .and_then(|c| c.inclination_deg)
                    .or(r.inclination_deg)
            })
        })
        .or_else(|| q.gyro.as_ref().map(|g| g.inclination_deg(field_nt)))
}

/// The inclination `apply` judges against and where it came from: the one
/// given, else the document's ([`document_inclination_deg`]), else the
/// world model's at the site, else none (learned, and no sample `ok`).
pub fn choose_inclination(
    doc: &CalDoc,
    field_nt: f64,
    given_deg: Option<f64>,
    site_deg: Option<f64>,
) -> (Option<f64>, InclinationSource) {
    match (given_deg, document_inclination_deg(doc, field_nt), site_deg) {
        (Some(d), _, _) => (Some(d), InclinationSource::User),
        (None, Some(d), _) => (Some(d), InclinationSource::Document),
        (None, None, Some(d)) => (Some(d), InclinationSource::Site),
        (None, None, None) => (None, InclinationSource::Learned),
    }
}

/// Where the heading's north comes from: the heading is true only when a
/// declination is known (the document's, its swing's A, or the world
/// model's at a site); otherwise it is magnetic and labelled so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum North {
    /// The document's `declination_deg`.
    DocumentDeclination,
    /// The document's swing, fitted against a true reference heading: its
    /// A holds the declination.
    Swing,
    /// IGRF-14's declination at the site given to `apply`.
    Site,
    /// IGRF-14's declination at the document's own reference site.
    DocumentSite,
    /// No declination known: the heading is magnetic.
    Magnetic,
}

impl North {
    /// The output's heading column: `heading_deg` (true) or
    /// `magnetic_heading_deg`.
    pub fn heading_column(self) -> &'static str {
        match self {
            North::Magnetic => MAGNETIC_HEADING_DEG,
            _ => col::HEADING_DEG,
        }
    }

    /// Why the heading is true or magnetic, in words.
    pub fn reason(self) -> &'static str {
        match self {
            North::DocumentDeclination => "true heading: the document's declination_deg added",
            North::Swing => "true heading: the document's swing was fitted against a true reference heading, so its A holds the declination",
            North::Site => "true heading: IGRF-14's declination at the site given added",
            North::DocumentSite => "true heading: IGRF-14's declination at the document's reference site added",
            North::Magnetic => "magnetic heading: neither the document (no declination_deg, no swing, no reference site) nor a site gives a declination",
        }
    }
}

/// The output column of a magnetic heading (no declination known), degrees.
pub const MAGNETIC_HEADING_DEG: &str = "magnetic_heading_deg";

/// Where the heading's north comes from for `doc`, and the declination to
/// add when it is not the document's own (degrees east): the document's
/// `declination_deg`, else its swing (A holds it), else the world model's
/// at `site` (given to `apply`), else at the document's reference site,
/// else none (magnetic).
pub fn choose_north(doc: &CalDoc, site: Option<&crate::geomag::Site>) -> (North, Option<f64>) {
    if doc.declination_deg.is_some() {
        return (North::DocumentDeclination, None);
    }
    if doc.swing.is_some() {
        return (North::Swing, None);
    }
    let declination = |s: &crate::geomag::Site| s.field().ok().map(|f| f.declination_deg());
    if let Some(d) = site.and_then(declination) {
        return (North::Site, Some(d));
    }
    match doc.reference.as_ref().and_then(|r| r.site.as_ref()).and_then(declination) {
        Some(d) => (North::DocumentSite, Some(d)),
        None => (North::Magnetic, None),
    }
}

/// The heading RMS to expect with a document against a true heading,
/// degrees: the σ `apply` gives a row judged against the document's own
/// reference ([`reference_of`]) — its predicted 1σ (the calibration's own
/// error) and each component's noise across the horizontal field,
/// `noise / (F cos I)`, in quadrature. `None` without an inclination.
pub fn expected_heading_rms_deg(doc: &CalDoc) -> Option<f64> {
    let r = reference_of(doc, &ApplyOptions::default()).ok()?;
    let h_nt = r.field_nt * r.inclination_rad?.cos();
    Some(r.heading_sigma_rad.hypot(r.noise_nt / h_nt).to_degrees())
}

/// The reference a document gives the monitor: `F`, the scatter (the
/// latest step's residual: a back-stepped calibration's per-axis residual
/// with its intensity's 1σ, else the fit's), the inclination
/// ([`document_inclination_deg`], or `opts`), the predicted heading error.
pub fn reference_of(doc: &CalDoc, opts: &ApplyOptions) -> Result<Reference<f64>, ApplyError> {
    let q = &doc.quality;
    let f = opts.field_nt.unwrap_or(doc.field_nt);
    let estimates = q.backstep.as_ref().and_then(|b| b.estimates.as_ref());
    let backstep_residual_nt = estimates.map(|e| e.residual_rms_nt);
    // The back-stepping replaced the first step's matrix: its residual on
    // the run, with the uncertainty of the intensity it found, is the
    // scatter |h| keeps (the first step's fit residual is a stale one).
    let backstep_scatter_nt = estimates.map(|e| e.residual_rms_nt.hypot(e.intensity_sigma_nt));
    let scatter = opts
        .field_sigma_nt
        .or(backstep_scatter_nt)
        .or_else(|| q.fit.as_ref().map(|x| x.residual_rms_nt))
        .or_else(|| q.gyro.as_ref().map(|g| g.residual_rms_nt))
        .filter(|s| *s > 0.0)
        .unwrap_or(DEFAULT_FIELD_SIGMA_REL * f);
    let inclination_rad = opts
        .inclination_deg
        .or_else(|| document_inclination_deg(doc, f))
        .map(f64::to_radians);
    let heading_sigma_rad = q.predicted_heading_rms_deg.unwrap_or(0.0).to_radians();
    // The per-component noise behind the heading's σ: a back-stepped
    // calibration's per-axis residual on the run (its slowly varying errors
    // are in the predicted heading error already); else the scatter.
    let noise_nt = opts
        .field_sigma_nt
        .or(backstep_residual_nt)
        .filter(|s| *s > 0.0)
        .unwrap_or(scatter);
    let r = Reference {
        field_nt: f,
        field_sigma_nt: scatter,
        noise_nt,
        inclination_rad,
        heading_sigma_rad,
    };
    calib_core::integrity::Monitor::new(r, opts.tuning.unwrap_or_else(Tuning::standard)).map_err(|e| match e {
        IntegrityError::BadReference => ApplyError::Reference("the field's scatter and noise must be positive and below field_nt, the inclination within ±90°"),
        IntegrityError::BadTuning => ApplyError::Reference("a tuning constant is not positive, or the misfit thresholds not 0 < exit < enter < 1"),
    })?;
    Ok(r)
}

/// Applies the document to every row, as the board would.
pub fn apply_recording(
    rec: &Recording,
    doc: &CalDoc,
    opts: &ApplyOptions,
) -> Result<Applied, ApplyError> {
    if rec.is_empty() {
        return Err(ApplyError::Empty);
    }
    let reference = reference_of(doc, opts)?;
    // The board's estimator cadence, so a recording gives the board's bits.
    let mut online = OnlineIntegrity::new(reference, opts.tuning.unwrap_or_else(Tuning::standard))
        .map_err(|_| ApplyError::Reference("bad reference"))?
        .with_estimator_every(calib_core::online::BOARD_ESTIMATOR_EVERY);
    let cal = doc.calibration();
    let col = |c: &Option<Vec<f64>>, i: usize| {
        c.as_ref()
            .and_then(|v| v.get(i).copied())
            .filter(|v| v.is_finite())
    };
    let gyro = rec.gyro_rad_s();
    let mut prev_t: Option<f64> = None;
    let mut rows = Vec::with_capacity(rec.len());
    for (i, raw) in rec.mag.iter().enumerate() {
        let t = col(&rec.t_s, i);
        let dt = match (t, prev_t) {
            (Some(t), Some(p)) => t - p,
            _ => f64::NAN,
        };
        if t.is_some() {
            prev_t = t;
        }
        if !raw.iter().all(|v| v.is_finite()) {
            // No field: no heading, whatever the attitude.
            let attitude = col(&rec.roll_deg, i).is_some() && col(&rec.pitch_deg, i).is_some();
            rows.push(AppliedRow {
                field_nt: [f64::NAN; 3],
                heading_deg: None,
                heading_sigma_deg: None,
                integrity: decide(&Evidence::without_monitor(false, attitude)),
            });
            continue;
        }
        let env = Environment {
            current_a: col(&rec.motor_current_a, i).unwrap_or(0.0),
            temp_c: col(&rec.temp_c, i).unwrap_or(cal.env.ref_c),
        };
        let corrected = cal.env.correct_raw(*raw, &env);
        let tilt = match (col(&rec.roll_deg, i), col(&rec.pitch_deg, i)) {
            (Some(r), Some(p)) => Some(Tilt::new(r.to_radians(), p.to_radians())),
            _ => None,
        };
        let rate = gyro
            .as_ref()
            .and_then(|g| g.get(i).copied())
            .filter(|w| w.iter().all(|v| v.is_finite()) && dt.is_finite());
        let out = online.process(&cal, corrected, tilt.as_ref(), rate, dt);
        rows.push(AppliedRow {
            field_nt: out.field_nt,
            heading_deg: out.heading_rad.map(f64::to_degrees),
            heading_sigma_deg: out
                .heading_rad
                .map(|_| out.verdict.heading_sigma_rad.to_degrees()),
            integrity: out.verdict.state,
        });
    }
    Ok(Applied {
        rows,
        reference,
        inclination_deg: online.monitor().inclination_rad().map(f64::to_degrees),
        hard_iron: online.hard_iron(),
        applied_offset_nt: online.applied_offset_nt(),
        health: *online.health(),
    })
}

/// The heading error against a reference heading (degrees), per row
/// (`None` where either is missing), wrapped to (−180, 180].
pub fn heading_errors_deg(applied: &Applied, reference_deg: &[f64]) -> Vec<Option<f64>> {
    applied
        .rows
        .iter()
        .zip(reference_deg)
        .map(|(r, &t)| {
            r.heading_deg
                .filter(|_| t.is_finite())
                .map(|h| wrap_pi((h - t).to_radians()).to_degrees())
        })
        .collect()
}

/// The best constant offset of a set of heading errors (their circular
/// mean), degrees: what a declination would remove.
pub fn constant_offset_deg(errors_deg: &[f64]) -> f64 {
    let (s, c) = errors_deg.iter().fold((0.0, 0.0), |(s, c), e| {
        (s + e.to_radians().sin(), c + e.to_radians().cos())
    });
    s.atan2(c).to_degrees()
}

/// The constant offset of a set of heading errors that rows off by a
/// disturbance do not move: the median of the errors about their circular
/// mean, degrees. The integrity score's offset, taken robustly: on a trial
/// passing a magnet (`broad-28`), the circular mean is pulled 2.6° by the
/// rows 40–150° off, and a third of the undisturbed rows then count as
/// "bad"; the median stays within 0.2° of the undisturbed rows' mean.
pub fn robust_offset_deg(errors_deg: &[f64]) -> f64 {
    let mean = constant_offset_deg(errors_deg);
    let mut about: Vec<f64> = errors_deg
        .iter()
        .map(|e| wrap_pi((e - mean).to_radians()).to_degrees())
        .collect();
    mean + calib_core::series::median(&mut about).unwrap_or(0.0)
}

/// `magcal apply --json`: what the run found.
#[derive(Debug, Clone, Serialize)]
pub struct ApplySummary {
    /// Rows in the recording.
    pub rows: usize,
    /// Rows per integrity state.
    pub rows_per_state: BTreeMap<&'static str, usize>,
    /// The reference intensity, its scatter and the inclination used (deg).
    pub field_nt: f64,
    /// The field's expected scatter, nT (the magnitude and dip gates' σ).
    pub field_sigma_nt: f64,
    /// Each component's noise behind the heading's σ, nT.
    pub noise_nt: f64,
    /// The inclination in use at the end (given or learned), degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inclination_deg: Option<f64>,
    /// Where the inclination came from (set by the caller that chose it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inclination_source: Option<InclinationSource>,
    /// Where the heading's north came from (set by the caller that chose it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub north: Option<North>,
    /// The output's heading column and why ([`North::reason`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_column: Option<&'static str>,
    /// Why the heading is true or magnetic.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub north_reason: Option<&'static str>,
    /// What the run must say about its inputs: a weak document used, a
    /// value beyond its allowance kept (empty: nothing).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Longest run not ok, s.
    pub longest_disturbance_s: f64,
    /// The on-line hard-iron estimate at the end, nT, with its 1σ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hard_iron_nt: Option<[f64; 3]>,
    /// Its 1σ, nT.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hard_iron_sigma_nt: Option<[f64; 3]>,
    /// Whether the estimate was applied at the end of the recording.
    pub hard_iron_applied: bool,
    /// The reference heading column compared against, when present.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_reference: Option<String>,
    /// Heading RMS error over all rows with a heading and a reference, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_rms_deg: Option<f64>,
    /// The same over the rows judged ok.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_rms_ok_deg: Option<f64>,
    /// The constant offset (circular mean error) over all rows, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub constant_offset_deg: Option<f64>,
    /// Heading RMS over the ok rows with that offset removed, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub heading_rms_ok_offset_removed_deg: Option<f64>,
    /// RMS of the predicted 1σ over the ok rows, degrees (compare with the
    /// observed RMS: their ratio is the σ's honesty).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_sigma_ok_deg: Option<f64>,
}

fn rms(v: impl Iterator<Item = f64>) -> Option<f64> {
    let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    (n > 0).then(|| (s / n as f64).sqrt())
}

/// The summary, with the heading compared against `reference` (column name
/// and values) when given.
pub fn summarize(applied: &Applied, reference: Option<(&str, &[f64])>) -> ApplySummary {
    let mut per_state: BTreeMap<&'static str, usize> =
        IntegrityState::ALL.iter().map(|s| (s.name(), 0)).collect();
    for r in &applied.rows {
        *per_state.entry(r.integrity.name()).or_default() += 1;
    }
    let ok = |i: usize| {
        applied
            .rows
            .get(i)
            .is_some_and(|r| r.integrity == IntegrityState::Ok)
    };
    let predicted = rms(applied
        .rows
        .iter()
        .filter(|r| r.integrity == IntegrityState::Ok)
        .filter_map(|r| r.heading_sigma_deg));
    let mut s = ApplySummary {
        rows: applied.rows.len(),
        rows_per_state: per_state,
        field_nt: applied.reference.field_nt,
        field_sigma_nt: applied.reference.field_sigma_nt,
        noise_nt: applied.reference.noise_nt,
        inclination_deg: applied.inclination_deg,
        inclination_source: None,
        north: None,
        heading_column: None,
        north_reason: None,
        warnings: Vec::new(),
        longest_disturbance_s: applied.health.longest_disturbance_s,
        hard_iron_nt: applied.hard_iron.map(|h| h.offset_nt),
        hard_iron_sigma_nt: applied.hard_iron.map(|h| h.sigma_nt),
        hard_iron_applied: applied.applied_offset_nt.is_some(),
        heading_reference: None,
        heading_rms_deg: None,
        heading_rms_ok_deg: None,
        constant_offset_deg: None,
        heading_rms_ok_offset_removed_deg: None,
        predicted_sigma_ok_deg: predicted,
    };
    if let Some((name, values)) = reference {
        let errors = heading_errors_deg(applied, values);
        let all: Vec<f64> = errors.iter().flatten().copied().collect();
        if !all.is_empty() {
            let offset = constant_offset_deg(&all);
            let ok_errors = || {
                errors
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| ok(*i))
                    .filter_map(|(_, e)| *e)
            };
            s.heading_reference = Some(name.to_string());
            s.heading_rms_deg = rms(all.iter().copied());
            s.heading_rms_ok_deg = rms(ok_errors());
            s.constant_offset_deg = Some(offset);
            s.heading_rms_ok_offset_removed_deg =
                rms(ok_errors().map(|e| wrap_pi((e - offset).to_radians()).to_degrees()));
        }
    }
    s
}

/// Writes `OUT.csv`: the input's `t` (when it has one) and, per row, the
/// calibrated field, heading (under `north`'s column: `heading_deg` true,
/// `magnetic_heading_deg` magnetic), σ and integrity, through
/// [`crate::files::write_atomic`], after [`crate::files::check_output`]:
/// never over `input` (also through a hard or symbolic link).
pub fn write_applied(
    path: &Path,
    input: &Path,
    t_s: Option<&[f64]>,
    applied: &Applied,
    north: North,
) -> Result<(), ApplyError> {
    crate::files::check_output(path, &[input])?;
    let mut header = if t_s.is_some() { vec![col::T] } else { vec![] };
    header.extend(["field_x_nt", "field_y_nt", "field_z_nt", north.heading_column(), "heading_sigma_deg", "integrity"]);
    write_cells(path, &header, |w| {
        for (i, r) in applied.rows.iter().enumerate() {
            let mut cells = Vec::with_capacity(7);
            if let Some(t) = t_s {
                cells.push(Cell::opt(t.get(i).copied()));
            }
            cells.extend(r.field_nt.map(|v| Cell::Fixed(v, 1)));
            cells.extend([Cell::opt_fixed(r.heading_deg, 3), Cell::opt_fixed(r.heading_sigma_deg, 3), Cell::Text(r.integrity.name())]);
            w.row(&cells)?;
        }
        Ok(())
    })?;
    Ok(())
}

/// How well the integrity separates good headings from bad against a
/// reference heading (the rule of the bench and the real-data tests): the
/// heading error with one constant offset removed (as a declination
/// would; [`robust_offset_deg`]), the rows off by more than `bad_deg`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct IntegrityScore {
    /// Rows with a heading and a reference.
    pub rows: usize,
    /// Fraction of them judged ok.
    pub ok_fraction: f64,
    /// Rows off by more than `bad_deg`.
    pub bad_rows: usize,
    /// Fraction of those not judged ok (NaN without any).
    pub bad_not_ok_fraction: f64,
    /// Rows off by more than [`GROSS_DEG`] (a disturbance, not the
    /// calibration's own error's tail).
    pub gross_rows: usize,
    /// Fraction of those not judged ok (NaN without any).
    pub gross_not_ok_fraction: f64,
    /// Rows within [`GOOD_DEG`] of the reference.
    pub good_rows: usize,
    /// Fraction of those judged ok (NaN without any).
    pub good_ok_fraction: f64,
    /// Heading RMS error over the ok rows, degrees (NaN without any).
    pub ok_rms_deg: f64,
    /// RMS of the predicted σ over the ok rows, degrees (NaN without any).
    pub ok_predicted_deg: f64,
}

impl IntegrityScore {
    /// Observed over predicted heading RMS on the ok rows (1 is honest).
    pub fn sigma_ratio(&self) -> f64 {
        self.ok_rms_deg / self.ok_predicted_deg
    }
}

/// A row within this of the reference (after the constant offset) is
/// "good" (the scoring rule: the share of good rows kept `ok` is the
/// monitor's false-alarm side), degrees.
pub const GOOD_DEG: f64 = 2.0;

/// A row off by more than this is off by a disturbance, not by the tail of
/// the stored calibration's own error (1.7–2.5° RMS on the undisturbed
/// BROAD trials, whose rows beyond 5° are that tail: 0.4–4 % of them),
/// degrees.
pub const GROSS_DEG: f64 = 10.0;

/// Scores `applied` against `reference_deg`, rows off by more than `bad_deg` counting as bad.
pub fn score(applied: &Applied, reference_deg: &[f64], bad_deg: f64) -> IntegrityScore {
    let errors = heading_errors_deg(applied, reference_deg);
    let all: Vec<f64> = errors.iter().flatten().copied().collect();
    let offset = robust_offset_deg(&all);
    let rows: Vec<(f64, &AppliedRow)> = errors
        .iter()
        .zip(&applied.rows)
        .filter_map(|(e, r)| e.map(|e| (wrap_pi((e - offset).to_radians()).to_degrees(), r)))
        .collect();
    let is_ok = |r: &AppliedRow| r.integrity == IntegrityState::Ok;
    let ok: Vec<&(f64, &AppliedRow)> = rows.iter().filter(|(_, r)| is_ok(r)).collect();
    let bad: Vec<&(f64, &AppliedRow)> = rows.iter().filter(|(e, _)| e.abs() > bad_deg).collect();
    let frac = |n: usize, d: usize| {
        if d == 0 {
            f64::NAN
        } else {
            n as f64 / d as f64
        }
    };
    IntegrityScore {
        rows: rows.len(),
        ok_fraction: frac(ok.len(), rows.len()),
        bad_rows: bad.len(),
        bad_not_ok_fraction: frac(bad.iter().filter(|(_, r)| !is_ok(r)).count(), bad.len()),
        gross_rows: rows.iter().filter(|(e, _)| e.abs() > GROSS_DEG).count(),
        gross_not_ok_fraction: frac(
            rows.iter()
                .filter(|(e, r)| e.abs() > GROSS_DEG && !is_ok(r))
                .count(),
            rows.iter().filter(|(e, _)| e.abs() > GROSS_DEG).count(),
        ),
        good_rows: rows.iter().filter(|(e, _)| e.abs() < GOOD_DEG).count(),
        good_ok_fraction: frac(
            rows.iter()
                .filter(|(e, r)| e.abs() < GOOD_DEG && is_ok(r))
                .count(),
            rows.iter().filter(|(e, _)| e.abs() < GOOD_DEG).count(),
        ),
        ok_rms_deg: rms(ok.iter().map(|(e, _)| *e)).unwrap_or(f64::NAN),
        ok_predicted_deg: rms(ok.iter().filter_map(|(_, r)| r.heading_sigma_deg))
            .unwrap_or(f64::NAN),
    }
}

/// The gates' scale factors of [`gate_curve`] (1: the tuning given).
pub const GATE_CURVE: [f64; 7] = [0.5, 0.7, 0.85, 1.0, 1.2, 1.5, 2.0];

/// One point of [`gate_curve`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GatePoint {
    /// Every gate (field with and without a gyro, gyro) times this.
    pub gates_times: f64,
    /// The score there.
    pub score: IntegrityScore,
}

/// How the separation of good rows from bad moves with the gates: `rec`
/// run through `doc` with every gate of the tuning in `opts` (else
/// [`Tuning::standard`]) times each of [`GATE_CURVE`], scored against
/// `reference_deg` (rows off by more than `bad_deg` bad). The bench's and
/// the report's curve, with the tuning given at × 1.
pub fn gate_curve(rec: &Recording, doc: &CalDoc, opts: &ApplyOptions, reference_deg: &[f64], bad_deg: f64) -> Result<Vec<GatePoint>, ApplyError> {
    let base = opts.tuning.unwrap_or_else(Tuning::standard);
    GATE_CURVE
        .iter()
        .map(|&k| {
            let tuning = Tuning { gate_sigma: base.gate_sigma * k, no_gyro_gate_sigma: base.no_gyro_gate_sigma * k, gyro_gate_sigma: base.gyro_gate_sigma * k, ..base };
            let applied = apply_recording(rec, doc, &ApplyOptions { tuning: Some(tuning), ..*opts })?;
            Ok(GatePoint { gates_times: k, score: score(&applied, reference_deg, bad_deg) })
        })
        .collect()
}

#[cfg(test)]
mod tests;
