//! The calibration session: the paper's field procedure driven over the
//! serial link, one [`run`] for any [`Vehicle`].
//!
//! 1. **Swing test** — the vehicle is turned (by a diver) while the board
//!    streams raw samples and runs its on-board fit; the session tracks the
//!    attitudes and field directions covered and says what is missing
//!    ([`coverage`]).
//! 2. **Out-and-back run** — recorded the same way, with the GPS course.
//! 3. **Computation** on the host: [`crate::compute::chain`].
//! 4. **Upload** ([`upload`]): unlock, stage, commit, read back and compare —
//!    resumed over a reconnect if the link drops; the board never runs
//!    unverified coefficients (it only switches after a CRC-checked commit).
//! 5. **Validation** (when the vehicle knows its heading): a run on other
//!    courses with the board's own headings compared with the truth.
//!
//! Everything is saved in a directory (recordings, settings, calibrations,
//! report, summary) so `magcal fit/backstep/swing` reproduce the numbers
//! offline. Recording ([`record`]) reopens the link when it drops and keeps
//! the lost steps as rows without a field. The vehicle is a [`Vehicle`]: a
//! real one ([`NavVehicle`]) or the simulator's (in the `magcal-sim` crate,
//! which this module does not know).

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use magcal_protocol::{FitReport, Sample, StreamMode};

use crate::board::coefficients::{doc_from_coefficients, to_coefficients};
use crate::board::{BoardClient, ClientError};
use crate::compute::{self, truth, Chain, ChainOptions, ComputeError, FirstStep};
use crate::compute::apply::{apply_recording, ApplyOptions};
use crate::doc::results::{OnboardFitSummary, RecalibrateEvidence, SessionSettings, SessionSummary, ValidationMetrics};
use crate::doc::CalDoc;
pub use crate::doc::integrity::{recalibrate_evidence, recalibrate_text, RECALIBRATE_CAL_INVALID_FRACTION};
use crate::geomag::Site;

pub(crate) mod coverage;
pub(crate) mod error;
pub(crate) mod progress;
pub(crate) mod record;
pub(crate) mod upload;
pub(crate) mod vehicle;

pub use error::SessionError;
pub use coverage::{SwingCoverage, SwingTracker, PITCH_GATE_DEG, ROLL_GATE_DEG};
pub use progress::{Progress, Working};
pub use record::{record, Recorded};
pub use crate::board::reconnect::Resume;
pub use upload::upload_verified;
pub use vehicle::{NavStream, NavVehicle, Phase, Step, Vehicle};

/// The site and options of a session.
#[derive(Debug, Clone)]
pub struct SessionConfig {
    /// Where and when (the IGRF-14 reference).
    pub site: Site,
    /// Output directory.
    pub out_dir: PathBuf,
    /// Show progress bars (a terminal); otherwise plain progress lines.
    pub interactive: bool,
}

/// Link reconnections tried per drop while recording.
const RECONNECT_ATTEMPTS: u32 = 5;
/// Upload attempts (each on a fresh connection).
const UPLOAD_ATTEMPTS: u32 = 3;

/// The files a session writes into its folder (its report's go into
/// `report/`, [`crate::report::check_outputs`]).
pub const SESSION_FILES: [&str; 10] = [
    "swing.csv",
    "run.csv",
    "validation.csv",
    "validation_truth.csv",
    "cal_step1.json",
    "cal_backstep.json",
    "cal_final.json",
    "cal_before.json",
    "settings.json",
    "summary.json",
];

/// Checks the session's folder before the session (it takes the vehicle's
/// time, so nothing may fail for a file at its end): made when missing,
/// and each file the session and its report write checked by
/// [`crate::files::check_output`] against `inputs` (the navigation
/// streams: a stream in the folder under a session file's name would be
/// overwritten) — a directory, a read-only file, a folder that cannot be
/// written refused now.
pub fn check_outputs(out_dir: &Path, inputs: &[&Path]) -> Result<(), SessionError> {
    std::fs::create_dir_all(out_dir).map_err(|source| SessionError::File { path: out_dir.to_path_buf(), source })?;
    for name in SESSION_FILES {
        crate::files::check_output(&out_dir.join(name), inputs)?;
    }
    crate::report::check_outputs(&out_dir.join("report"), inputs)?;
    Ok(())
}

/// The whole session with `vehicle`, over links opened by `connect`:
/// swing test, out-and-back run, computation, verified upload and (when the
/// vehicle has one) a validation run. Writes everything into `cfg.out_dir`
/// and returns the summary.
pub fn run<P: Read + Write>(
    vehicle: &mut dyn Vehicle,
    connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>,
    cfg: &SessionConfig,
) -> Result<SessionSummary, SessionError> {
    check_outputs(&cfg.out_dir, &[])?;
    let field = cfg.site.field().map_err(ComputeError::from)?;
    let mut link = connect()?;
    let id = link.identify()?;
    eprintln!(
        "session: {} {} on {:?}; IGRF-14 here: F {:.0} nT, I {:.1}°, D {:.2}°",
        id.name,
        id.firmware_version,
        id.platform,
        field.total_nt(),
        field.inclination_deg(),
        field.declination_deg()
    );
    let (board_coefficients, _, _) = link.read_coefficients()?;
    let before = doc_from_coefficients(&board_coefficients);

    let (swing, fit) = swing_test(&mut link, vehicle, connect, cfg, field.total_nt(), &before)?;
    eprintln!("2/5 out-and-back run: dolphin profile, GPS at the surface");
    begin(vehicle, Phase::Run)?;
    prepare_board(&mut link, StreamMode::Raw, None)?;
    let attitude = vehicle.sends_attitude();
    let run = record_phase(&mut link, vehicle, Phase::Run, attitude, connect, cfg, |_, _, _, _| Ok("recording".into()))?;
    let chain = compute_chain(&swing, &run, cfg)?;

    // 4. Verified upload on fresh connections.
    eprintln!("4/5 uploading: unlock, stage, commit, read back");
    drop(link);
    let seq = upload_verified(&mut *connect, &to_coefficients(&chain.final_doc), UPLOAD_ATTEMPTS)?;
    eprintln!("  coefficients #{seq} stored and verified");

    let validation = validation_run(vehicle, connect, cfg, &before)?;
    let settings = session_settings(vehicle, cfg, &id.firmware_version);
    save_json(&cfg.out_dir, "settings.json", &settings)?;
    let onboard_fit = OnboardFitSummary { samples: fit.samples, coverage_pct: fit.coverage_pct, residual_rms_nt: fit.residual_rms_nt };
    let recalibrate = validation.as_ref().and_then(|(v, _)| validation_integrity(&v.recording, &chain.final_doc));
    let summary = session_summary(&chain, validation.as_ref().map(|(_, m)| *m), recalibrate, seq, onboard_fit, cfg)?;
    save_json(&cfg.out_dir, "summary.json", &summary)?;
    // The report comes after the summary: a report that cannot be drawn is
    // said, and does not undo a verified session.
    if let Err(e) = write_report(&chain, &swing, &run, validation.as_ref().map(|(v, _)| v), &before, &summary, &settings, cfg) {
        eprintln!("session: the report was not written: {e}");
    }
    Ok(summary)
}

/// Step 1, the swing test, with the on-board fit of the paper's axis model and
/// the coverage guidance; refused when the coverage is incomplete.
fn swing_test<P: Read + Write>(
    link: &mut BoardClient<P>,
    vehicle: &mut dyn Vehicle,
    connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>,
    cfg: &SessionConfig,
    field_nt: f64,
    before: &CalDoc,
) -> Result<(Recorded, FitReport), SessionError> {
    eprintln!("1/5 swing test: turn the vehicle through every heading, roll ±55°, pitch ±10° (thrusters off)");
    begin(vehicle, Phase::Swing)?;
    prepare_board(link, StreamMode::Raw, Some(field_nt as f32))?;
    let mut tracker = SwingTracker::new(before);
    let attitude = vehicle.sends_attitude();
    let swing = record_phase(link, vehicle, Phase::Swing, attitude, connect, cfg, |i, step, sample, link| tracker.step(i, step, sample, link))?;
    let fit = link.fit_stop()?;
    let guidance = tracker.coverage.guidance();
    if !guidance.is_empty() {
        return Err(SessionError::Coverage(guidance));
    }
    eprintln!(
        "  swing test complete: {} heading sectors, on-board fit {} samples, {}% of directions, {:.0} nT RMS",
        tracker.coverage.sectors_visited(),
        fit.samples,
        fit.coverage_pct,
        fit.residual_rms_nt
    );
    Ok((swing, fit))
}

/// Step 3, the calibration chain on the swing test and the run, its documents
/// saved beside the recordings.
fn compute_chain(swing: &Recorded, run: &Recorded, cfg: &SessionConfig) -> Result<Chain, SessionError> {
    eprintln!("3/5 computing: axis fit against IGRF, back-stepping, swing fit against the GPS course");
    // A swing test with a gyro starts with the gyro-aided fit, which needs
    // no full tumble; without, the paper's axis fit.
    let first_step = if swing.recording.gyro_rad_s().is_some_and(|g| g.iter().any(|w| w.iter().all(|v| v.is_finite()))) { FirstStep::Gyro } else { FirstStep::Axis };
    let chain = compute::calibrate(&swing.recording, &run.recording, &cfg.site, &ChainOptions { first_step, ..ChainOptions::default() })?;
    for (name, doc) in [("cal_step1.json", &chain.step1), ("cal_backstep.json", &chain.backstepped), ("cal_final.json", &chain.final_doc)] {
        doc.save(&cfg.out_dir.join(name))?;
    }
    let (b0, b1) = (&chain.backstep.before, &chain.backstep.after);
    eprintln!("  turnaround step {:.1} → {:.1} nT; |F| − IGRF {:.1} → {:.1} nT RMS", b0.step_nt, b1.step_nt, b0.f_error_rms_nt, b1.f_error_rms_nt);
    Ok(chain)
}

/// Step 5, the validation run with the board's own output, when the vehicle
/// knows its true heading.
fn validation_run<P: Read + Write>(
    vehicle: &mut dyn Vehicle,
    connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>,
    cfg: &SessionConfig,
    before: &CalDoc,
) -> Result<Option<(Recorded, ValidationMetrics)>, SessionError> {
    if !vehicle.begin(Phase::Validation)? {
        eprintln!("5/5 no validation run: the vehicle does not know its true heading");
        return Ok(None);
    }
    eprintln!("5/5 validation run on other courses, headings from the board");
    let mut link = connect()?;
    prepare_board(&mut link, StreamMode::Both, None)?;
    let val = record_phase(&mut link, vehicle, Phase::Validation, true, connect, cfg, |_, _, _, _| Ok("recording".into()))?;
    link.set_stream(StreamMode::Off)?;
    let metrics = validation_metrics(&val, before, &cfg.site);
    Ok(Some((val, metrics)))
}

/// The session's settings, with the commands that reproduce its numbers.
fn session_settings(vehicle: &dyn Vehicle, cfg: &SessionConfig, firmware: &str) -> SessionSettings {
    SessionSettings {
        lat_deg: cfg.site.lat_deg,
        lon_deg: cfg.site.lon_deg,
        decimal_year: cfg.site.decimal_year,
        vehicle: vehicle.describe(),
        firmware: firmware.to_string(),
        reproduce: vec![
            "magcal fit --input swing.csv --model axis --lat LAT --lon LON --date YEAR --out cal_step1.json".into(),
            "magcal backstep --input run.csv --cal cal_step1.json --swing-input swing.csv --lat LAT --lon LON --date YEAR --out cal_backstep.json".into(),
            "magcal swing --input run.csv --cal cal_backstep.json --estimate-delay --out cal_final.json".into(),
        ],
    }
}

/// The session's summary: the chain's reports, the upload, the validation
/// and how its heading error compares with the prediction.
fn session_summary(chain: &Chain, validation: Option<ValidationMetrics>, recalibrate: Option<RecalibrateEvidence>, seq: u32, onboard_fit: OnboardFitSummary, cfg: &SessionConfig) -> Result<SessionSummary, SessionError> {
    let validation = validation.filter(|v| v.validation_samples > 0);
    // The chain's prediction: the fit's covariance and the run's white
    // heading noise together, the same number the bench holds to 0.5–2×.
    let predicted_heading_rms_deg = chain.predicted_heading_rms_deg;
    let heading_rms_observed_over_predicted = match (validation, predicted_heading_rms_deg) {
        (Some(v), Some(p)) if p > 0.0 && v.heading_rms_deg_after.is_finite() => Some(v.heading_rms_deg_after / p),
        _ => None,
    };
    Ok(SessionSummary {
        validation,
        coefficients_verified: true,
        coefficient_seq: seq,
        onboard_fit,
        backstep: chain.backstepped.quality.backstep.clone().ok_or(SessionError::NoReport("back-stepping"))?,
        swing: chain.final_doc.quality.swing.clone().ok_or(SessionError::NoReport("swing fit"))?,
        predicted_heading_rms_deg,
        heading_rms_observed_over_predicted,
        recalibrate,
        session_dir: cfg.out_dir.clone(),
    })
}

/// What the session's "recalibrate" line calls its samples.
pub const VALIDATION_ROWS: &str = "validation rows";

/// The final calibration applied to the validation recording by the board's
/// own per-sample code, and what it says: `Some` evidence when it says
/// "recalibrate" (printed), `None` when the calibration fits or it could
/// not be applied (said).
fn validation_integrity(recording: &crate::data::Recording, final_doc: &CalDoc) -> Option<RecalibrateEvidence> {
    match apply_recording(recording, final_doc, &ApplyOptions::default()) {
        Ok(applied) => {
            let evidence = recalibrate_evidence(&applied.integrity_counts(), RECALIBRATE_CAL_INVALID_FRACTION);
            if let Some(e) = &evidence {
                eprintln!("session: {}", recalibrate_text(e, VALIDATION_ROWS));
            }
            evidence
        }
        Err(e) => {
            eprintln!("session: the validation run's integrity was not computed: {e}");
            None
        }
    }
}

fn begin(vehicle: &mut dyn Vehicle, phase: Phase) -> Result<(), SessionError> {
    if vehicle.begin(phase)? {
        Ok(())
    } else {
        Err(SessionError::NoManoeuvre(phase.label()))
    }
}

/// One recording phase with its progress display (`detail` gives the line
/// for each step), saved as `<phase>.csv` in the session directory whatever
/// happens next.
fn record_phase<P: Read + Write>(
    link: &mut BoardClient<P>,
    vehicle: &mut dyn Vehicle,
    phase: Phase,
    send_attitude: bool,
    connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>,
    cfg: &SessionConfig,
    mut detail: impl FnMut(usize, &Step, &Sample, &mut BoardClient<P>) -> Result<String, SessionError>,
) -> Result<Recorded, SessionError> {
    let label = phase.label();
    let mut progress = Progress::new(label, vehicle.len_hint().unwrap_or(0), cfg.interactive);
    let stream = if phase == Phase::Validation { StreamMode::Both } else { StreamMode::Raw };
    let resume = Resume { connect, stream, attempts: RECONNECT_ATTEMPTS };
    let recorded = record(link, vehicle, send_attitude, Some(resume), |i, step, sample, link| {
        let line = detail(i, step, sample, link)?;
        progress.update(i, &line);
        Ok(())
    })?;
    progress.finish();
    let path = cfg.out_dir.join(format!("{label}.csv"));
    recorded.recording.write(&path)?;
    Ok(recorded)
}

/// Starts the board's streaming for a recording phase; with `fit`, also the
/// on-board fit of the paper's axis model (what the swing test determines).
pub fn prepare_board<P: Read + Write>(link: &mut BoardClient<P>, stream: StreamMode, fit: Option<f32>) -> Result<(), SessionError> {
    link.set_output_rate(100)?;
    link.set_stream(stream)?;
    if let Some(f) = fit {
        link.fit_start(magcal_protocol::OnboardModel::Axis, f)?;
    }
    link.clear_samples();
    Ok(())
}

/// Heading and field errors of the board's own output on a validation run
/// against the vehicle's true heading (and its true local field, when the
/// vehicle knows it; else IGRF), and what the coefficients the board
/// had before the session would have given.
pub fn validation_metrics(val: &Recorded, before: &CalDoc, site: &Site) -> ValidationMetrics {
    let cal_before = before.calibration();
    let rec = &val.recording;
    let (roll, pitch) = (rec.roll_deg.as_deref().unwrap_or(&[]), rec.pitch_deg.as_deref().unwrap_or(&[]));
    let with_heading = || {
        val.samples.iter().zip(&val.true_heading_deg).enumerate().filter_map(|(i, (s, t))| match (s.heading_rad, s.raw) {
            (Some(h), Some(raw)) => Some((i, h, raw, *t)),
            _ => None,
        })
    };
    let before_rms = truth::heading_rms_deg(with_heading().map(|(i, _, raw, t)| {
        let (r, p) = (roll.get(i).copied().unwrap_or(f64::NAN), pitch.get(i).copied().unwrap_or(f64::NAN));
        (cal_before.apply(raw.map(f64::from), r.to_radians(), p.to_radians()).true_heading_rad, t)
    }));
    let after_rms = truth::heading_rms_deg(with_heading().map(|(_, h, _, t)| (f64::from(h), t)));
    let fields = || val.samples.iter().enumerate().filter_map(|(i, s)| s.field_nt.map(|f| (f.map(f64::from), i)));
    // Against the true local field where the vehicle knows it, else IGRF.
    let field_against_truth = val.true_field_nt.iter().any(|f| f.is_finite());
    let field = if field_against_truth {
        truth::field_rms_against_nt(fields().map(|(f, i)| (f, val.true_field_nt.get(i).copied().unwrap_or(f64::NAN))))
    } else {
        truth::field_rms_nt(fields(), rec, site)
    };
    ValidationMetrics {
        heading_rms_deg_before: before_rms.rms,
        heading_rms_deg_after: after_rms.rms,
        field_error_nt_after: field.rms,
        field_against_truth,
        validation_samples: after_rms.samples,
    }
}

/// The session's report (`report/index.html`) and the deviation card of
/// the validation run against the truth (`report/deviation_card.{txt,csv,json}`);
/// saves the validation run's truth beside it (`validation_truth.csv`, the
/// `true_heading_deg` column `magcal report --session` reads) and the
/// board's coefficients before the session (`cal_before.json`).
#[allow(clippy::too_many_arguments)]
fn write_report(chain: &Chain, swing: &Recorded, run: &Recorded, validation: Option<&Recorded>, before: &CalDoc, summary: &SessionSummary, settings: &SessionSettings, cfg: &SessionConfig) -> Result<crate::report::WrittenReport, SessionError> {
    // As the board had them, unchecked (a factory set may not pass as a
    // calibration; `magcal report --session` then leaves it out).
    save_json(&cfg.out_dir, "cal_before.json", before)?;
    if let Some(v) = validation {
        v.recording.write_with_extra(&cfg.out_dir.join("validation_truth.csv"), &[("true_heading_deg", &v.true_heading_deg)])?;
    }
    let cals: Vec<(String, &CalDoc)> = vec![("step 1 (swing-test fit)".into(), &chain.step1), ("back-stepped".into(), &chain.backstepped), ("final".into(), &chain.final_doc)];
    let inputs = crate::report::ReportInputs {
        run: Some(&run.recording),
        swing: Some(&swing.recording),
        validation: validation.map(|v| crate::report::Validation { recording: &v.recording, truth_deg: &v.true_heading_deg, truth_column: crate::data::table::col::TRUE_HEADING_DEG }),
        cals,
        before: Some(before),
        field_nt: None,
        site: Some(cfg.site),
        summary: Some(summary),
        settings: Some(settings),
    };
    Ok(crate::report::write_report(&cfg.out_dir.join("report"), &inputs)?)
}

/// Writes a JSON file in the session directory.
fn save_json<T: serde::Serialize>(dir: &Path, name: &str, value: &T) -> Result<PathBuf, SessionError> {
    let p = dir.join(name);
    let text = serde_json::to_string_pretty(value)?;
    crate::files::write_text_atomic(&p, &text)?;
    Ok(p)
}

#[cfg(test)]
mod tests;
