//! One module per subcommand, and the arguments and output they share.

pub mod apply;
pub mod backstep;
pub mod card;
pub mod export;
pub mod fit;
pub mod identify;
pub mod igrf;
pub mod import;
pub mod log;
pub mod merge;
pub mod ortho;
pub mod report;
pub mod session;
pub mod simulate;
pub mod swing;

use std::path::PathBuf;

use anyhow::{bail, Result};
use host_tools::data::CalDoc;
use host_tools::geomag::{self, Field, Site};

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

/// Writes the document (`--out`) and prints it (`--json`) or the summary.
pub fn emit(doc: &CalDoc, out: Option<&PathBuf>, json: bool, summary: &str) -> Result<()> {
    if let Some(path) = out {
        doc.save(path)?;
        eprintln!("wrote {}", path.display());
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
