//! `magcal apply`: a calibration applied to any recording, with the
//! heading's integrity per row, by the board's own per-sample code
//! (host-tools' [`host_tools::compute::apply_recording`] over calib-core's
//! `online::OnlineIntegrity`).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::compute::{apply_recording, choose_inclination, choose_north, document_inclination_deg, summarize, write_applied, ApplyError, ApplyOptions, InclinationSource};
use host_tools::compute::read_reference_column;
use host_tools::compute::{apply_compass, write_compass_applied};
use host_tools::compute::{given_disagreement, shown, world_field_for};
use host_tools::doc::world_allowance;
use host_tools::doc::{CompassDoc, Document};
use host_tools::data::Recording;
use host_tools::doc::CalDoc;
use host_tools::geomag::Site;


/// Arguments of `magcal apply`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
    /// Recording: mx, my, mz; roll_deg, pitch_deg for the heading; t and
    /// gx, gy, gz for the gyro check; motor_current_a, temp_c for the
    /// document's terms.
    #[arg(long)]
    input: PathBuf,
    /// The calibration document.
    #[arg(long)]
    cal: PathBuf,
    /// Where to write the result (t, field_x_nt, field_y_nt, field_z_nt,
    /// heading_deg — magnetic_heading_deg when no declination is known —,
    /// heading_sigma_deg, integrity); never the input.
    #[arg(long)]
    out: PathBuf,
    /// The intensity the calibration reproduces, nT (default: the
    /// document's field_nt): for a calibration made by another tool whose
    /// scale is its own (the magnitude check judges |h| against it).
    #[arg(long)]
    field_nt: Option<f64>,
    /// The local inclination, degrees (default: the document's, or learned
    /// from the samples judged ok).
    #[arg(long, allow_hyphen_values = true)]
    inclination_deg: Option<f64>,
    /// The site, for a document without a reference inclination: IGRF-14's
    /// there is the monitor's (otherwise it is learned from the recording
    /// it judges, and said so).
    #[command(flatten)]
    site: super::SiteArgs,
    /// The field's expected scatter about field_nt, nT (default: the
    /// document's fit residual, or 1.2 % of field_nt).
    #[arg(long)]
    field_sigma_nt: Option<f64>,
    /// Print a JSON summary on stdout: rows, rows per state, heading RMS
    /// against the true heading (true_heading_deg; truth_heading_deg, the
    /// name of the BROAD files' optical heading, too) or ref_heading_deg.
    #[arg(long)]
    json: bool,
    /// Use a weak document (one whose own reference check failed: `fit
    /// --allow-weak`), a recording made far from the document's site, or an
    /// --inclination-deg/--field-nt beyond its allowance: kept, and said
    /// on stderr and in the summary's `warnings`.
    #[arg(long)]
    allow_weak: bool,
}

/// The true heading's name in files prepared before it had one name
/// (`tests/data/broad-*`: the optical heading), read when there is no
/// `true_heading_deg`.
const TRUTH_HEADING_ALIAS: &str = "truth_heading_deg";

/// Runs `magcal apply`.
pub fn run(a: Args) -> Result<()> {
    // Never the recording, never the calibration (also through links).
    super::check_out("--out", &a.out, &[&a.input, &a.cal])?;
    if let Some(d) = a.inclination_deg {
        if !(d.is_finite() && d.abs() < 90.0) {
            bail!("--inclination-deg must be within ±90, not {d}");
        }
    }
    if let Some(f) = a.field_nt {
        super::check_field_nt(f, "--field-nt")?;
    }
    if let Some(s) = a.field_sigma_nt {
        if !(s.is_finite() && s > 0.0) {
            bail!("--field-sigma-nt must be a positive number of nT, not {s}");
        }
    }
    let (doc, mut warnings) = match Document::load_with(&a.cal, a.allow_weak).map_err(|e| super::hinted(e, super::weak_hint))? {
        (Document::Field(doc), said) => (*doc, said),
        (Document::Compass(doc), _) => return run_compass(&a, &doc),
    };
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let rec = a.columns.read(&a.input)?;
    let given_site = a.site.site()?;
    // The recording's positions against the site the document's reference
    // field and declination are for (the one given, else the document's).
    let doc_site = doc.reference.as_ref().and_then(|r| r.site);
    if let Some(site) = given_site.or(doc_site) {
        let whose = if given_site.is_some() { "the site given" } else { "the document's reference site" };
        super::weak_or_refused(&mut warnings, a.allow_weak, super::check_site(&rec, &a.input, &site, false).map(|_| ()).with_context(|| format!("{}: against {whose}", a.cal.display())))?;
    }
    for w in given_values_disagree(&a, &doc, &rec, given_site.or(doc_site)) {
        super::weak_or_refused(&mut warnings, a.allow_weak, Err(anyhow::anyhow!("{w}: the value given would judge the recording against another field; check it")))?;
    }
    let site_deg = match given_site {
        Some(s) => Some(s.field()?.inclination_deg()),
        None => None,
    };
    let (inclination_deg, source) = choose_inclination(&doc, a.field_nt.unwrap_or(doc.field_nt), a.inclination_deg, site_deg);
    if source == InclinationSource::Learned {
        eprintln!(
            "warning: {} holds no reference inclination: the monitor learns the dip from the recording it judges and calls no sample ok (unjudged); give --lat/--lon/--date (IGRF-14 at the site) or --inclination-deg",
            a.cal.display()
        );
    }
    if a.site.any() && source != InclinationSource::Site {
        eprintln!("note: --lat/--lon/--date not used for the inclination: it is the {}", if source == InclinationSource::User { "one given" } else { "document's" });
    }
    // The heading's north: true only where a declination is known.
    let (north, add_declination) = choose_north(&doc, given_site.as_ref());
    let mut doc = doc;
    if add_declination.is_some() {
        doc.declination_deg = add_declination;
    }
    eprintln!("note: {}: {}", north.heading_column(), north.reason());
    let opts = ApplyOptions { field_nt: a.field_nt, inclination_deg, field_sigma_nt: a.field_sigma_nt, tuning: None };
    let working = super::working(&format!("applying the calibration to {} rows", rec.len()), a.json);
    let applied = apply_recording(&rec, &doc, &opts).map_err(|e| {
        // A reference the monitor cannot use is the document's problem.
        let blamed = if matches!(e, ApplyError::Reference(_)) { &a.cal } else { &a.input };
        anyhow::Error::new(e).context(blamed.display().to_string())
    })?;
    write_applied(&a.out, &a.input, rec.t_s.as_deref(), &applied, north)?;
    working.done();
    eprintln!("wrote {}", a.out.display());
    // The true heading by its one name, or the BROAD files' older one.
    let mut truth = None;
    for name in [host_tools::data::col::TRUE_HEADING_DEG, TRUTH_HEADING_ALIAS] {
        if let Some(column) = read_reference_column(&a.input, name)? {
            truth = Some((name, column));
            break;
        }
    }
    let reference = match (&truth, &rec.ref_heading_deg) {
        (Some((name, t)), _) => Some((*name, t.as_slice())),
        (None, Some(r)) => Some(("ref_heading_deg", r.as_slice())),
        _ => None,
    };
    let mut summary = summarize(&applied, reference);
    summary.inclination_source = Some(source);
    summary.north = Some(north);
    summary.heading_column = Some(north.heading_column());
    summary.north_reason = Some(north.reason());
    summary.warnings = warnings;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        let states: Vec<String> = summary.rows_per_state.iter().map(|(k, v)| format!("{k} {v}")).collect();
        println!("{} rows: {}", summary.rows, states.join(", "));
        println!("{}: {}", north.heading_column(), north.reason());
        if let (Some(name), Some(all), Some(ok)) = (&summary.heading_reference, summary.heading_rms_deg, summary.heading_rms_ok_deg) {
            println!("heading RMS against {name}: {all:.2}° all rows, {ok:.2}° on the ok rows");
        }
        for w in &summary.warnings {
            println!("warning: {w}");
        }
    }
    Ok(())
}

/// `--inclination-deg` and `--field-nt` against what is known apart from
/// them, beyond `REFUSE_SIGMAS` of the allowance: the inclination
/// against IGRF-14 at the recording's positions (or the site: given, else
/// the document's), else the document's own; the intensity against what
/// the recording shows through the calibration (the scale it reproduces:
/// the option exists for a calibration from another tool whose scale is
/// its own, so the world model's intensity is not its judge).
fn given_values_disagree(a: &Args, doc: &CalDoc, rec: &Recording, site: Option<Site>) -> Vec<String> {
    let mut words = Vec::new();
    if let Some(i) = a.inclination_deg {
        let world = world_field_for(rec, site);
        let expected = match &world {
            Some((s, f)) => Some((f.inclination_deg(), world_allowance(f.total_nt()).0, format!("IGRF-14 at {:.3}°, {:.3}°, {:.2}", s.lat_deg, s.lon_deg, s.decimal_year))),
            None => document_inclination_deg(doc, doc.field_nt).map(|d| {
                let sigma = doc.reference.as_ref().and_then(|r| r.inclination_sigma_deg).unwrap_or_else(|| world_allowance(doc.field_nt).0);
                (d, sigma, format!("{} (the document's inclination)", a.cal.display()))
            }),
        };
        if let Some((d, sigma, source)) = expected {
            words.extend(given_disagreement("--inclination-deg", i, d, sigma, "°", &source));
        }
    }
    if let Some(f) = a.field_nt {
        let (_, shown_nt) = shown(&doc.field_cal(), rec);
        if shown_nt.is_finite() {
            let sigma = world_allowance(shown_nt).1;
            words.extend(given_disagreement("--field-nt", f, shown_nt, sigma, " nT", &format!("{}'s median intensity through the calibration", a.input.display())));
        }
    }
    words
}

/// A heading-only compass's document on its log: the corrected heading per
/// row, and the error against `ref_heading_deg` before and after.
fn run_compass(a: &Args, doc: &CompassDoc) -> Result<()> {
    if a.field_nt.is_some() || a.inclination_deg.is_some() || a.field_sigma_nt.is_some() || a.site.any() {
        bail!("{} is a heading-only compass's calibration: --field-nt, --inclination-deg, --field-sigma-nt and the site judge a magnetometer's field, which a compass log does not have", a.cal.display());
    }
    let log = a.columns.read_compass(&a.input).with_context(|| format!("{} is a heading-only compass's calibration, so the recording must be a compass log", a.cal.display()))?;
    let (corrected, summary) = apply_compass(&log, doc).with_context(|| format!("{}", a.input.display()))?;
    write_compass_applied(&a.out, &log, &corrected)?;
    eprintln!("wrote {}", a.out.display());
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!("{} rows, {} with a compass heading corrected", summary.rows, summary.corrected_rows);
        if let (Some(b), Some(c)) = (summary.before_rms_deg, summary.after_rms_deg) {
            println!("against ref_heading_deg ({} samples, at the document's delay): {b:.2}° before, {c:.2}° after RMS", summary.reference_pairs);
        }
    }
    Ok(())
}
