//! The calibration report: one self-contained HTML page (SVG figures and CSS
//! inline, no external fetches, a print stylesheet) that an engineer hands
//! to a colleague, and the deviation card beside it (text, CSV, JSON).
//!
//! Sections, each saying so when its input is missing:
//! 1. the headline — true-heading RMS before/after on the validation run,
//!    the predicted heading error, coefficients verified, date, site, IGRF;
//! 2. the deviation card of the validation run (against truth), else of the
//!    run (against its GPS reference);
//! 3. the swing test's coverage: heading × roll and heading × pitch maps
//!    with the gaps marked (paper 000 Fig 6);
//! 4. the field magnitude along the run for each calibration (Figs 7–12);
//! 5. heading against the reference at the surface (Fig 13) and against the
//!    truth in validation;
//! 6. the back-stepping trace;
//! 7. residual distributions (|F| − IGRF, heading errors);
//! 8. the coefficients.
//!
//! Figures are drawn by [`plot`] (plotters' SVG backend).

pub mod plot;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use calib_core::heading::wrap_pi;
use serde::{Deserialize, Serialize};

use crate::compute::card::{deviation_card, CardError, DeviationCard};
use crate::compute::magnetic_headings;
use crate::compute::truth::{calibrated_fields_nt, heading_rms_deg, true_headings_rad};
use crate::data::caldoc::CalDoc;
use crate::data::recording::Recording;
use crate::data::results::{SessionSettings, SessionSummary};
use crate::geomag::Site;
use crate::procedure::{PITCH_GATE_DEG, ROLL_GATE_DEG};

pub use plot::{line_plot, Series};
use plot::{try_coverage_map, try_histogram, try_line_plot, CoverageGrid, PlotError};

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Writing failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A recording lacks what a figure needs.
    #[error("{0}")]
    Data(String),
    /// A figure could not be drawn.
    #[error("{0}")]
    Plot(#[from] PlotError),
    /// The deviation card could not be written.
    #[error("deviation card: {0}")]
    Card(#[from] CardError),
}

/// A validation run: a recording and the true heading of each row.
pub struct Validation<'a> {
    /// The recording (mx, my, mz, roll_deg, pitch_deg, …).
    pub recording: &'a Recording,
    /// The true heading of each row, degrees from true north (NaN: unknown).
    pub truth_deg: &'a [f64],
}

/// What to put in a report. Every part is optional: a section whose input
/// is missing says so.
pub struct ReportInputs<'a> {
    /// The out-and-back run (field and surface-heading figures).
    pub run: Option<&'a Recording>,
    /// The swing test (coverage maps).
    pub swing: Option<&'a Recording>,
    /// The validation run with its truth (headline, card, heading vs truth).
    pub validation: Option<Validation<'a>>,
    /// Calibrations to compare, with their labels, in the order they were
    /// made: the last is the one reported on (the card, the headline).
    pub cals: Vec<(String, &'a CalDoc)>,
    /// The coefficients the board had before the session (the "before" of
    /// the validation run); without, the card's raw heading.
    pub before: Option<&'a CalDoc>,
    /// Reference intensity for the field figure, nT (else the site's IGRF).
    pub field_nt: Option<f64>,
    /// Where and when (date, IGRF).
    pub site: Option<Site>,
    /// The session's summary (verified upload, the board's own validation numbers).
    pub summary: Option<&'a SessionSummary>,
    /// The session's settings (vehicle, firmware).
    pub settings: Option<&'a SessionSettings>,
}

/// The files of the deviation card.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CardFiles {
    /// `magcal card`'s text table.
    pub text: PathBuf,
    /// `magcal card --csv`.
    pub csv: PathBuf,
    /// `magcal card --json`.
    pub json: PathBuf,
    /// What the card compares with: `truth (validation run)` or `GPS course (run)`.
    pub against: String,
}

/// What [`write_report`] wrote.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WrittenReport {
    /// The page.
    pub index: PathBuf,
    /// The deviation card, when the inputs allow one.
    pub card: Option<CardFiles>,
    /// Figures drawn.
    pub figures: usize,
    /// Sections left without their input, with the reason.
    pub missing: Vec<String>,
}

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
    move |source| ReportError::Io { path: path.into(), source }
}

/// Points a line keeps (every k-th row): enough for the eye at the page's
/// 900 px, few enough that the page renders quickly.
const LINE_POINTS: usize = 2000;
/// Dots a scatter series keeps (each is an SVG element).
const SCATTER_POINTS: usize = 700;

/// At most about `n` indices spread over `0..len`.
fn thin(len: usize, n: usize) -> impl Iterator<Item = usize> {
    (0..len).step_by(len.div_ceil(n.max(1)).max(1))
}

fn fmt_opt(v: Option<f64>, prec: usize, unit: &str) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.prec$}{unit}"),
        _ => "not available".into(),
    }
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

/// The page being built: sections, figures counted, missing parts noted.
struct Page {
    body: String,
    figures: usize,
    missing: Vec<String>,
}

impl Page {
    fn h2(&mut self, id: &str, title: &str) {
        let _ = writeln!(self.body, "<section id=\"{id}\"><h2>{}</h2>", escape(title));
    }
    fn end(&mut self) {
        self.body.push_str("</section>\n");
    }
    fn figure(&mut self, svg: Result<String, PlotError>, caption: &str) -> Result<(), ReportError> {
        let svg = svg?;
        let _ = writeln!(self.body, "<figure>{svg}<figcaption>{}</figcaption></figure>", escape(caption));
        self.figures += 1;
        Ok(())
    }
    fn missing(&mut self, section: &str, why: &str) {
        let _ = writeln!(self.body, "<p class=\"missing\">Not available: {}</p>", escape(why));
        self.missing.push(format!("{section}: {why}"));
    }
    fn p(&mut self, html: &str) {
        let _ = writeln!(self.body, "<p>{html}</p>");
    }
}

const CSS: &str = r#"
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;max-width:960px;margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;border-bottom:2px solid #1f77b4;padding-bottom:.15em;margin-top:1.6em}
.sub{color:#555;margin-top:0}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#eef3f8}td.l,th.l{text-align:left}
.headline td{font-size:1.05em}.headline td.big{font-weight:bold;font-size:1.2em}
figure{margin:.8em 0;page-break-inside:avoid;break-inside:avoid}figure svg{width:100%;height:auto;display:block}
figcaption{font-size:.88em;color:#444;margin-top:.2em}
.missing{color:#8a5300;background:#fff6e5;border-left:4px solid #e0a030;padding:.3em .6em}
.ok{color:#176d17;font-weight:bold}.bad{color:#b00;font-weight:bold}
.cols{display:flex;gap:1.5em;flex-wrap:wrap}
@media print{body{max-width:none;margin:0;font-size:10.5pt}h2{page-break-after:avoid;break-after:avoid}section{page-break-inside:auto}a{color:inherit;text-decoration:none}}
@page{size:A4;margin:14mm}
"#;

/// Writes `index.html` (self-contained) into `dir` and, when the inputs
/// allow, the deviation card as `deviation_card.txt`, `.csv` and `.json`.
pub fn write_report(dir: &Path, inputs: &ReportInputs<'_>) -> Result<WrittenReport, ReportError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let mut page = Page { body: String::new(), figures: 0, missing: Vec::new() };
    let final_doc = inputs.cals.last().map(|(_, d)| *d);
    let igrf = inputs.site.as_ref().and_then(|s| s.field().ok());
    let field_nt = inputs.field_nt.or(igrf.as_ref().map(|f| f.total_nt())).or(final_doc.map(|d| d.field_nt));

    // Heading errors on the validation run (heading − truth, degrees).
    let validation_errors = match (&inputs.validation, final_doc) {
        (Some(v), Some(doc)) => {
            if v.truth_deg.len() != v.recording.len() {
                return Err(ReportError::Data(format!("the validation truth has {} rows, the recording {}", v.truth_deg.len(), v.recording.len())));
            }
            let err = |h: Vec<f64>| h.iter().zip(v.truth_deg).map(|(h, t)| wrap_pi(h - t.to_radians()).to_degrees()).collect::<Vec<f64>>();
            let after = err(true_headings_rad(doc, v.recording));
            let before = inputs.before.map(|b| err(true_headings_rad(b, v.recording)));
            Some((before, after))
        }
        _ => None,
    };

    // 1. Headline.
    page.h2("headline", "Headline");
    let rms = |e: &[f64]| heading_rms_deg(e.iter().map(|d| (d.to_radians(), 0.0))).rms;
    let (before_rms, after_rms, source) = match (inputs.summary.and_then(|s| s.validation), &validation_errors) {
        (Some(v), _) => (Some(v.heading_rms_deg_before), Some(v.heading_rms_deg_after), "the board's own headings against the truth (session summary)"),
        (None, Some((b, a))) => (b.as_deref().map(rms), Some(rms(a)), "the final calibration applied to the validation recording"),
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
    row("True-heading RMS on validation, before → after", format!("{} → {}", fmt_opt(before_rms, 2, "°"), fmt_opt(after_rms, 2, "°")));
    row("Predicted heading error (the fit's uncertainty and the heading noise)", fmt_opt(predicted, 2, "° RMS"));
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
        None => row("Date, site", "not available (no site given)".into()),
    }
    if let Some(st) = inputs.settings {
        row("Vehicle, firmware", format!("{}, firmware {}", escape(&st.vehicle), escape(&st.firmware)));
    }
    match &igrf {
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

    // 2. Deviation card.
    page.h2("card", "Deviation card");
    let mut card_files = None;
    let card_input = match (&inputs.validation, inputs.run) {
        (Some(v), _) => {
            let mut rec = v.recording.clone();
            rec.ref_heading_deg = Some(v.truth_deg.to_vec());
            Some((rec, "truth (validation run)"))
        }
        (None, Some(run)) if run.ref_heading_deg.is_some() => Some((run.clone(), "GPS course (run, at the surface)")),
        _ => None,
    };
    match (card_input, final_doc) {
        (Some((rec, against)), Some(doc)) => {
            match deviation_card(&rec, doc, 15.0, 16) {
                Ok(card) => card_section(&mut page, dir, &card, against, &mut card_files)?,
                Err(e) => page.missing("card", &format!("the card could not be made against the {against}: {e}")),
            }
        }
        (_, None) => page.missing("card", "no calibration document"),
        (None, _) => page.missing("card", "no validation run with a truth column and no run with a reference heading"),
    }
    page.end();

    // 3. Swing coverage.
    page.h2("coverage", "Swing test coverage (paper 000 Fig 6)");
    match (inputs.swing, final_doc) {
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

    // 4. Field magnitude along the run; 5. headings.
    page.h2("field", "Field magnitude along the run (paper 000 Figs 7–12)");
    let run_t = inputs.run.and_then(|r| r.t_s.as_ref());
    let mut field_errors: Vec<(String, Vec<f64>)> = Vec::new();
    match (inputs.run, run_t) {
        (Some(run), Some(t)) if !inputs.cals.is_empty() => {
            let mut series = Vec::new();
            for (label, doc) in &inputs.cals {
                let f: Vec<f64> = calibrated_fields_nt(doc, run).iter().map(|h| (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()).collect();
                series.push(Series { name: label.clone(), points: thin(run.len(), LINE_POINTS).map(|i| (t[i], f[i])).collect(), dots: false });
                if let Some(r) = field_nt {
                    field_errors.push((label.clone(), f.iter().map(|v| v - r).collect()));
                }
            }
            if let (Some(f), Some(&t0), Some(&t1)) = (field_nt, t.first(), t.last()) {
                series.push(Series { name: format!("IGRF {f:.0} nT"), points: vec![(t0, f), (t1, f)], dots: false });
            }
            page.figure(try_line_plot("|H| along the out-and-back run", "time, s", "|H|, nT", &series, None, None), "The field magnitude with each calibration; the step at the turnaround is what back-stepping removes.")?;
        }
        (None, _) => page.missing("field", "no run recording"),
        (_, None) => page.missing("field", "the run has no `t` column"),
        _ => page.missing("field", "no calibration document"),
    }
    page.end();

    page.h2("heading", "Heading against the reference (paper 000 Fig 13) and the truth");
    let mut heading_errors: Vec<(String, Vec<f64>)> = Vec::new();
    match (inputs.run, run_t) {
        (Some(run), Some(t)) if run.ref_heading_deg.is_some() && !inputs.cals.is_empty() => {
            let reference = run.ref_heading_deg.as_deref().unwrap_or(&[]);
            let mut series = Vec::new();
            for (label, doc) in &inputs.cals {
                let e: Vec<f64> = true_headings_rad(doc, run).iter().zip(reference).map(|(h, r)| wrap_pi(h - r.to_radians()).to_degrees()).collect();
                let rows: Vec<usize> = (0..run.len()).filter(|&i| e[i].is_finite()).collect();
                let step = rows.len().div_ceil(SCATTER_POINTS).max(1);
                series.push(Series { name: label.clone(), points: rows.iter().step_by(step).map(|&i| (t[i], e[i])).collect(), dots: true });
                heading_errors.push((format!("{label} − GPS course (run)"), e));
            }
            page.figure(try_line_plot("Heading − GPS course at the surface (run)", "time, s", "heading − reference, °", &series, None, None), "Each calibration's true heading against the GPS course while surfaced.")?;
        }
        _ => page.missing("heading at the surface", "no run with a reference heading (ref_heading_deg) and a calibration"),
    }
    match (&inputs.validation, &validation_errors) {
        (Some(v), Some((before, after))) => {
            let t: Vec<f64> = v.recording.t_s.clone().unwrap_or_else(|| (0..v.recording.len()).map(|i| i as f64).collect());
            let pts = |e: &[f64]| -> Vec<(f64, f64)> {
                let rows: Vec<usize> = (0..e.len()).filter(|&i| e[i].is_finite()).collect();
                let step = rows.len().div_ceil(SCATTER_POINTS).max(1);
                rows.iter().step_by(step).map(|&i| (t[i], e[i])).collect()
            };
            let mut series = Vec::new();
            if let Some(b) = before {
                series.push(Series { name: "before (the board's previous coefficients)".into(), points: pts(b), dots: true });
                heading_errors.push(("before − truth (validation)".into(), b.clone()));
            }
            series.push(Series { name: "after (final calibration)".into(), points: pts(after), dots: true });
            heading_errors.push(("after − truth (validation)".into(), after.clone()));
            page.figure(try_line_plot("Heading − truth on the validation run", if v.recording.t_s.is_some() { "time, s" } else { "row" }, "heading − truth, °", &series, None, None), "The validation run is on other courses than the calibration.")?;
        }
        _ => page.missing("heading against truth", "no validation run with a truth heading"),
    }
    page.end();

    // 6. Back-stepping trace.
    page.h2("backstep", "Back-stepping trace");
    match inputs.cals.iter().rev().find_map(|(l, d)| d.trace.as_ref().map(|t| (l, t))) {
        Some((label, trace)) if !trace.is_empty() => {
            page.p(&format!("From the document <em>{}</em>: each correction and what the run shows after it.", escape(label)));
            page.body.push_str("<table><tr><th>#</th><th class=\"l\">correction</th><th>step at turnaround, nT</th><th>|F| − IGRF RMS, nT</th><th>Hh, nT</th><th>Hz, nT</th><th>bias x, y, z (raw)</th></tr>\n");
            for e in trace {
                let bias = e.bias.map(|b| format!("{:.1}, {:.1}, {:.1}", b[0], b[1], b[2])).unwrap_or_default();
                let _ = writeln!(
                    page.body,
                    "<tr><td>{}</td><td class=\"l\">{}</td><td>{:.1}</td><td>{:.1}</td><td>{:.0}</td><td>{:.0}</td><td>{bias}</td></tr>",
                    e.iteration,
                    e.correction.label(),
                    e.stats.step_nt,
                    e.stats.f_error_rms_nt,
                    e.stats.hh_nt,
                    e.stats.hz_nt
                );
            }
            page.body.push_str("</table>\n");
            let idx = |f: fn(&crate::data::results::TraceEntry) -> f64| trace.iter().map(|e| (f64::from(e.iteration), f(e))).collect::<Vec<_>>();
            // Markers, not lines: the joint solver's trace has only its start and end.
            let series = [Series { name: "|step at turnaround|".into(), points: idx(|e| e.stats.step_nt.abs()), dots: true }, Series { name: "|F| − IGRF RMS".into(), points: idx(|e| e.stats.f_error_rms_nt), dots: true }];
            let last = trace.iter().map(|e| e.iteration).max().unwrap_or(0);
            let ticks: Vec<f64> = (0..=last).map(f64::from).collect();
            page.figure(plot::try_line_plot_ticks("Back-stepping: what each correction leaves", "iteration (0 = the input coefficients)", "nT", &series, Some((-0.2, f64::from(last) + 0.2)), None, Some(&ticks)), "The step in |H| at the turnaround and the RMS of |F| − IGRF after each entry of the trace.")?;
        }
        _ => page.missing("backstep", "no calibration document carries a back-stepping trace"),
    }
    page.end();

    // 7. Residual distributions.
    page.h2("residuals", "Residual distributions");
    if field_errors.is_empty() {
        page.missing("field residuals", "no run and reference field");
    } else {
        let span = field_errors.last().map(|(_, e)| percentile_abs(e, 0.99)).unwrap_or(10.0).max(5.0) * 1.5;
        page.figure(try_histogram("|H| − reference field on the run", "|H| − IGRF, nT", &field_errors, (-span, span), 40), "Each calibration's field magnitude error over the run; the axis spans 1.5 × the final calibration's 99th percentile.")?;
    }
    if heading_errors.is_empty() {
        page.missing("heading residuals", "no heading reference or truth");
    } else {
        let chosen: Vec<(String, Vec<f64>)> = heading_errors.iter().filter(|(n, _)| n.contains("validation") || n.starts_with(inputs.cals.last().map(|c| c.0.as_str()).unwrap_or("\u{0}"))).cloned().collect();
        let span = chosen.iter().map(|(_, e)| percentile_abs(e, 0.99)).fold(0.5, f64::max).min(180.0) * 1.2;
        page.figure(try_histogram("Heading errors", "heading − reference, °", &chosen, (-span, span), 40), "The final calibration against the GPS course (run) and, on validation, before and after against the truth.")?;
    }
    page.end();

    // 8. Coefficients.
    page.h2("coefficients", "Calibrations");
    if inputs.cals.is_empty() {
        page.missing("coefficients", "no calibration document");
    } else {
        page.body.push_str("<table><tr><th class=\"l\">calibration</th><th class=\"l\">model</th><th>bias x, y, z (raw)</th><th>matrix diagonal, nT/raw</th><th>field, nT</th><th>declination, °</th><th class=\"l\">swing A…E</th><th>predicted heading RMS, °</th></tr>\n");
        for (label, doc) in &inputs.cals {
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

    let title = match &inputs.site {
        Some(s) => format!("Magnetometer calibration report — {}", date_of_decimal_year(s.decimal_year)),
        None => "Magnetometer calibration report".into(),
    };
    let nav = "<p class=\"sub\">magcal · <a href=\"#headline\">headline</a> · <a href=\"#card\">deviation card</a> · <a href=\"#coverage\">coverage</a> · <a href=\"#field\">field</a> · <a href=\"#heading\">heading</a> · <a href=\"#backstep\">back-stepping</a> · <a href=\"#residuals\">residuals</a> · <a href=\"#coefficients\">coefficients</a></p>";
    let html = format!(
        "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><link rel=\"icon\" href=\"data:,\"><title>{t}</title><style>{CSS}</style></head>\n<body><h1>{t}</h1>{nav}\n{}</body></html>\n",
        page.body,
        t = escape(&title)
    );
    let index = dir.join("index.html");
    std::fs::write(&index, html).map_err(io(&index))?;
    Ok(WrittenReport { index, card: card_files, figures: page.figures, missing: page.missing })
}

/// The card's section: table, figure, and its files written beside the page.
fn card_section(page: &mut Page, dir: &Path, card: &DeviationCard, against: &str, files: &mut Option<CardFiles>) -> Result<(), ReportError> {
    *files = Some(write_card(dir, card, against)?);
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
    )
}

/// The `q`-quantile of |e| over the finite values (0 when none).
fn percentile_abs(e: &[f64], q: f64) -> f64 {
    let mut a: Vec<f64> = e.iter().filter(|v| v.is_finite()).map(|v| v.abs()).collect();
    if a.is_empty() {
        return 0.0;
    }
    a.sort_by(f64::total_cmp);
    a[((a.len() - 1) as f64 * q).round() as usize]
}

/// Writes the card as `deviation_card.txt`, `.csv` and `.json` in `dir`.
pub fn write_card(dir: &Path, card: &DeviationCard, against: &str) -> Result<CardFiles, ReportError> {
    let text = dir.join("deviation_card.txt");
    std::fs::write(&text, format!("Deviation card against the {against}\n{}", card.to_text())).map_err(io(&text))?;
    let csv = dir.join("deviation_card.csv");
    card.write_csv(&csv)?;
    let json = dir.join("deviation_card.json");
    let body = serde_json::to_string_pretty(card).map_err(|e| ReportError::Data(e.to_string()))?;
    std::fs::write(&json, body).map_err(io(&json))?;
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

#[cfg(test)]
mod tests;
