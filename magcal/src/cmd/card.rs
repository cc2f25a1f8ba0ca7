//! `magcal card`: the compass deviation card — the residual heading error by
//! heading and by compass point, before and after the calibration
//! (host-tools' [`host_tools::compute::deviation_card`]).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::compute::{compass_card, deviation_card, check_reference_column, read_reference_column, CardError, DeviationCard, STEP_DEG_RANGE};
use host_tools::doc::Document;

use super::hinted;

/// Arguments of `magcal card`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
    /// Recording with mx, my, mz, roll_deg, pitch_deg and the reference
    /// (or truth) heading `ref_heading_deg`.
    #[arg(long)]
    input: PathBuf,
    /// The calibration document.
    #[arg(long)]
    cal: PathBuf,
    /// The column holding the reference (or truth) heading, degrees true.
    #[arg(long, default_value = "ref_heading_deg")]
    reference_column: String,
    /// Width of the heading sectors, degrees (0.1 to 180; must divide 360).
    #[arg(long, default_value_t = 15.0, value_parser = super::number_in(STEP_DEG_RANGE, "degrees"))]
    step_deg: f64,
    /// Compass points: 16 (N, NNE, …) or 8 (N, NE, …).
    #[arg(long, default_value_t = 16, value_parser = compass_points)]
    points: usize,
    /// Also write the card as CSV here.
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Use a document whose own reference check failed (written by `fit
    /// --allow-weak`); it is then said on stderr.
    #[arg(long)]
    allow_weak: bool,
    /// Print the card as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal card`.
pub fn run(a: Args) -> Result<()> {
    // `mx` is counts, not a heading (it was once taken as one).
    check_reference_column(&a.reference_column).map_err(|e| hinted(e, |_| Some("name a heading column with --reference-column")))?;
    if let Some(csv) = &a.csv {
        super::check_out("--csv", csv, &[&a.input, &a.cal])?;
    }
    let doc = match super::load_document(&a.cal, a.allow_weak)? {
        Document::Field(doc) => *doc,
        Document::Compass(doc) => {
            if a.reference_column != "ref_heading_deg" {
                bail!("a compass log's card is against its ref_heading_deg (--reference-column is for a magnetometer recording)");
            }
            let log = a.columns.read_compass(&a.input).with_context(|| format!("{} is a heading-only compass's calibration, so the recording must be a compass log", a.cal.display()))?;
            let card = compass_card(&log, &doc, a.step_deg, a.points)
                .map_err(|e| hinted(e, |e| matches!(e, CardError::BadStep(_)).then_some("give another --step-deg")))
                .with_context(|| format!("{}: deviation card", a.input.display()))?;
            return print_card(&a, &card);
        }
    };
    let mut rec = a.columns.read(&a.input)?;
    if a.reference_column != "ref_heading_deg" {
        let column = read_reference_column(&a.input, &a.reference_column)?.ok_or_else(|| CardError::NoReferenceColumn(a.reference_column.clone()))?;
        if column.len() != rec.len() {
            bail!("{}: column `{}` has {} rows, the recording {}", a.input.display(), a.reference_column, column.len(), rec.len());
        }
        rec.ref_heading_deg = Some(column);
    }
    let mut card = deviation_card(&rec, &doc, a.step_deg, a.points).map_err(|e| hinted(e, |e| matches!(e, CardError::BadStep(_)).then_some("give another --step-deg"))).with_context(|| format!("{}: deviation card", a.input.display()))?;
    card.reference.clone_from(&a.reference_column);
    print_card(&a, &card)
}

/// Writes the card's CSV when asked, and prints it.
fn print_card(a: &Args, card: &DeviationCard) -> Result<()> {
    if let Some(path) = &a.csv {
        card.write_csv(path)?;
        eprintln!("wrote {}", path.display());
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&card)?);
    } else {
        print!("{}", card.to_text());
    }
    Ok(())
}

/// `--points`: 8 or 16.
fn compass_points(text: &str) -> Result<usize, String> {
    match text.trim() {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err("must be 8 or 16".into()),
    }
}
