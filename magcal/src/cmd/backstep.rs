//! `magcal backstep`: the back-stepping refinement on an out-and-back run.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use host_tools::compute::{self, BackstepMethod, BackstepOptions, RunReference, SwingMagnitudes};
use host_tools::data::{CalDoc, Recording};

use super::{emit, SiteArgs};

/// The solver, as the command line names it.
#[derive(Clone, Copy, ValueEnum)]
pub enum Method {
    /// Our joint least-squares refinement.
    Joint,
    /// Paper 000's corrections (axis model).
    Paper,
}

/// Arguments of `magcal backstep`.
#[derive(clap::Args)]
pub struct Args {
    /// The run (t, mx, my, mz, roll_deg, pitch_deg; lat_deg/lon_deg used when present).
    #[arg(long)]
    input: PathBuf,
    /// The calibration to refine (step 1).
    #[arg(long)]
    cal: PathBuf,
    #[command(flatten)]
    site: SiteArgs,
    /// Reference horizontal intensity, nT (instead of IGRF).
    #[arg(long)]
    field_h_nt: Option<f64>,
    /// Reference down component, nT (instead of IGRF).
    #[arg(long, allow_hyphen_values = true)]
    field_z_nt: Option<f64>,
    /// Solver: ours (joint) or the paper's.
    #[arg(long, value_enum, default_value = "joint")]
    method: Method,
    /// Time of the turnaround, seconds (default: found from the headings).
    #[arg(long)]
    turnaround_s: Option<f64>,
    /// The swing-test recording (thrusters off), to let the joint solver separate the running-only bias.
    #[arg(long)]
    swing_input: Option<PathBuf>,
    /// Write the calibration document here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the calibration document (with its trace) on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal backstep`.
pub fn run(a: Args) -> Result<()> {
    let reference = match (a.site.site()?, a.site.any(), a.field_h_nt, a.field_z_nt) {
        (Some(site), _, None, None) => RunReference::Igrf(site),
        (None, false, Some(h_nt), Some(z_nt)) => RunReference::Given { h_nt, z_nt },
        _ => bail!("give the reference as --lat/--lon/--date or as --field-h-nt/--field-z-nt"),
    };
    let doc = CalDoc::load(&a.cal)?;
    let rec = Recording::read(&a.input)?;
    let mut opts = BackstepOptions::new(reference);
    opts.method = match a.method {
        Method::Joint => BackstepMethod::Joint,
        Method::Paper => BackstepMethod::Paper,
    };
    opts.turnaround_s = a.turnaround_s;
    if let Some(p) = &a.swing_input {
        let swing = Recording::read(p)?;
        opts.swing = Some(SwingMagnitudes { raw: swing.complete_mag().1, field_nt: doc.field_nt });
    }
    let (out_doc, report) = compute::backstep_recording(&rec, &doc, &opts).with_context(|| format!("{}: back-stepping", a.input.display()))?;
    if !a.json {
        for e in out_doc.trace.iter().flatten() {
            eprintln!(
                "  iter {} {:<28} step {:>8.1} nT  Hh {:>8.1}  Hz {:>8.1}  F {:>8.1}",
                e.iteration,
                e.correction.label(),
                e.stats.step_nt,
                e.stats.hh_nt,
                e.stats.hz_nt,
                e.stats.f_nt
            );
        }
    }
    let summary = format!(
        "back-stepping ({}) around the turnaround at {:.0} s: step {:.1} → {:.1} nT, |F − IGRF| RMS {:.1} → {:.1} nT",
        opts.method.name(),
        report.turnaround_s,
        report.before.step_nt,
        report.after.step_nt,
        report.before.f_error_rms_nt,
        report.after.f_error_rms_nt
    );
    emit(&out_doc, a.out.as_ref(), a.json, &summary)
}
