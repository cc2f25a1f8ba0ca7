//! One module per subcommand, and the arguments and output they share.

pub mod apply;
pub mod backstep;
pub mod card;
pub mod export;
pub mod fit;
pub mod identify;
pub mod stream;
pub mod igrf;
pub mod import;
pub mod log;
pub mod merge;
pub mod ortho;
pub mod report;
pub mod session;
pub mod simulate;
pub mod swing;

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use host_tools::data::{self, ColumnMap, CompassLog, IntakeError, Recording, RecordingError};
use host_tools::doc::CalDoc;
use host_tools::files::{self, Replaces};
use host_tools::geomag::{self, Field, Site};

/// The input recordings' own column names and units (`--columns`), shared
/// by every command that reads recordings.
#[derive(clap::Args, Clone)]
pub struct InputColumns {
    /// The recordings' own names for the project's columns, and optionally
    /// their units: `mx=Magnetometer X (uT):uT,my=...,roll_deg=Roll:rad`
    /// (names any case, may hold spaces; units nT, uT, µT, gauss, mG,
    /// counts for mx/my/mz, converted to nT; deg, rad for angles, converted
    /// to degrees; rad/s, deg/s for gx/gy/gz, converted to rad/s; s, ms, us
    /// for t, converted to s). Cells may be separated by comma, semicolon,
    /// tab or spaces.
    #[arg(long, value_name = "COLUMN=NAME[:UNIT],...")]
    pub columns: Option<ColumnMap>,
}

impl InputColumns {
    /// Reads a recording under the mapping through the one way in
    /// ([`host_tools::data::read_recording`]: the time's unit, roll and pitch in
    /// radians, placeholder fixes, duplicated columns), saying on stderr
    /// what it converted or dropped; a refusal says which `--columns` entry
    /// settles it.
    pub fn read(&self, path: &Path) -> Result<Recording> {
        let map = self.columns.clone().unwrap_or_default();
        let intake = data::read_recording(path, &map).map_err(|e| hinted(e, intake_hint))?;
        for note in &intake.notes {
            eprintln!("note: {note}");
        }
        Ok(intake.recording)
    }

    /// Reads a heading-only compass's log under the mapping, through the
    /// one way in ([`data::read_compass`]: the time's unit, placeholder
    /// fixes), saying what it converted or dropped.
    pub fn read_compass(&self, path: &Path) -> Result<CompassLog> {
        let map = self.columns.clone().unwrap_or_default();
        let (log, notes) = data::read_compass(path, &map).map_err(|e| hinted(e, intake_hint))?;
        for note in &notes {
            eprintln!("note: {note}");
        }
        Ok(log)
    }
}

/// What to change on the command line when the one way in refuses a
/// recording.
pub fn intake_hint(e: &IntakeError) -> Option<&'static str> {
    match e {
        IntakeError::Read(RecordingError::MissingColumn { hint, .. }) if !hint.is_empty() => Some("give the mapping with --columns"),
        IntakeError::Read(RecordingError::DuplicateColumn { .. } | RecordingError::SharedColumn { .. }) => Some("name the header's column for each with --columns"),
        IntakeError::TimeUnit { .. } => Some("give it with --columns (e.g. --columns t=t:us)"),
        IntakeError::AttitudeUnits { .. } => Some(
            "looks like radians: give --columns roll_deg=roll_deg:rad,pitch_deg=pitch_deg:rad (the file's names for them); if they really are degrees, say so with :deg",
        ),
        _ => None,
    }
}

/// Where and when, for the IGRF reference (all three or none).
#[derive(clap::Args, Clone)]
pub struct SiteArgs {
    /// Latitude, degrees (IGRF reference; with --lon and --date).
    #[arg(long, allow_hyphen_values = true)]
    pub lat: Option<f64>,
    /// Longitude, degrees.
    #[arg(long, allow_hyphen_values = true)]
    pub lon: Option<f64>,
    /// Date, YYYY-MM-DD or decimal year.
    #[arg(long)]
    pub date: Option<String>,
}

impl SiteArgs {
    /// Whether any of the three was given.
    pub fn any(&self) -> bool {
        self.lat.is_some() || self.lon.is_some() || self.date.is_some()
    }

    /// The site when all three are given (`None` when any is missing).
    pub fn site(&self) -> Result<Option<Site>> {
        match (self.lat, self.lon, self.date.as_deref()) {
            (Some(lat), Some(lon), Some(date)) => Ok(Some(Site::new(lat, lon, date)?)),
            _ => Ok(None),
        }
    }

    /// The recording's positions against what was given: the site with its
    /// date ([`check_site`]), or a latitude and longitude alone
    /// ([`check_positions`]). Returns the refusals kept only as weak results
    /// were allowed, for the document the command writes.
    pub fn check_recording(&self, rec: &Recording, path: &Path, allow_weak: bool) -> Result<Vec<String>> {
        match (self.site()?, self.lat, self.lon) {
            (Some(site), _, _) => check_site(rec, path, &site, allow_weak),
            (None, Some(lat), Some(lon)) => check_positions(rec, path, lat, lon).map(|()| Vec::new()),
            _ => Ok(Vec::new()),
        }
    }
}

/// Where and when, required.
#[derive(clap::Args, Clone)]
pub struct Place {
    /// Geodetic latitude, degrees.
    #[arg(long, allow_hyphen_values = true)]
    pub lat: f64,
    /// Longitude, degrees.
    #[arg(long, allow_hyphen_values = true)]
    pub lon: f64,
    /// Date: YYYY-MM-DD or decimal year.
    #[arg(long)]
    pub date: String,
}

impl Place {
    /// The site.
    pub fn site(&self) -> Result<Site> {
        Ok(Site::new(self.lat, self.lon, &self.date)?)
    }
}

/// The reference intensity from --field-nt or --lat/--lon/--date (IGRF-14).
pub fn reference_field(field_nt: Option<f64>, site: &SiteArgs) -> Result<Field> {
    match (field_nt, site.any()) {
        (Some(f), false) => {
            if !(f > 0.0 && f.is_finite()) {
                bail!("--field-nt must be a positive number of nT, not {f}");
            }
            check_field_nt(f, "--field-nt")?;
            // Only the intensity is known: put it all on one axis.
            Ok(geomag::Field { north_nt: f, east_nt: 0.0, down_nt: 0.0 })
        }
        (Some(_), true) => bail!("give either --field-nt or --lat/--lon/--date, not both"),
        (None, _) => match site.site()? {
            Some(s) => Ok(s.field()?),
            None => bail!("give the reference field intensity with --field-nt (nT) or all of --lat/--lon/--date"),
        },
    }
}

/// Refuses a field intensity that is not one at the Earth's surface in nT,
/// saying which unit it looks like (`what` names where it came from): the
/// one rule of the document check ([`host_tools::doc::field_nt_problem`]).
pub fn check_field_nt(field_nt: f64, what: &str) -> Result<()> {
    match host_tools::doc::field_nt_problem(field_nt) {
        None => Ok(()),
        Some(why) => bail!("{what} {why}"),
    }
}

/// Checks an output path before any work is done
/// ([`host_tools::files::check_output`]): a regular file or nothing (not a
/// directory, a device, a pipe), in a folder that exists, and none of
/// `inputs` — compared on disk, so a hard or symbolic link to an input is
/// the input. An existing file it will replace is said on stderr.
/// `flag` is the option that named it (`--out`, `--csv`).
pub fn check_out(flag: &str, out: &Path, inputs: &[&Path]) -> Result<()> {
    match files::check_output(out, inputs).map_err(|e| anyhow::anyhow!("{flag} {e}"))? {
        Replaces::ExistingFile => eprintln!("note: {flag} {} exists and will be replaced when the work is done", out.display()),
        Replaces::Nothing => {}
    }
    Ok(())
}

/// Checks the recording's own positions (`lat_deg`/`lon_deg`, where present)
/// against the site of the reference field ([`data::check_positions`]):
/// a warning beyond [`data::SITE_WARN_KM`], a refusal beyond
/// [`data::SITE_REFUSE_KM`], naming both. Without a date the declination
/// is not compared (see [`check_site`]).
pub fn check_positions(rec: &Recording, path: &Path, lat_deg: f64, lon_deg: f64) -> Result<()> {
    site_checked(data::check_positions(rec, path, lat_deg, lon_deg, None, false), lat_deg, lon_deg).map(|_| ())
}

/// [`check_positions`] against a site with its date: the declination at the
/// farthest position against the site's too, refused beyond
/// [`data::DECLINATION_CHANGE_LIMIT_DEG`] unless `allow_weak` (then said
/// on stderr, and returned: what a document written from this recording
/// carries in `quality.allowed_weak`).
pub fn check_site(rec: &Recording, path: &Path, site: &Site, allow_weak: bool) -> Result<Vec<String>> {
    site_checked(data::check_positions(rec, path, site.lat_deg, site.lon_deg, Some(site.decimal_year), allow_weak), site.lat_deg, site.lon_deg)
}

/// The warnings of a site check on stderr, or its refusal with its hint;
/// both name the site as given on the command line. Returns the warnings
/// that were refusals kept only as weak results were allowed.
fn site_checked(found: std::result::Result<Vec<data::SiteWarning>, IntakeError>, lat_deg: f64, lon_deg: f64) -> Result<Vec<String>> {
    let site = format!("--lat {lat_deg} --lon {lon_deg}");
    match found {
        Ok(warnings) => {
            let mut weak = Vec::new();
            for w in warnings {
                let said = format!("{w} (the site: {site})");
                eprintln!("warning: {said}");
                if matches!(w, data::SiteWarning::Declination { .. }) {
                    weak.push(said);
                }
            }
            Ok(weak)
        }
        Err(e @ IntakeError::FarFromSite(_)) => bail!("{e}: check {site} (the sign of each)"),
        Err(e @ IntakeError::DeclinationChange { .. }) => bail!("{e}: check {site}, or give --allow-weak to keep it (said in the output)"),
        Err(e) => Err(hinted(e, intake_hint)),
    }
}

/// A spinner with the elapsed time on stderr while `what` runs, on a
/// terminal only (never with `--json`, never into a pipe or a log); it
/// clears itself when dropped.
pub fn working(what: &str, json: bool) -> host_tools::session::Working {
    use std::io::IsTerminal;
    host_tools::session::Working::start(what, !json && std::io::stderr().is_terminal())
}

/// Writes the document (`--out`) and prints it (`--json`) or the summary.
/// Without `--out` it says on stderr that nothing was saved. Coefficients
/// refused are blamed on the `input` they were computed from, not on `--out`.
pub fn emit(doc: &CalDoc, input: &Path, out: Option<&PathBuf>, json: bool, summary: &str) -> Result<()> {
    if let Some(path) = out {
        doc.validate(input)?;
        doc.save(path).with_context(|| format!("{}: saving the calibration", path.display()))?;
        eprintln!("wrote {}", path.display());
    } else {
        eprintln!("note: no --out given: the calibration is printed, not saved");
    }
    if json {
        println!("{}", serde_json::to_string_pretty(doc)?);
    } else {
        println!("{summary}");
    }
    Ok(())
}

/// Every warning of the document's quality report, on stderr.
pub fn warn_all(doc: &CalDoc) {
    for w in doc.quality.warnings() {
        eprintln!("warning: {w}");
    }
}

/// A library error with the command line's fix appended, in the command's
/// own flags (the library's messages name none). Printed as
/// `<error>: <hint>`; the error stays its source.
#[derive(Debug)]
pub struct Hinted<E> {
    /// What the library said.
    pub error: E,
    /// What to change on the command line.
    pub hint: &'static str,
}

impl<E: std::fmt::Display> std::fmt::Display for Hinted<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.error, self.hint)
    }
}

impl<E: std::error::Error + 'static> std::error::Error for Hinted<E> {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

/// `e` with the hint `hint_for` gives for it (none: `e` as it is).
pub fn hinted<E: std::error::Error + Send + Sync + 'static>(e: E, hint_for: impl FnOnce(&E) -> Option<&'static str>) -> anyhow::Error {
    match hint_for(&e) {
        Some(hint) => Hinted { error: e, hint }.into(),
        None => e.into(),
    }
}

/// A clap value parser for an `f64` option within `range` (both ends
/// included), in `unit`: a number outside it, NaN or an infinity is
/// refused as the command line is parsed, saying the range (every
/// numeric option has a stated range in its parser).
pub fn number_in(range: std::ops::RangeInclusive<f64>, unit: &'static str) -> impl Fn(&str) -> Result<f64, String> + Clone + Send + Sync + 'static {
    move |text: &str| {
        let v: f64 = text.trim().parse().map_err(|_| format!("not a number (give one within {} … {} {unit})", range.start(), range.end()))?;
        if range.contains(&v) {
            Ok(v)
        } else if !v.is_finite() {
            Err(format!("must be finite, within {} … {} {unit}", range.start(), range.end()))
        } else {
            Err(format!("must be within {} … {} {unit}", range.start(), range.end()))
        }
    }
}

/// The hint for a weak document refused.
pub fn weak_hint(e: &host_tools::doc::CalDocError) -> Option<&'static str> {
    matches!(e, host_tools::doc::CalDocError::WeakReference { .. } | host_tools::doc::CalDocError::KeptWeak { .. } | host_tools::doc::CalDocError::AllowedWeak { .. }).then_some("give --allow-weak to use it anyway (it is then said in the output)")
}

/// A check's refusal: returned, or with `allow_weak` kept as a warning
/// (said on stderr now and in the summary).
pub fn weak_or_refused(warnings: &mut Vec<String>, allow_weak: bool, checked: Result<()>) -> Result<()> {
    match checked {
        Ok(()) => Ok(()),
        Err(e) if allow_weak => {
            let w = format!("{e:#} (kept: --allow-weak)");
            eprintln!("warning: {w}");
            warnings.push(w);
            Ok(())
        }
        Err(e) => Err(anyhow::anyhow!("{e:#}; refused: --allow-weak keeps it and says so")),
    }
}

/// A field calibration document through the one document check, with
/// `--allow-weak` (a weak document, [`CalDoc::check`], is refused
/// without it, and said on stderr with it).
pub fn load_field_doc(path: &Path, allow_weak: bool) -> Result<CalDoc> {
    let (doc, said) = CalDoc::load_with(path, allow_weak).map_err(|e| hinted(e, weak_hint))?;
    for w in said {
        eprintln!("warning: {w}");
    }
    Ok(doc)
}

/// Either form of document (field or heading-only) through the one
/// document check, as [`load_field_doc`].
pub fn load_document(path: &Path, allow_weak: bool) -> Result<host_tools::doc::Document> {
    let (doc, said) = host_tools::doc::Document::load_with(path, allow_weak).map_err(|e| hinted(e, weak_hint))?;
    for w in said {
        eprintln!("warning: {w}");
    }
    Ok(doc)
}
