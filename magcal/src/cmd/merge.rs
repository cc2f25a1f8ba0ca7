//! `magcal merge`: one recording from the board's field log and the
//! navigation log, kept on different clocks (`host_tools::data::merge`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use host_tools::data::{merge_files_with, Clock, MergeError, MergeOptions, SharedSignal};
use host_tools::data::RecordingError;
use host_tools::data::ColumnMap;

/// Arguments of `magcal merge`.
#[derive(clap::Args)]
pub struct Args {
    /// The board's log (t on the board's clock, mx, my, mz; temp_c, health optional).
    #[arg(long)]
    board: PathBuf,
    /// The navigation log (t on the navigation clock, roll_deg, pitch_deg; heading_deg, GPS, gyro, ... optional).
    #[arg(long)]
    nav: PathBuf,
    /// The merged recording (CSV), `t` on the navigation clock.
    #[arg(long)]
    out: PathBuf,
    /// The navigation log's own names (and units) for its columns, as
    /// `--columns` elsewhere: `t=Time (s),roll_deg=Roll:rad,pitch_deg=Pitch:rad,...`
    /// (cells may be separated by comma, semicolon, tab or spaces).
    #[arg(long, value_name = "COLUMN=NAME[:UNIT],...")]
    nav_columns: Option<ColumnMap>,
    /// The clock offset, navigation − board, s, at the board log's first
    /// sample (instead of estimating it).
    #[arg(long, allow_hyphen_values = true)]
    offset_s: Option<f64>,
    /// With --offset-s: how much faster the navigation clock runs, ppm.
    #[arg(long, allow_hyphen_values = true, requires = "offset_s", default_value_t = 0.0)]
    drift_ppm: f64,
    /// Centre of the offset search, s (navigation − board).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.0, conflicts_with = "offset_s")]
    approx_offset_s: f64,
    /// Half-width of the offset search, s.
    #[arg(long, default_value_t = 120.0, conflicts_with = "offset_s")]
    max_offset_s: f64,
    /// The board log's own names (and units) for its columns, as
    /// `--nav-columns` (e.g. `t=TimeUS:us`).
    #[arg(long, value_name = "COLUMN=NAME[:UNIT],...")]
    board_columns: Option<ColumnMap>,
    /// The longest gap of the navigation log interpolated across, s: the
    /// board samples in a longer one are written without navigation (and
    /// counted). A vehicle's attitude changes by degrees within a second or
    /// two. Never beyond five of the log's median steps (at least 1 s).
    #[arg(long, default_value_t = host_tools::data::MAX_NAV_GAP_S, value_parser = positive_s)]
    max_nav_gap_s: f64,
    /// Keep a given --offset-s the data disagree with (said in the output).
    #[arg(long)]
    allow_weak: bool,
    /// Refuse an offset found at its search window's edge (otherwise kept
    /// with a warning).
    #[arg(long)]
    strict: bool,
    /// Print the clocks found (and counts) as one JSON document on stdout.
    #[arg(long)]
    json: bool,
}

/// What to change on the command line (the commands' one hint mechanism):
/// the navigation log missing a column, read without a mapping, says how to
/// give one; a clock that could not be found, which options set it.
fn merge_hint(e: MergeError, nav: &Path, mapped: bool) -> anyhow::Error {
    super::hinted(e, |e| match e {
        MergeError::Log(RecordingError::MissingColumn { path, .. }) if path == nav && !mapped => {
            Some("give the navigation log's own names with --nav-columns (e.g. --nav-columns \"t=Time,roll_deg=Roll:rad,pitch_deg=Pitch:rad\")")
        }
        MergeError::NoRotation(_) | MergeError::DriftTooLarge { .. } => Some("give the clock offset with --offset-s (and its drift with --drift-ppm)"),
        MergeError::OutsideWindow { .. } | MergeError::NoAgreement { .. } => Some("centre the search window with --approx-offset-s, widen it with --max-offset-s, or give --offset-s"),
        MergeError::GivenOffsetDisagrees { .. } => Some("check --offset-s (its sign), leave it out to use the offset found, or give --allow-weak to keep it (said in the output)"),
        MergeError::AtWindowEdge(_) => Some("centre the search window with --approx-offset-s, widen it with --max-offset-s, or leave out --strict to keep it with a warning"),
        MergeError::Time(_) => Some("give the log's time unit with --nav-columns or --board-columns (e.g. t=t:us)"),
        MergeError::SpanTooLong { .. } => Some("give the log's time unit with --nav-columns or --board-columns (e.g. t=t:ms), or cut the log at the jump"),
        MergeError::NotUnique { .. } => Some("centre a narrower window on the right offset with --approx-offset-s and --max-offset-s, or give --offset-s"),
        _ => None,
    })
}

/// Runs `magcal merge`.
pub fn run(a: Args) -> Result<()> {
    super::check_out("--out", &a.out, &[&a.board, &a.nav])?;
    let clock = match a.offset_s {
        Some(offset_s) => Clock::Given { offset_s, drift_ppm: a.drift_ppm },
        None => Clock::Estimate { center_s: a.approx_offset_s, max_offset_s: a.max_offset_s },
    };
    let mapped = a.nav_columns.is_some();
    let working = super::working("merging the logs", a.json);
    let opts = MergeOptions { max_nav_gap_s: a.max_nav_gap_s, allow_weak: a.allow_weak, strict: a.strict };
    let merged = merge_files_with(&a.board, &a.board_columns.unwrap_or_default(), &a.nav, &a.nav_columns.unwrap_or_default(), clock, &opts).map_err(|e| merge_hint(e, &a.nav, mapped))?;
    working.done();
    for note in &merged.report.notes {
        eprintln!("note: {note}");
    }
    for warning in &merged.report.warnings {
        eprintln!("warning: {warning}");
    }
    merged.write(&a.out).with_context(|| format!("writing {}", a.out.display()))?;
    let r = &merged.report;
    eprintln!(
        "wrote {} ({} rows; {} board samples outside the navigation log left out, {} in its gaps (over {} s) without navigation, {} saturated without a field)",
        a.out.display(),
        r.rows,
        r.board_samples_outside_nav,
        r.rows_in_nav_gaps,
        r.nav_gap_limit_s,
        r.saturated_rows
    );
    if a.json {
        println!("{}", serde_json::to_string_pretty(r)?);
    } else if r.estimated {
        let timed_by = r.timed_by.map_or_else(String::new, |s| format!(" timed by the {}", signal_name(s)));
        let unique = match (r.margin_sigma, r.runner_up_offset_s) {
            (Some(m), Some(o)) => format!("; {m:.1} σ clearer than the next best offset, {o:.2} s"),
            _ => "; no other offset comes close".to_string(),
        };
        println!(
            "clock offset (navigation − board) {:.4} ± {:.4} s at board t = {:.3} s, drift {:.1} ± {:.1} ppm{} ({} windows{timed_by}, agreement {:.2}{unique})",
            r.offset_s,
            r.offset_sigma_s,
            r.board_ref_s,
            r.drift_ppm,
            r.drift_sigma_ppm,
            if r.drift_fitted { "" } else { " (not fitted: too short)" },
            r.windows_used,
            r.peak_correlation
        );
    } else {
        println!("clock offset (navigation − board) {:.4} s at board t = {:.3} s, drift {:.1} ppm (given)", r.offset_s, r.board_ref_s, r.drift_ppm);
    }
    Ok(())
}

/// A shared signal in words.
fn signal_name(s: SharedSignal) -> &'static str {
    match s {
        SharedSignal::Attitude => "attitude",
        SharedSignal::Course => "GPS course",
        SharedSignal::Tilt => "tilt (roll and pitch)",
        SharedSignal::Rates => "rates of turn",
    }
}

/// A positive, finite number of seconds.
fn positive_s(text: &str) -> std::result::Result<f64, String> {
    match text.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("`{text}` is not a positive number of seconds")),
    }
}
