//! `magcal export`: a calibration document as ArduPilot's or PX4's
//! magnetometer parameters (host-tools' [`host_tools::export`]).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::export::{export, ExportError, ExportOptions, Stack};

use super::hinted;

/// The target stack as `--format` spells it.
#[derive(clap::ValueEnum, Clone, Copy)]
pub enum Format {
    /// ArduPilot (ArduSub …): COMPASS_OFS/DIA/ODI/SCALE, COMPASS_MOT/MOTCT.
    Ardupilot,
    /// PX4: CAL_MAG0_*OFF/SCALE/ODIAG/COMP, CAL_MAG_COMP_TYP.
    Px4,
}

/// The raw units of the calibration (the recording's input units).
#[derive(clap::ValueEnum, Clone, Copy)]
pub enum RawUnit {
    /// Nanotesla.
    Nt,
    /// Microtesla.
    Ut,
    /// Milligauss (ArduPilot's unit).
    Mgauss,
    /// Gauss (PX4's unit).
    Gauss,
}

/// Arguments of `magcal export`.
#[derive(clap::Args)]
pub struct Args {
    /// The calibration document.
    #[arg(long)]
    cal: PathBuf,
    /// The stack whose parameters to write.
    #[arg(long, value_enum)]
    format: Format,
    /// The parameter file to write.
    #[arg(long)]
    out: PathBuf,
    /// The calibration's raw units (default: inferred from the matrix's gain,
    /// refused when it is none of these).
    #[arg(long, value_enum, conflicts_with = "raw_nt_per_unit")]
    raw_unit: Option<RawUnit>,
    /// The calibration's raw units as nT per unit.
    #[arg(long)]
    raw_nt_per_unit: Option<f64>,
    /// Largest rotation part of a non-symmetric matrix that is dropped (with
    /// a warning) rather than refused, degrees.
    #[arg(long, default_value_t = 2.0)]
    max_rotation_deg: f64,
    /// Use a document whose own reference check failed (written by `fit
    /// --allow-weak`); it is then said on stderr.
    #[arg(long)]
    allow_weak: bool,
    /// Print the export (parameters and typed warnings) as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal export`.
pub fn run(a: Args) -> Result<()> {
    super::check_out("--out", &a.out, &[&a.cal])?;
    if !(a.max_rotation_deg.is_finite() && a.max_rotation_deg >= 0.0) {
        bail!("--max-rotation-deg must be a non-negative number of degrees, not {}", a.max_rotation_deg);
    }
    let (doc, said) = host_tools::doc::CalDoc::load_with(&a.cal, a.allow_weak).map_err(|e| hinted(e, super::weak_hint))?;
    for w in &said {
        eprintln!("warning: {w}");
    }
    let stack = match a.format {
        Format::Ardupilot => Stack::ArduPilot,
        Format::Px4 => Stack::Px4,
    };
    let raw_nt_per_unit = match a.raw_unit {
        Some(u) => Some(match u {
            RawUnit::Nt => 1.0,
            RawUnit::Ut => 1e3,
            RawUnit::Mgauss => 100.0,
            RawUnit::Gauss => 1e5,
        }),
        None => a.raw_nt_per_unit,
    };
    let opts = ExportOptions { stack, raw_nt_per_unit, max_rotation_deg: a.max_rotation_deg };
    let ex = export(&doc, &opts).map_err(|e| hinted(e, export_hint)).with_context(|| format!("{}: export to {}", a.cal.display(), stack.name()))?;
    if ex.raw_unit_inferred {
        eprintln!("note: raw units taken as {} nT per unit from the matrix's gain (give --raw-unit to set them)", ex.raw_nt_per_unit);
    }
    for w in &ex.warnings {
        eprintln!("warning: {}", w.message);
    }
    let text = ex.to_file_text(&a.cal, &doc);
    // What was used with --allow-weak is said in the file too, under its first line.
    let text = match text.split_once('\n') {
        Some((first, rest)) if !said.is_empty() => format!("{first}\n{}{rest}", said.iter().map(|w| format!("# WARNING: {w}\n")).collect::<String>()),
        _ => text,
    };
    host_tools::files::write_text_atomic(&a.out, &text)?;
    eprintln!("wrote {} ({} parameters)", a.out.display(), ex.params.len());
    if a.json {
        println!("{}", serde_json::to_string_pretty(&ex)?);
    } else {
        println!("{} parameters for {} in {}; {} warning(s)", ex.params.len(), stack.name(), a.out.display(), ex.warnings.len());
    }
    Ok(())
}

/// What to change on this command line when the export refuses.
fn export_hint(e: &ExportError) -> Option<&'static str> {
    match e {
        ExportError::UnknownUnits { .. } => Some("give them with --raw-unit or --raw-nt-per-unit"),
        ExportError::Rotation { .. } => Some("raise --max-rotation-deg to export the symmetric part anyway"),
        ExportError::Gain { .. } => Some("check --raw-unit"),
        _ => None,
    }
}
