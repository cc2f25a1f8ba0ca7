//! `magcal fit`: a field (ellipsoid) calibration from a recording.

use std::path::PathBuf;

use anyhow::{Context, Result};
use calib_core::cal::ModelKind;
use host_tools::compute::MODELS;
use host_tools::compute::{self, FitOptions, GyroLag};
use host_tools::doc::model_kind;
use host_tools::data::Recording;

use super::{check_out, emit, hinted, reference_field, warn_all, SiteArgs};
use host_tools::compute::{ComputeError, GyroError};
use host_tools::doc::HeldOutBasis;
use host_tools::doc::Reference;

/// `--model`: `auto` or one model.
#[derive(Debug, Clone, Copy)]
enum ModelArg {
    /// Every allowed model judged on held-out data.
    Auto,
    /// This model.
    Kind(ModelKind),
}

/// `--model`: `auto` or calib-core's `ModelKind` by its document name.
fn model_parser() -> impl clap::builder::TypedValueParser<Value = ModelArg> {
    use clap::builder::{PossibleValue, PossibleValuesParser, TypedValueParser};
    let auto = PossibleValue::new("auto").help("Every model the recording's columns allow, each judged on held-out time blocks of the recording; the best kept (the default)");
    PossibleValuesParser::new(std::iter::once(auto).chain(MODELS.iter().map(|e| PossibleValue::new(e.kind.name()).help(e.help))))
    .try_map(|name| if name == "auto" { Ok(ModelArg::Auto) } else { model_kind(&name).map(ModelArg::Kind).ok_or_else(|| format!("unknown model `{name}`")) })
}

/// Arguments of `magcal fit`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
    /// Recording (CSV with mx, my, mz).
    #[arg(long)]
    input: PathBuf,
    /// Calibration model (default `auto`).
    #[arg(long, value_parser = model_parser(), default_value = "auto")]
    model: ModelArg,
    /// Reference field intensity, nT.
    #[arg(long)]
    field_nt: Option<f64>,
    #[command(flatten)]
    site: SiteArgs,
    /// Raw magnitude at which the sensor saturates (per axis).
    #[arg(long)]
    saturation: Option<f64>,
    /// The magnetometer's lag behind the gyro, s (gyro model): the rates are
    /// read this much earlier than each field sample.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, conflicts_with = "estimate_gyro_lag")]
    gyro_lag_s: f64,
    /// Estimate that lag from the data instead (gyro model; within ±0.25 s).
    #[arg(long)]
    estimate_gyro_lag: bool,
    /// Return coefficients even when the quality gates fail (with `auto`:
    /// keep the least held-out error even when it, or the model's own
    /// expected error, is not below the limit; the document says so).
    #[arg(long)]
    allow_weak: bool,
    /// Write the calibration document here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the calibration document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal fit`.
pub fn run(a: Args) -> Result<()> {
    if let Some(out) = &a.out {
        check_out("--out", out, &[&a.input])?;
    }
    // The site's world model judges the fit; --field-nt with a site is the
    // local intensity the calibration is scaled to, checked against it.
    let site = a.site.site()?;
    let reference = match (a.field_nt, &site) {
        (Some(f), Some(s)) => {
            super::check_field_nt(f, "--field-nt")?;
            let w = s.field()?;
            let k = f / w.total_nt();
            host_tools::geomag::Field { north_nt: k * w.north_nt, east_nt: k * w.east_nt, down_nt: k * w.down_nt }
        }
        _ => reference_field(a.field_nt, &a.site)?,
    };
    let world = match &site {
        Some(s) => Some(Reference::world_model(*s, &s.field()?)),
        None => None,
    };
    let rec = a.columns.read(&a.input)?;
    let site_weak = a.site.check_recording(&rec, &a.input, a.allow_weak)?;
    let opts = FitOptions { model: match a.model { ModelArg::Kind(m) => m, ModelArg::Auto => ModelKind::Attitude }, field_nt: reference.total_nt(), saturation: a.saturation, allow_weak: a.allow_weak, gyro_lag: if a.estimate_gyro_lag { GyroLag::Estimate } else { GyroLag::Given(a.gyro_lag_s) }, reference: world };
    let working = super::working(&format!("fitting {} rows", rec.len()), a.json);
    let mut doc = match a.model {
        ModelArg::Kind(model) => compute::fit_recording(&rec, &opts).map_err(|e| hinted(e, fit_hint)).with_context(|| format!("{}: {} fit", a.input.display(), model.name()))?,
        ModelArg::Auto => {
            let (doc, choice) = compute::fit_auto(&rec, &opts).map_err(|e| hinted(e, fit_hint)).with_context(|| format!("{}: model auto", a.input.display()))?;
            working.done();
            eprintln!("model auto: held-out errors against {}:", basis_words(choice.basis));
            for row in &choice.candidates {
                let held = row.held_out_deg.map_or("—".to_string(), |h| format!("{h:.2}°"));
                let predicted = row.predicted_deg.map_or("—".to_string(), |p| format!("{p:.2}°"));
                let expected = row.expected_deg.map_or("—".to_string(), |p| format!("{p:.2}°"));
                eprintln!("  {:<9} held-out {held:>7}  covariance {predicted:>7}  expected {expected:>7}  {}", row.model, row.refused.as_deref().or(row.note.as_deref()).unwrap_or(""));
            }
            match &choice.kept_weak {
                Some(why) => eprintln!("  kept {}: {why}", choice.chosen),
                None => eprintln!("  kept {} (the least held-out error of those whose held-out and own expected errors are below {}°)", choice.chosen, host_tools::doc::MAX_HELD_OUT_DEG),
            }
            doc
        }
    };
    working.done();
    if a.site.lat.is_some() {
        doc.declination_deg = Some(reference.declination_deg());
    }
    // The site check kept with --allow-weak travels with the document.
    doc.quality.allowed_weak.extend(site_weak.into_iter().map(|w| format!("fit: {w}")));
    warn_all(&doc);
    print_environment_columns(&rec);
    let summary = match &doc.quality.fit {
        Some(q) => format!(
            "{} fit of {} samples: bias {:?}, residual {:.1} nT RMS ({:.2} %), coverage {} %",
            doc.model.name(),
            q.samples,
            doc.bias,
            q.residual_rms_nt,
            q.residual_rms_pct,
            q.coverage_pct
        ),
        None => format!("{} fit: bias {:?}", doc.model.name(), doc.bias),
    };
    emit(&doc, &a.input, a.out.as_ref(), a.json, &summary)
}

/// What the held-out errors of `auto` are measured against, in words.
fn basis_words(b: HeldOutBasis) -> &'static str {
    match b {
        HeldOutBasis::ReferenceHeading => "the recording's ref_heading_deg (one constant offset removed)",
        HeldOutBasis::GyroYaw => "the integrated gyro yaw (each held-out stretch's heading changes) with the reference field's dip and horizontal intensity, in quadrature",
        HeldOutBasis::FieldAndDip => "the reference field (each held-out sample's dip and horizontal intensity)",
        HeldOutBasis::Intensity => "the reference intensity (no roll and pitch)",
    }
}

/// What to change on this command line when the fit refuses.
fn fit_hint(e: &ComputeError) -> Option<&'static str> {
    match e {
        ComputeError::NoReference => Some("give the reference field intensity with --field-nt (nT) or --lat/--lon/--date"),
        ComputeError::Gyro(GyroError::LagOutOfRange { .. }) => Some("give --gyro-lag-s within ±1 s"),
        ComputeError::AnglesLookLikeRadians { .. } => Some("if they are radians, say so: --columns roll_deg=roll_deg:rad,pitch_deg=pitch_deg:rad"),
        ComputeError::Coverage { .. } => Some("choose the model with --model NAME"),
        ComputeError::Disagrees { .. } => Some("check the site (--lat/--lon/--date), --field-nt and the roll/pitch columns' units; --allow-weak keeps the fit with the disagreement written into the document"),
        _ => None,
    }
}

/// Says what the recording's current and temperature columns span: the
/// field fit does not model them (a swing test is made thrusters off at one
/// temperature); `magcal backstep` estimates them from the run.
fn print_environment_columns(rec: &Recording) {
    let span = |c: &Option<Vec<f64>>| {
        let v: Vec<f64> = c.iter().flatten().copied().filter(|x| x.is_finite()).collect();
        (!v.is_empty()).then(|| (v.iter().copied().fold(f64::MAX, f64::min), v.iter().copied().fold(f64::MIN, f64::max)))
    };
    if let Some((lo, hi)) = span(&rec.motor_current_a) {
        eprintln!("  motor_current_a {lo:.1} … {hi:.1} A: not modelled by the field fit; `magcal backstep` estimates the per-ampere field from the run");
    }
    if let Some((lo, hi)) = span(&rec.temp_c) {
        eprintln!("  temp_c {lo:.1} … {hi:.1} °C: not modelled by the field fit; `magcal backstep` estimates the gains from the run");
    }
}
