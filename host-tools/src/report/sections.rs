//! The report's sections, one function each, in the page's order: each
//! writes its part of the [`Page`] or says what input it lacks.

use std::fmt::Write as _;
use std::path::Path;

use calib_core::heading::wrap_pi;

use super::error::ReportError;
use super::inputs::{CardFiles, ReportInputs};
use super::page::{escape, fmt_opt, Page};
use super::plot::{self, integer_ticks, try_coverage_map, try_histogram, try_line_plot, CoverageGrid, Series};
use crate::compute::apply::{apply_recording, gate_curve, heading_errors_deg, summarize, ApplyOptions, ApplySummary, GatePoint, GOOD_DEG};
use crate::compute::card::{deviation_card, DeviationCard};
use calib_core::integrity::IntegrityState;
use crate::compute::magnetic_headings;
use crate::compute::truth::{calibrated_fields_nt, heading_rms_deg, true_headings_rad};
use crate::doc::caldoc::CalDoc;
use crate::doc::results::TraceEntry;
use crate::geomag::Field;
use crate::procedure::{PITCH_GATE_DEG, ROLL_GATE_DEG};

/// Points a line keeps (every k-th row): enough for the eye at the page's
/// 900 px, few enough that the page renders quickly.
const LINE_POINTS: usize = 2000;
/// Dots a scatter series keeps (each is an SVG element).
const SCATTER_POINTS: usize = 700;

/// Errors by row, each labelled (a histogram's samples).
pub(crate) type Errors = Vec<(String, Vec<f64>)>;

/// Heading errors on the validation run (heading − truth, degrees): with
/// the coefficients before (when known) and with the final calibration.
pub(crate) struct ValidationErrors {
    pub(crate) before: Option<Vec<f64>>,
    pub(crate) after: Vec<f64>,
}

/// What every section shares: the inputs and what follows from them.
pub(crate) struct Context<'a> {
    pub(crate) inputs: &'a ReportInputs<'a>,
    /// The calibration reported on (the last).
    pub(crate) final_doc: Option<&'a CalDoc>,
    /// IGRF-14 at the site.
    pub(crate) igrf: Option<Field>,
    /// The reference intensity, nT: given, else IGRF, else the final document's.
    pub(crate) field_nt: Option<f64>,
    pub(crate) validation_errors: Option<ValidationErrors>,
}

impl<'a> Context<'a> {
    /// The context of `inputs`; refuses a validation truth whose length is
    /// not the recording's.
    pub(crate) fn new(inputs: &'a ReportInputs<'a>) -> Result<Self, ReportError> {
        let final_doc = inputs.cals.last().map(|(_, d)| *d);
        let igrf = inputs.site.as_ref().and_then(|s| s.field().ok());
        let field_nt = inputs.field_nt.or(igrf.as_ref().map(|f| f.total_nt())).or(final_doc.map(|d| d.field_nt));
        let validation_errors = match (&inputs.validation, final_doc) {
            (Some(v), Some(doc)) => {
                if v.truth_deg.len() != v.recording.len() {
                    return Err(ReportError::TruthLength { truth_rows: v.truth_deg.len(), recording_rows: v.recording.len() });
                }
                let err = |h: Vec<f64>| h.iter().zip(v.truth_deg).map(|(h, t)| wrap_pi(h - t.to_radians()).to_degrees()).collect::<Vec<f64>>();
                let after = err(true_headings_rad(doc, v.recording));
                let before = inputs.before.map(|b| err(true_headings_rad(b, v.recording)));
                Some(ValidationErrors { before, after })
            }
            _ => None,
        };
        Ok(Self { inputs, final_doc, igrf, field_nt, validation_errors })
    }
}

/// At most about `n` indices spread over `0..len`.
fn thin(len: usize, n: usize) -> impl Iterator<Item = usize> {
    (0..len).step_by(len.div_ceil(n.max(1)).max(1))
}

/// The finite `(t, e)` points of a scatter, thinned to [`SCATTER_POINTS`].
fn scatter_points(t: &[f64], e: &[f64]) -> Vec<(f64, f64)> {
    let rows: Vec<usize> = (0..e.len().min(t.len())).filter(|&i| e[i].is_finite()).collect();
    let step = rows.len().div_ceil(SCATTER_POINTS).max(1);
    rows.iter().step_by(step).map(|&i| (t[i], e[i])).collect()
}

/// A decimal year as a calendar date (`2021.0` → `2021-01-01`).
pub fn date_of_decimal_year(year: f64) -> String {
    let y = year.floor() as i32;
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let mut day = ((year - year.floor()) * if leap { 366.0 } else { 365.0 }).floor() as u32;
    let months = [31, if leap { 29 } else { 28 }, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31];
    let mut m = 0;
    while m < 11 && day >= months[m] {
        day -= months[m];
        m += 1;
    }
    format!("{y:04}-{:02}-{:02}", m + 1, day + 1)
}

/// Section 1, the headline: heading RMS before → after, the prediction, the
/// verified upload, date, site, IGRF.
pub(crate) fn headline(page: &mut Page, cx: &Context<'_>) {
    let inputs = cx.inputs;
    page.h2("headline", "Headline");
    let rms = |e: &[f64]| heading_rms_deg(e.iter().map(|d| (d.to_radians(), 0.0))).rms;
    let (before_rms, after_rms, source) = match (inputs.summary.and_then(|s| s.validation), &cx.validation_errors) {
        (Some(v), _) => (Some(v.heading_rms_deg_before), Some(v.heading_rms_deg_after), "the board's own headings against the truth (session summary)"),
        (None, Some(e)) => (e.before.as_deref().map(rms), Some(rms(&e.after)), "the final calibration applied to the validation recording"),
        (None, None) => (None, None, ""),
    };
    // The session's prediction (the fit's covariance and the run's white
    // heading noise) when there is one, else the final document's own.
    let predicted = inputs.summary.and_then(|s| s.predicted_heading_rms_deg).or_else(|| inputs.cals.iter().rev().find_map(|(_, d)| d.quality.predicted_heading_rms_deg));
    let verified = match inputs.summary {
        Some(s) if s.coefficients_verified => format!("<span class=\"ok\">yes</span> (board set #{})", s.coefficient_seq),
        Some(_) => "<span class=\"bad\">NO</span>".into(),
        None => "not known (no session summary)".into(),
    };
    page.body.push_str("<table class=\"headline\">\n");
    let mut row = |k: &str, v: String| {
        let _ = writeln!(page.body, "<tr><th class=\"l\">{k}</th><td class=\"l big\">{v}</td></tr>");
    };
    let before_text = match (before_rms, after_rms) {
        // The card's "before" is the uncalibrated heading: a different thing.
        (None, Some(_)) => "not given (no coefficients before; the card's “before” is the uncalibrated heading)".to_string(),
        _ => fmt_opt(before_rms, 2, "°"),
    };
    // Against a truth column the calibration's own error; against a GPS
    // course (`--truth-column ref_heading_deg`) also the reference's.
    let label = match inputs.validation.as_ref().map(|v| v.truth_column) {
        Some(c) if inputs.summary.and_then(|s| s.validation).is_none() && !crate::compute::card::is_truth_column(c) => {
            format!("Heading RMS against `{}` on validation, before → after ({})", escape(c), crate::compute::card::reference_note(c))
        }
        _ => "True-heading RMS on validation, before → after".to_string(),
    };
    row(&label, format!("{before_text} → {}", fmt_opt(after_rms, 2, "°")));
    row("Predicted heading error (from the fit's covariance only: what the data's noise leaves uncertain, not what the model leaves out)", fmt_opt(predicted, 2, "° RMS"));
    if let (Some(p), Some(after)) = (predicted, after_rms) {
        if p > 0.0 {
            row("Observed ÷ predicted heading error", format!("{:.2} (near 1: the prediction is honest)", after / p));
        }
    }
    row("Coefficients verified on the board", verified);
    if let Some(s) = inputs.summary.and_then(|s| s.validation) {
        let reference = if s.field_against_truth { "the true local field" } else { "IGRF" };
        row(&format!("|F| − {reference} on validation, after"), fmt_opt(Some(s.field_error_nt_after), 1, " nT RMS"));
    }
    match &inputs.site {
        Some(s) => {
            row("Date", date_of_decimal_year(s.decimal_year));
            row("Site", format!("{:.4}° {}, {:.4}° {}", s.lat_deg.abs(), if s.lat_deg >= 0.0 { "N" } else { "S" }, s.lon_deg.abs(), if s.lon_deg >= 0.0 { "E" } else { "W" }));
        }
        None => match recordings_position(inputs) {
            Some((lat, lon)) => row("Site (no site given: the recordings' mean position)", format!("{:.4}° {}, {:.4}° {}", lat.abs(), if lat >= 0.0 { "N" } else { "S" }, lon.abs(), if lon >= 0.0 { "E" } else { "W" })),
            None => row("Date, site", "not available (no site given)".into()),
        },
    }
    if let Some(st) = inputs.settings {
        row("Vehicle, firmware", format!("{}, firmware {}", escape(&st.vehicle), escape(&st.firmware)));
    }
    match &cx.igrf {
        Some(f) => row("IGRF-14 at the site", format!("F {:.0} nT, H {:.0} nT, Z {:.0} nT, I {:.2}°, D {:.2}°", f.total_nt(), f.horizontal_nt(), f.down_nt, f.inclination_deg(), f.declination_deg())),
        None => row("IGRF-14", "not available (no site given)".into()),
    }
    page.body.push_str("</table>\n");
    if !source.is_empty() {
        page.p(&format!("Heading RMS from {}.", escape(source)));
    } else {
        page.missing("headline", "no validation run with a truth heading and no session summary: no heading RMS before/after");
    }
    page.end();
}

/// The mean of the recordings' own positions (`lat_deg`, `lon_deg`), when
/// they carry any: the validation run's, the run's, the swing test's.
fn recordings_position(inputs: &ReportInputs<'_>) -> Option<(f64, f64)> {
    let recs = [inputs.validation.as_ref().map(|v| v.recording), inputs.run, inputs.swing];
    recs.into_iter().flatten().find_map(|r| {
        let (lat, lon) = (r.lat_deg.as_ref()?, r.lon_deg.as_ref()?);
        let fixes: Vec<(f64, f64)> = lat.iter().zip(lon).filter(|(a, o)| a.is_finite() && o.is_finite()).map(|(&a, &o)| (a, o)).collect();
        let n = fixes.len() as f64;
        (n > 0.0).then(|| (fixes.iter().map(|f| f.0).sum::<f64>() / n, fixes.iter().map(|f| f.1).sum::<f64>() / n))
    })
}

/// Section 2, the deviation card of the validation run (against truth), else of
/// the run (against its GPS reference); its files are written into `dir`.
pub(crate) fn card(page: &mut Page, cx: &Context<'_>, dir: &Path) -> Result<Option<CardFiles>, ReportError> {
    page.h2("card", "Deviation card");
    let mut card_files = None;
    let card_input = match (&cx.inputs.validation, cx.inputs.run) {
        (Some(v), _) => {
            let mut rec = v.recording.clone();
            rec.ref_heading_deg = Some(v.truth_deg.to_vec());
            Some((rec, "truth (validation run)"))
        }
        (None, Some(run)) if run.ref_heading_deg.is_some() => Some((run.clone(), "GPS course (run, at the surface)")),
        _ => None,
    };
    match (card_input, cx.final_doc) {
        (Some((rec, against)), Some(doc)) => match deviation_card(&rec, doc, 15.0, 16) {
            Ok(card) => card_files = Some(card_section(page, dir, &card, against)?),
            Err(e) => page.missing("card", &format!("the card could not be made against the {against}: {e}")),
        },
        (_, None) => page.missing("card", "no calibration document"),
        (None, _) => page.missing("card", "no validation run with a truth column and no run with a reference heading"),
    }
    page.end();
    Ok(card_files)
}

/// The card's section: table, figure, and its files written beside the page.
fn card_section(page: &mut Page, dir: &Path, card: &DeviationCard, against: &str) -> Result<CardFiles, ReportError> {
    let files = write_card(dir, card, against)?;
    page.p(&format!(
        "Reference − heading against the {}, {} samples; before = the raw field (no calibration, declination only), after = the final calibration. Mean is circular; RMS of the wrapped error. Files: <code>deviation_card.txt</code>, <code>.csv</code>, <code>.json</code>.",
        escape(against),
        card.samples
    ));
    card_table(&mut page.body, card);
    let mean = |after: bool| -> Vec<(f64, f64)> {
        card.by_heading.iter().map(|r| (r.centre_deg, if after { r.after.mean_deg } else { r.before.mean_deg }.unwrap_or(f64::NAN))).collect()
    };
    let series = [Series { name: "before (raw field)".into(), points: mean(false), dots: false }, Series { name: "after (final calibration)".into(), points: mean(true), dots: false }];
    let ticks: Vec<f64> = (0..=8).map(|k| f64::from(k) * 45.0).collect();
    page.figure(
        plot::try_line_plot_ticks("Deviation by heading (15° sectors)", "reference heading, ° true", "reference − heading, °", &series, Some((0.0, 360.0)), None, Some(&ticks)),
        "The card's mean deviation per 15° sector; a gap is a sector without samples.",
    )?;
    Ok(files)
}

/// Writes the card as `deviation_card.txt`, `.csv` and `.json` in `dir`.
pub fn write_card(dir: &Path, card: &DeviationCard, against: &str) -> Result<CardFiles, ReportError> {
    let [text, csv, json] = super::CARD_FILES.map(|name| dir.join(name));
    crate::files::write_text_atomic(&text, &format!("Deviation card against the {against}\n{}", card.to_text()))?;
    card.write_csv(&csv)?;
    let body = serde_json::to_string_pretty(card)?;
    crate::files::write_text_atomic(&json, &body)?;
    Ok(CardFiles { text, csv, json, against: against.into() })
}

fn card_table(out: &mut String, card: &DeviationCard) {
    let cell = |v: Option<f64>| v.map(|v| format!("{v:+.2}")).unwrap_or_else(|| "—".into());
    let rms = |v: Option<f64>| v.map(|v| format!("{v:.2}")).unwrap_or_else(|| "—".into());
    out.push_str("<div class=\"cols\"><table><tr><th class=\"l\">point</th><th>before mean, °</th><th>before RMS, °</th><th>after mean, °</th><th>after RMS, °</th><th>samples</th></tr>\n");
    for r in &card.by_point {
        let _ = writeln!(
            out,
            "<tr><td class=\"l\">{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            escape(&r.label),
            cell(r.before.mean_deg),
            rms(r.before.rms_deg),
            cell(r.after.mean_deg),
            rms(r.after.rms_deg),
            r.after.samples
        );
    }
    let _ = writeln!(
        out,
        "<tr><th class=\"l\">all</th><th>{}</th><th>{}</th><th>{}</th><th>{}</th><th>{}</th></tr></table></div>",
        cell(card.before.mean_deg),
        rms(card.before.rms_deg),
        cell(card.after.mean_deg),
        rms(card.after.rms_deg),
        card.samples
    );
}

/// Section 3, the swing test's coverage: heading × roll and heading × pitch maps
/// with the gaps marked (paper 000 Fig 6).
pub(crate) fn coverage(page: &mut Page, cx: &Context<'_>) -> Result<(), ReportError> {
    page.h2("coverage", "Swing test coverage (paper 000 Fig 6)");
    match (cx.inputs.swing, cx.final_doc) {
        (Some(swing), _) if swing.roll_deg.is_none() || swing.pitch_deg.is_none() => page.missing("coverage", "the swing test has no roll_deg/pitch_deg columns"),
        (Some(swing), Some(doc)) => {
            let (roll, pitch) = (swing.roll_deg.as_deref().unwrap_or(&[]), swing.pitch_deg.as_deref().unwrap_or(&[]));
            // With the document's current and temperature terms, as everywhere
            // (roll and pitch are there: checked above).
            let heading: Vec<f64> = magnetic_headings(swing, doc).unwrap_or_default().iter().map(|h| h.to_degrees()).collect();
            let by_roll = CoverageGrid::new(heading.iter().copied().zip(roll.iter().copied()), 30.0, 60.0, 10.0, ROLL_GATE_DEG);
            let by_pitch = CoverageGrid::new(heading.iter().copied().zip(pitch.iter().copied()), 30.0, 15.0, 2.5, PITCH_GATE_DEG);
            page.p(&format!(
                "{} samples; magnetic heading from the final calibration. Cells are 30° of heading by 10° of roll (2.5° of pitch); an empty cell inside the session's gate (roll ±{ROLL_GATE_DEG:.0}°, pitch ±{PITCH_GATE_DEG:.0}°) is a gap: {} gaps in roll, {} in pitch.",
                swing.len(),
                by_roll.gaps(),
                by_pitch.gaps()
            ));
            page.figure(try_coverage_map("Swing test: heading × roll", "roll, °", &by_roll), "Key: blue cells hold samples (darker = more, log scale); red crossed cells are gaps (no sample inside the gate); dashed lines: the gate.")?;
            page.figure(try_coverage_map("Swing test: heading × pitch", "pitch, °", &by_pitch), "Same key as above, for pitch.")?;
        }
        (None, _) => page.missing("coverage", "no swing-test recording"),
        (_, None) => page.missing("coverage", "no calibration document to compute headings"),
    }
    page.end();
    Ok(())
}

/// Section 4, the field magnitude along the run for each calibration (paper 000
/// Figs 7–12); returns each calibration's |H| − reference for the residuals.
pub(crate) fn field(page: &mut Page, cx: &Context<'_>) -> Result<Errors, ReportError> {
    let inputs = cx.inputs;
    page.h2("field", "Field magnitude along the run (paper 000 Figs 7–12)");
    let mut field_errors = Vec::new();
    match (inputs.run, inputs.run.and_then(|r| r.t_s.as_ref())) {
        (Some(run), Some(t)) if !inputs.cals.is_empty() => {
            let mut series = Vec::new();
            for (label, doc) in &inputs.cals {
                let f: Vec<f64> = calibrated_fields_nt(doc, run).iter().map(|h| (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()).collect();
                series.push(Series { name: label.clone(), points: thin(run.len(), LINE_POINTS).map(|i| (t[i], f[i])).collect(), dots: false });
                if let Some(r) = cx.field_nt {
                    field_errors.push((label.clone(), f.iter().map(|v| v - r).collect()));
                }
            }
            if let (Some(f), Some(&t0), Some(&t1)) = (cx.field_nt, t.first(), t.last()) {
                series.push(Series { name: format!("IGRF {f:.0} nT"), points: vec![(t0, f), (t1, f)], dots: false });
            }
            page.figure(try_line_plot("|H| along the out-and-back run", "time, s", "|H|, nT", &series, None, None), "The field magnitude with each calibration; the step at the turnaround is what back-stepping removes.")?;
        }
        (None, _) => page.missing("field", "no run recording"),
        (_, None) => page.missing("field", "the run has no `t` column"),
        _ => page.missing("field", "no calibration document"),
    }
    page.end();
    Ok(field_errors)
}

/// Section 5, heading against the reference at the surface (paper 000 Fig 13) and
/// against the truth in validation; returns the heading errors for the
/// residuals.
pub(crate) fn heading(page: &mut Page, cx: &Context<'_>) -> Result<Errors, ReportError> {
    let inputs = cx.inputs;
    page.h2("heading", "Heading against the reference (paper 000 Fig 13) and the truth");
    let mut heading_errors = Vec::new();
    match (inputs.run, inputs.run.and_then(|r| r.t_s.as_ref())) {
        (Some(run), Some(t)) if run.ref_heading_deg.is_some() && !inputs.cals.is_empty() => {
            let reference = run.ref_heading_deg.as_deref().unwrap_or(&[]);
            let mut series = Vec::new();
            for (label, doc) in &inputs.cals {
                let e: Vec<f64> = true_headings_rad(doc, run).iter().zip(reference).map(|(h, r)| wrap_pi(h - r.to_radians()).to_degrees()).collect();
                series.push(Series { name: label.clone(), points: scatter_points(t, &e), dots: true });
                heading_errors.push((format!("{label} − GPS course (run)"), e));
            }
            page.figure(try_line_plot("Heading − GPS course at the surface (run)", "time, s", "heading − reference, °", &series, None, None), "Each calibration's true heading against the GPS course while surfaced.")?;
        }
        _ => page.missing("heading at the surface", "no run with a reference heading (ref_heading_deg) and a calibration"),
    }
    match (&inputs.validation, &cx.validation_errors) {
        (Some(v), Some(errors)) => {
            let t: Vec<f64> = v.recording.t_s.clone().unwrap_or_else(|| (0..v.recording.len()).map(|i| i as f64).collect());
            let mut series = Vec::new();
            if let Some(b) = &errors.before {
                series.push(Series { name: "before (the board's previous coefficients)".into(), points: scatter_points(&t, b), dots: true });
                heading_errors.push(("before − truth (validation)".into(), b.clone()));
            }
            series.push(Series { name: "after (final calibration)".into(), points: scatter_points(&t, &errors.after), dots: true });
            heading_errors.push(("after − truth (validation)".into(), errors.after.clone()));
            page.figure(try_line_plot("Heading − truth on the validation run", if v.recording.t_s.is_some() { "time, s" } else { "row" }, "heading − truth, °", &series, None, None), "The validation run is on other courses than the calibration.")?;
        }
        _ => page.missing("heading against truth", "no validation run with a truth heading"),
    }
    page.end();
    Ok(heading_errors)
}

/// Section 6, the back-stepping trace of the last document that carries one: its
/// table and what each correction leaves.
pub(crate) fn backstep(page: &mut Page, cx: &Context<'_>) -> Result<(), ReportError> {
    page.h2("backstep", "Back-stepping trace");
    match cx.inputs.cals.iter().rev().find_map(|(l, d)| d.trace.as_ref().map(|t| (l, t))) {
        Some((label, trace)) if !trace.is_empty() => {
            page.p(&format!("From the document <em>{}</em>: each correction and what the run shows after it.", escape(label)));
            trace_table(&mut page.body, trace);
            let idx = |f: fn(&TraceEntry) -> f64| trace.iter().map(|e| (f64::from(e.iteration), f(e))).collect::<Vec<_>>();
            // Markers, not lines: the joint solver's trace has only its start and end.
            let series = [Series { name: "|step at turnaround|".into(), points: idx(|e| e.stats.step_nt.abs()), dots: true }, Series { name: "|F| − IGRF RMS".into(), points: idx(|e| e.stats.f_error_rms_nt), dots: true }];
            let last = trace.iter().map(|e| e.iteration).max().unwrap_or(0);
            // Round iteration numbers, a dozen at most (a paper trace has ~100 entries).
            let ticks = integer_ticks(u32::from(last), 12);
            page.figure(plot::try_line_plot_ticks("Back-stepping: what each correction leaves", "iteration (0 = the input coefficients)", "nT", &series, Some((-0.2, f64::from(last) + 0.2)), None, Some(&ticks)), "The step in |H| at the turnaround and the RMS of |F| − IGRF after each entry of the trace.")?;
        }
        _ => page.missing("backstep", "no calibration document carries a back-stepping trace"),
    }
    page.end();
    Ok(())
}

fn trace_table(out: &mut String, trace: &[TraceEntry]) {
    out.push_str("<table><tr><th>#</th><th class=\"l\">correction</th><th>step at turnaround, nT</th><th>|F| − IGRF RMS, nT</th><th>Hh, nT</th><th>Hz, nT</th><th>bias x, y, z (raw)</th></tr>\n");
    for e in trace {
        let bias = e.bias.map(|b| format!("{:.1}, {:.1}, {:.1}", b[0], b[1], b[2])).unwrap_or_default();
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td class=\"l\">{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.0}</td><td>{:.0}</td><td>{bias}</td></tr>",
            e.iteration,
            e.correction.label(),
            e.stats.step_nt,
            e.stats.f_error_rms_nt,
            e.stats.hh_nt,
            e.stats.hz_nt
        );
    }
    out.push_str("</table>\n");
}

/// Section 7, the residual distributions: |F| − reference on the run, heading errors.
pub(crate) fn residuals(page: &mut Page, cx: &Context<'_>, field_errors: &Errors, heading_errors: &Errors) -> Result<(), ReportError> {
    page.h2("residuals", "Residual distributions");
    if field_errors.is_empty() {
        page.missing("field residuals", "no run and reference field");
    } else {
        let span = field_errors.last().map(|(_, e)| percentile_abs(e, 0.99)).unwrap_or(10.0).max(5.0) * 1.5;
        page.figure(try_histogram("|H| − reference field on the run", "|H| − IGRF, nT", field_errors, (-span, span), 40), "Each calibration's field magnitude error over the run; the axis spans 1.5 × the final calibration's 99th percentile.")?;
    }
    if heading_errors.is_empty() {
        page.missing("heading residuals", "no heading reference or truth");
    } else {
        let final_label = cx.inputs.cals.last().map(|c| c.0.as_str()).unwrap_or("\u{0}");
        let chosen: Errors = heading_errors.iter().filter(|(n, _)| n.contains("validation") || n.starts_with(final_label)).cloned().collect();
        let span = chosen.iter().map(|(_, e)| percentile_abs(e, 0.99)).fold(0.5, f64::max).min(180.0) * 1.2;
        page.figure(try_histogram("Heading errors", "heading − reference, °", &chosen, (-span, span), 40), "The final calibration against the GPS course (run) and, on validation, before and after against the truth.")?;
    }
    page.end();
    Ok(())
}

/// The `q`-quantile of |e| over the finite values (0 when none).
fn percentile_abs(e: &[f64], q: f64) -> f64 {
    let mut a: Vec<f64> = e.iter().filter(|v| v.is_finite()).map(|v| v.abs()).collect();
    calib_core::series::quantile(&mut a, q).unwrap_or(0.0)
}

/// Section 8, the calibrations' coefficients side by side.
pub(crate) fn coefficients(page: &mut Page, cx: &Context<'_>) {
    page.h2("coefficients", "Calibrations");
    if cx.inputs.cals.is_empty() {
        page.missing("coefficients", "no calibration document");
    } else {
        page.body.push_str("<table><tr><th class=\"l\">calibration</th><th class=\"l\">model</th><th>bias x, y, z (raw)</th><th>matrix diagonal, nT/raw</th><th>field, nT</th><th>declination, °</th><th class=\"l\">swing A…E</th><th>predicted heading RMS, °</th></tr>\n");
        for (label, doc) in &cx.inputs.cals {
            let swing = doc.swing.map(|s| format!("{:.4}, {:.4}, {:.4}, {:.4}, {:.4}", s.a, s.b, s.c, s.d, s.e)).unwrap_or_else(|| "—".into());
            let _ = writeln!(
                page.body,
                "<tr><td class=\"l\">{}</td><td class=\"l\">{}</td><td>{:.1}, {:.1}, {:.1}</td><td>{:.4}, {:.4}, {:.4}</td><td>{:.0}</td><td>{}</td><td class=\"l\">{swing}</td><td>{}</td></tr>",
                escape(label),
                doc.model.name(),
                doc.bias[0],
                doc.bias[1],
                doc.bias[2],
                doc.matrix[0][0],
                doc.matrix[1][1],
                doc.matrix[2][2],
                doc.field_nt,
                doc.declination_deg.map(|d| format!("{d:.2}")).unwrap_or_else(|| "—".into()),
                fmt_opt(doc.quality.predicted_heading_rms_deg, 2, "")
            );
        }
        page.body.push_str("</table>\n");
    }
    page.end();
}

/// The colour of each integrity state in the figure (ok green, disturbed
/// orange, calibration invalid red, no attitude grey, unjudged purple), in
/// [`IntegrityState::ALL`]'s order.
pub(crate) fn state_colour(state: IntegrityState) -> plotters::style::RGBColor {
    match state {
        IntegrityState::Ok => plot::color(2),
        IntegrityState::Disturbed => plot::color(3),
        IntegrityState::CalInvalid => plot::color(1),
        IntegrityState::NoAttitude => plot::color(7),
        IntegrityState::Unjudged => plot::color(4),
    }
}

/// Section 5 (continued), the integrity along the validation run: the recording through
/// `magcal apply` with the final calibration (the board's own per-sample
/// code), the heading error against the truth coloured by state over the
/// predicted ±1σ, and a table of rows per state, the σ's honesty on the ok
/// rows and the longest disturbance.
pub(crate) fn integrity(page: &mut Page, cx: &Context<'_>) -> Result<(), ReportError> {
    page.h2("integrity", "Integrity along the validation run");
    let (Some(v), Some(doc)) = (&cx.inputs.validation, cx.final_doc) else {
        page.missing("integrity", "no validation run and final calibration to apply");
        page.end();
        return Ok(());
    };
    let applied = match apply_recording(v.recording, doc, &ApplyOptions::default()) {
        Ok(a) => a,
        Err(e) => {
            page.missing("integrity", &format!("the final calibration could not be applied to the validation run: {e}"));
            page.end();
            return Ok(());
        }
    };
    // The truth, else the recording's own reference heading.
    let reference: Option<(&str, &[f64])> = if v.truth_deg.iter().any(|t| t.is_finite()) {
        Some(("truth", v.truth_deg))
    } else {
        v.recording.ref_heading_deg.as_deref().filter(|r| r.iter().any(|t| t.is_finite())).map(|r| ("ref_heading_deg", r))
    };
    let summary = summarize(&applied, reference);
    page.p(&format!(
        "The validation recording run through <code>magcal apply</code> with the final calibration: the board's own per-sample integrity (field magnitude and dip against the calibration's reference, the field's rotation against the gyro, hysteresis), {} rows.",
        summary.rows
    ));
    integrity_table(&mut page.body, &summary);
    if let Some((name, values)) = reference {
        match gate_curve(v.recording, doc, &ApplyOptions::default(), values, 5.0) {
            Ok(points) => {
                page.p(&format!(
                    "How the gates separate good headings from bad on this run (against {name}, one constant offset removed; bad: off by more than 5°, good: within {GOOD_DEG}°), with every gate scaled; × 1 is what the board runs."
                ));
                gate_curve_table(&mut page.body, &points);
            }
            Err(e) => page.missing("integrity curve", &format!("the gates could not be varied: {e}")),
        }
    }
    match reference {
        Some((name, values)) => {
            let t: Vec<f64> = v.recording.t_s.clone().unwrap_or_else(|| (0..v.recording.len()).map(|i| i as f64).collect());
            let errors = heading_errors_deg(&applied, values);
            let series: Vec<Series> = IntegrityState::ALL
                .iter()
                .map(|&state| {
                    let e: Vec<f64> = errors.iter().zip(&applied.rows).map(|(e, r)| e.filter(|_| r.integrity == state).unwrap_or(f64::NAN)).collect();
                    Series { name: state.name().into(), points: scatter_points(&t, &e), dots: true }
                })
                .filter(|s| !s.points.is_empty())
                .collect();
            let colours: Vec<_> = IntegrityState::ALL.iter().filter(|&&st| applied.rows.iter().zip(&errors).any(|(r, e)| r.integrity == st && e.is_some())).map(|&st| state_colour(st)).collect();
            let band: Vec<(f64, f64)> = thin(applied.rows.len().min(t.len()), LINE_POINTS).filter_map(|i| applied.rows[i].heading_sigma_deg.map(|s| (t[i], s))).collect();
            let x_label = if v.recording.t_s.is_some() { "time, s" } else { "row" };
            page.figure(
                plot::try_band_plot("Heading error by integrity state (validation run)", x_label, &format!("heading − {name}, °"), "±1σ predicted", &band, &series, &colours, 180.0),
                "Each row's heading error coloured by the state the board would have given it; the band is the σ it would have streamed. Rows off the band should not be ok.",
            )?;
        }
        None => page.missing("integrity figure", "the validation run has no truth or reference heading to measure the error against"),
    }
    page.end();
    Ok(())
}

/// The curve over the gates ([`gate_curve`]): per scale factor, the
/// share of bad rows flagged, of good rows kept `ok`, of all rows `ok`, and
/// the RMS on the `ok` rows; the board's point in bold.
fn gate_curve_table(out: &mut String, points: &[GatePoint]) {
    out.push_str("<table><tr><th class=\"l\">gates ×</th><th>bad rows (&gt; 5°)</th><th>flagged</th><th>good rows</th><th>good rows ok</th><th>all rows ok</th><th>ok rows RMS</th></tr>\n");
    for p in points {
        let s = &p.score;
        let pct = |f: f64| fmt_opt(Some(100.0 * f), 1, " %");
        let (b0, b1) = if p.gates_times == 1.0 { ("<b>", " (board)</b>") } else { ("", "") };
        let _ = writeln!(
            out,
            "<tr><td class=\"l\">{b0}{}{b1}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            p.gates_times,
            s.bad_rows,
            pct(s.bad_not_ok_fraction),
            s.good_rows,
            pct(s.good_ok_fraction),
            pct(s.ok_fraction),
            fmt_opt(Some(s.ok_rms_deg), 2, "°")
        );
    }
    out.push_str("</table>\n");
}

fn integrity_table(out: &mut String, s: &ApplySummary) {
    out.push_str("<div class=\"cols\"><table><tr><th class=\"l\">state</th><th>rows</th><th>share</th></tr>\n");
    for state in IntegrityState::ALL {
        let n = s.rows_per_state.get(state.name()).copied().unwrap_or(0);
        let share = if s.rows > 0 { 100.0 * n as f64 / s.rows as f64 } else { f64::NAN };
        let _ = writeln!(out, "<tr><td class=\"l\">{}</td><td>{n}</td><td>{}</td></tr>", state.name(), fmt_opt(Some(share), 1, " %"));
    }
    out.push_str("</table><table>\n");
    let ratio = match (s.heading_rms_ok_deg, s.predicted_sigma_ok_deg) {
        (Some(o), Some(p)) if p > 0.0 => Some(o / p),
        _ => None,
    };
    let rows = [
        ("Heading RMS on ok rows, observed", fmt_opt(s.heading_rms_ok_deg, 2, "°")),
        ("Predicted σ on ok rows (RMS)", fmt_opt(s.predicted_sigma_ok_deg, 2, "°")),
        ("Observed ÷ predicted (0.5–2: honest)", fmt_opt(ratio, 2, "")),
        ("Longest disturbance", fmt_opt(Some(s.longest_disturbance_s), 1, " s")),
        ("On-line hard iron applied at the end", if s.hard_iron_applied { "<span class=\"bad\">yes</span>".into() } else { "no".to_string() }),
    ];
    for (k, v) in rows {
        let _ = writeln!(out, "<tr><th class=\"l\">{k}</th><td>{v}</td></tr>");
    }
    out.push_str("</table></div>\n");
}
