//! `magcal backstep`: the back-stepping refinement on an out-and-back run.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::ValueEnum;
use host_tools::compute::{self, BackstepOptions, RunReference, SwingMagnitudes};
use host_tools::doc::BackstepMethod;
use host_tools::doc::CalDoc;

use super::{check_field_nt, check_out, emit, hinted, SiteArgs};
use host_tools::compute::{check_given_field, shown, world_field_for};
use host_tools::compute::ComputeError;

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
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
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
    /// A thrust test (hold heading, step the thrusters; two headings ~90° apart), with motor_current_a, roll_deg, pitch_deg: lets the joint solver separate the per-ampere field when the run's current hardly varies.
    #[arg(long)]
    thrust_input: Option<PathBuf>,
    /// Write the calibration document here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the calibration document (with its trace) on stdout.
    #[arg(long)]
    json: bool,
    /// Use a weak document (its own reference check failed: `fit
    /// --allow-weak`), or --field-h-nt/--field-z-nt beyond their allowance
    /// against the world model or the recording's own dip: kept, and said.
    #[arg(long)]
    allow_weak: bool,
}

/// Runs `magcal backstep`.
pub fn run(a: Args) -> Result<()> {
    if let Some(out) = &a.out {
        let inputs: Vec<&std::path::Path> = [Some(&a.input), Some(&a.cal), a.swing_input.as_ref(), a.thrust_input.as_ref()].into_iter().flatten().map(|p| p.as_path()).collect();
        check_out("--out", out, &inputs)?;
    }
    let reference = match (a.site.site()?, a.site.any(), a.field_h_nt, a.field_z_nt) {
        (Some(site), _, None, None) => RunReference::Igrf(site),
        (None, false, Some(h_nt), Some(z_nt)) => {
            check_field_nt(h_nt.hypot(z_nt), "--field-h-nt/--field-z-nt give an intensity of")?;
            RunReference::Given { h_nt, z_nt }
        }
        _ => bail!("give the reference as --lat/--lon/--date or as --field-h-nt/--field-z-nt"),
    };
    // The one document check (a step-1 calibration fitted to a field in
    // other units — µT typed for nT — is refused there: nothing after it
    // could be right).
    let (doc, warnings) = CalDoc::load_with(&a.cal, a.allow_weak).map_err(|e| hinted(e, super::weak_hint))?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let rec = a.columns.read(&a.input)?;
    // The checks this run failed and kept (--allow-weak): marked in the
    // document it writes, so its readers refuse it unless allowed too.
    let mut allowed_weak = a.site.check_recording(&rec, &a.input, a.allow_weak)?;
    if let RunReference::Given { h_nt, z_nt } = reference {
        // Against physics (refused), the world model where the document's
        // site gives a date, and the dip the run shows through the
        // calibration it refines (refused unless --allow-weak).
        let world = world_field_for(&rec, doc.reference.as_ref().and_then(|r| r.site));
        let (data_dip, _) = shown(&doc.field_cal(), &rec);
        let words = check_given_field(h_nt, z_nt, world.as_ref(), data_dip).map_err(|e| anyhow::anyhow!("--field-h-nt {h_nt} --field-z-nt {z_nt}: {e}"))?;
        if !words.is_empty() {
            super::weak_or_refused(&mut allowed_weak, a.allow_weak, Err(anyhow::anyhow!("--field-h-nt {h_nt} --field-z-nt {z_nt}: {}", words.join("; "))))?;
        }
    }
    let mut opts = BackstepOptions::new(reference);
    opts.method = match a.method {
        Method::Joint => BackstepMethod::Joint,
        Method::Paper => BackstepMethod::Paper,
    };
    opts.turnaround_s = a.turnaround_s;
    if let Some(p) = &a.swing_input {
        let swing = a.columns.read(p)?;
        opts.swing = Some(SwingMagnitudes::from_recording(&swing, doc.field_nt));
    }
    if let Some(p) = &a.thrust_input {
        opts.thrust_test = Some(a.columns.read(p)?);
    }
    let working = super::working(&format!("back-stepping {} rows", rec.len()), a.json);
    let (mut out_doc, report) = compute::backstep_recording(&rec, &doc, &opts)
        .map_err(|e| {
            // A calibration the paper's solver cannot start from is the document's problem.
            let blamed = if matches!(e, ComputeError::PaperNeedsAxis { .. }) { &a.cal } else { &a.input };
            hinted(e, backstep_hint).context(format!("{}: back-stepping", blamed.display()))
        })?;
    drop(working);
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
    if let Some(e) = out_doc.quality.backstep.as_ref().and_then(|b| b.estimates.as_ref()) {
        print_estimates(e, a.swing_input.is_some());
        check_field_nt(e.local_hz_nt[0].hypot(e.local_hz_nt[1]), &format!("{}: the back-stepped local field", a.input.display()))?;
    }
    // What was kept with --allow-weak goes into the document too.
    if let Some(f) = out_doc.quality.fit.as_mut() {
        f.warnings.extend(warnings);
        f.warnings.extend(allowed_weak.iter().cloned());
    }
    out_doc.quality.allowed_weak.extend(allowed_weak.into_iter().map(|w| format!("backstep: {w}")));
    check_field_nt(report.after.f_nt, &format!("{}: the run's mean field through the back-stepped calibration", a.input.display()))?;
    let summary = format!(
        "back-stepping ({}) around the turnaround at {:.0} s: step {:.1} → {:.1} nT, |F − IGRF| RMS {:.1} → {:.1} nT",
        opts.method.name(),
        report.turnaround_s,
        report.before.step_nt,
        report.after.step_nt,
        report.before.f_error_rms_nt,
        report.after.f_error_rms_nt
    );
    emit(&out_doc, &a.input, a.out.as_ref(), a.json, &summary)
}

/// What to change on this command line when the back-stepping refuses.
fn backstep_hint(e: &ComputeError) -> Option<&'static str> {
    match e {
        ComputeError::NoTurnaround => Some("give it with --turnaround-s"),
        ComputeError::PaperNeedsAxis { .. } => Some("fit with --model axis first"),
        _ => None,
    }
}

/// Prints the joint solver's estimates with their 1σ on stderr; without a
/// swing test (`with_swing` false) it says the two biases are not separable.
pub fn print_estimates(e: &host_tools::doc::JointEstimates, with_swing: bool) {
    let v3 = |v: [f64; 3], k: f64| format!("[{:.4}, {:.4}, {:.4}]", v[0] * k, v[1] * k, v[2] * k);
    if let Some(c) = &e.bias_per_a_raw {
        eprintln!("  thruster field per A    {} ± {} raw/A", v3(c.value, 1.0), v3(c.sigma, 1.0));
    }
    if let Some(k) = &e.gain_per_c {
        eprintln!("  gain per °C (ref {:.1} °C) {} ± {} %/°C", e.ref_c, v3(k.value, 100.0), v3(k.sigma, 100.0));
    }
    eprintln!("  resting bias            {} ± {} raw", v3(e.bias_raw.value, 1.0), v3(e.bias_raw.sigma, 1.0));
    if e.bias_per_a_raw.is_none() {
        eprintln!("  running-only bias       {} ± {} raw", v3(e.running_bias_raw.value, 1.0), v3(e.running_bias_raw.sigma, 1.0));
        if !with_swing {
            eprintln!("  note: without --swing-input (a thrusters-off swing test) the resting and running-only biases are not observable apart: only their sum is; the ± above say so");
        }
    }
    eprintln!(
        "  local field             H {:.0} nT, Z {:.0} nT (inclination {:+.3}° ± {:.3}° from IGRF; intensity IGRF's ± {:.0} nT, not observable)",
        e.local_hz_nt[0], e.local_hz_nt[1], e.local_inclination_offset_deg, e.local_inclination_sigma_deg, e.intensity_sigma_nt
    );
    if let (Some(m), Some(s)) = (e.misalignment_deg, e.misalignment_sigma_deg) {
        eprintln!("  AHRS misalignment       roll {:+.2}° ± {:.2}°, pitch {:+.2}° ± {:.2}°", m[0], s[0], m[1], s[1]);
    }
    eprintln!("  residual RMS            {:.1} nT", e.residual_rms_nt);
    eprintln!("  predicted heading error {:.3}° RMS (1σ over level headings)", e.predicted_heading_rms_deg);
    eprintln!("  {}", e.guidance);
    for n in &e.notes {
        eprintln!("  note: {n}");
    }
}
