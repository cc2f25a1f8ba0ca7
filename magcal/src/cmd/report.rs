//! `magcal report`: the calibration report — one self-contained HTML page
//! (headline, deviation card, swing coverage, field along the run, headings
//! against reference and truth, back-stepping trace, residuals) and the
//! deviation card as text, CSV and JSON — from a session directory or from
//! explicit recordings and calibration documents.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use host_tools::compute::read_reference_column;
use host_tools::doc::{SessionSettings, SessionSummary};
use host_tools::doc::CalDoc;
use host_tools::geomag::Site;
use host_tools::report::{check_outputs, write_report, ReportInputs, Validation};

use super::SiteArgs;

/// Arguments of `magcal report`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
    /// A session directory (`magcal session --out`): its recordings,
    /// calibrations, settings and summary; the flags below override its files.
    #[arg(long)]
    session: Option<PathBuf>,
    /// The out-and-back run.
    #[arg(long)]
    run: Option<PathBuf>,
    /// The swing test.
    #[arg(long)]
    swing_input: Option<PathBuf>,
    /// A validation run with a truth heading column (see --truth-column).
    #[arg(long)]
    validation: Option<PathBuf>,
    /// The validation run's truth heading column, degrees true.
    #[arg(long, default_value = "true_heading_deg")]
    truth_column: String,
    /// Calibration documents to compare (repeat the flag), in the order they
    /// were made: the last is reported on. Labelled by file name.
    #[arg(long)]
    cal: Vec<PathBuf>,
    /// The coefficients before the calibration (the validation's "before").
    #[arg(long)]
    before: Option<PathBuf>,
    /// Reference intensity for the field figure, nT (10 000 to 100 000;
    /// default: IGRF at the site).
    #[arg(long, value_parser = field_nt)]
    field_nt: Option<f64>,
    #[command(flatten)]
    site: SiteArgs,
    /// Output directory (default: `<session>/report`).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Use a document whose own reference check failed (written by `fit
    /// --allow-weak`); it is then said on stderr.
    #[arg(long)]
    allow_weak: bool,
    /// Print what was written as JSON.
    #[arg(long)]
    json: bool,
}

/// `--field-nt`: an intensity at the Earth's surface, nT ([`super::check_field_nt`]).
fn field_nt(text: &str) -> Result<f64, String> {
    let v: f64 = text.trim().parse().map_err(|_| "not a number of nT".to_string())?;
    super::check_field_nt(v, "the intensity").map_err(|e| e.to_string())?;
    Ok(v)
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}", path.display()))
}

/// `dir/name` when `dir` is given and the file exists.
fn in_session(dir: Option<&Path>, name: &str) -> Option<PathBuf> {
    dir.map(|d| d.join(name)).filter(|p| p.is_file())
}

/// Runs `magcal report`.
pub fn run(a: Args) -> Result<()> {
    let dir = a.session.as_deref();
    if let Some(d) = dir {
        if !d.is_dir() {
            bail!("--session {}: not a directory", d.display());
        }
    }
    let out = match (&a.out, dir) {
        (Some(o), _) => o.clone(),
        (None, Some(d)) => d.join("report"),
        (None, None) => bail!("give --out DIR (or --session DIR to write DIR/report)"),
    };
    let run_path = a.run.clone().or_else(|| in_session(dir, "run.csv"));
    let swing_path = a.swing_input.clone().or_else(|| in_session(dir, "swing.csv"));
    let validation_path = a.validation.clone().or_else(|| in_session(dir, "validation_truth.csv"));
    let cal_paths: Vec<PathBuf> = if a.cal.is_empty() {
        ["cal_step1.json", "cal_backstep.json", "cal_final.json"].iter().filter_map(|n| in_session(dir, n)).collect()
    } else {
        a.cal.clone()
    };
    if run_path.is_none() && swing_path.is_none() && validation_path.is_none() && cal_paths.is_empty() {
        bail!("nothing to report: give --session DIR (a session's folder) or at least one of --run, --swing-input, --validation, --cal");
    }
    let before_path = a.before.clone().or_else(|| in_session(dir, "cal_before.json"));
    let (summary_path, settings_path) = (in_session(dir, "summary.json"), in_session(dir, "settings.json"));
    // Every file the report writes, against every file it reads, before
    // any work (a recording in the report's folder under a card's name was
    // replaced by the card).
    let read: Vec<&Path> = [&run_path, &swing_path, &validation_path, &before_path, &summary_path, &settings_path].into_iter().flatten().map(PathBuf::as_path).chain(cal_paths.iter().map(PathBuf::as_path)).collect();
    check_outputs(&out, &read).map_err(|e| anyhow::anyhow!("--out {e}"))?;

    let run = run_path.as_deref().map(|p| a.columns.read(p)).transpose()?;
    let swing = swing_path.as_deref().map(|p| a.columns.read(p)).transpose()?;
    let validation = match &validation_path {
        Some(p) => {
            let rec = a.columns.read(p)?;
            let truth = read_reference_column(p, &a.truth_column)?.with_context(|| format!("{}: no `{}` column (the validation run's truth heading; name another with --truth-column)", p.display(), a.truth_column))?;
            if truth.len() != rec.len() {
                bail!("{}: column `{}` has {} rows, the recording {}", p.display(), a.truth_column, truth.len(), rec.len());
            }
            Some((rec, truth))
        }
        None => None,
    };
    let docs = cal_paths.iter().map(|p| super::load_field_doc(p, a.allow_weak)).collect::<Result<Vec<_>, _>>()?;
    let labels = cal_paths.iter().map(|p| p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default());
    let before = match (&a.before, before_path) {
        (Some(p), _) => Some(super::load_field_doc(p, a.allow_weak)?),
        // The session saves the board's previous set unchecked: one that
        // does not pass as a calibration is left out, saying so.
        (None, Some(p)) => CalDoc::load_with(&p, a.allow_weak).map(|(d, _)| d).map_err(|e| eprintln!("leaving out the coefficients before the session: {e}")).ok(),
        (None, None) => None,
    };
    let summary: Option<SessionSummary> = summary_path.map(|p| read_json(&p)).transpose()?;
    let settings: Option<SessionSettings> = settings_path.map(|p| read_json(&p)).transpose()?;
    let site = match a.site.site()? {
        Some(s) => Some(s),
        None if a.site.any() => bail!("give all of --lat, --lon and --date (or none)"),
        None => settings.as_ref().map(|s| Site { lat_deg: s.lat_deg, lon_deg: s.lon_deg, decimal_year: s.decimal_year }),
    };
    // The recordings' own positions against the site whose field and
    // declination the report shows (as `fit` and `backstep` check them).
    if let Some(s) = &site {
        let recordings = [(&run_path, run.as_ref()), (&swing_path, swing.as_ref()), (&validation_path, validation.as_ref().map(|(r, _)| r))];
        for (path, rec) in recordings {
            if let (Some(p), Some(r)) = (path, rec) {
                // Said on stderr; the report writes no calibration to mark.
                super::check_site(r, p, s, a.allow_weak)?;
            }
        }
    }
    let inputs = ReportInputs {
        run: run.as_ref(),
        swing: swing.as_ref(),
        validation: validation.as_ref().map(|(recording, truth_deg)| Validation { recording, truth_deg, truth_column: &a.truth_column }),
        cals: labels.zip(docs.iter()).collect(),
        before: before.as_ref(),
        field_nt: a.field_nt,
        site,
        summary: summary.as_ref(),
        settings: settings.as_ref(),
    };
    let written = write_report(&out, &inputs)?;
    eprintln!("wrote {} ({} figures)", written.index.display(), written.figures);
    if let Some(c) = &written.card {
        eprintln!("wrote the deviation card against the {}: {}, {}, {}", c.against, c.text.display(), c.csv.display(), c.json.display());
    }
    for m in &written.missing {
        eprintln!("  not in the report: {m}");
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&written)?);
    }
    Ok(())
}
