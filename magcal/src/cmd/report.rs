//! `magcal report`: figures (SVG) and an HTML page comparing calibrations on
//! recordings.

use std::path::PathBuf;

use anyhow::Result;
use host_tools::data::{CalDoc, Recording};
use host_tools::report::{write_report, ReportInputs};
use serde_json::json;

/// Arguments of `magcal report`.
#[derive(clap::Args)]
pub struct Args {
    /// The out-and-back run.
    #[arg(long)]
    run: Option<PathBuf>,
    /// The swing test.
    #[arg(long)]
    swing_input: Option<PathBuf>,
    /// Calibration documents to compare (repeat the flag); labelled by file name.
    #[arg(long)]
    cal: Vec<PathBuf>,
    /// Reference intensity to draw, nT.
    #[arg(long)]
    field_nt: Option<f64>,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Print a JSON list of the files written.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal report`.
pub fn run(a: Args) -> Result<()> {
    let run = a.run.as_deref().map(Recording::read).transpose()?;
    let swing = a.swing_input.as_deref().map(Recording::read).transpose()?;
    let docs = a.cal.iter().map(|p| CalDoc::load(p)).collect::<Result<Vec<_>, _>>()?;
    let labels = a.cal.iter().map(|p| p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default());
    let inputs = ReportInputs {
        run: run.as_ref(),
        swing: swing.as_ref(),
        cals: labels.zip(docs.iter()).collect(),
        field_nt: a.field_nt.or_else(|| docs.first().map(|d| d.field_nt)),
    };
    let files = write_report(&a.out, &inputs)?;
    eprintln!("wrote {} with {} figures", a.out.join("index.html").display(), files.len());
    if a.json {
        println!("{}", json!({"index": a.out.join("index.html"), "figures": files}));
    }
    Ok(())
}
