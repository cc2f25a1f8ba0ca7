//! `magcal swing`: the Fourier (swinging) heading calibration against a
//! reference heading.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::compute::{self, Delay};
use host_tools::data::{CalDoc, Recording};

use super::{emit, warn_all};

/// Arguments of `magcal swing`.
#[derive(clap::Args)]
pub struct Args {
    /// Recording with t, mx, my, mz, roll_deg, pitch_deg, ref_heading_deg.
    #[arg(long)]
    input: PathBuf,
    /// The field calibration to start from.
    #[arg(long)]
    cal: PathBuf,
    /// Known delay of the reference behind the magnetometer, seconds.
    #[arg(long, conflicts_with = "estimate_delay")]
    delay_s: Option<f64>,
    /// Estimate the delay from the data.
    #[arg(long)]
    estimate_delay: bool,
    /// Upper bound of the delay search, seconds.
    #[arg(long, default_value_t = 5.0)]
    max_delay_s: f64,
    /// Write the calibration document here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the calibration document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal swing`.
pub fn run(a: Args) -> Result<()> {
    let delay = match (a.delay_s, a.estimate_delay) {
        (Some(s), false) if s.is_finite() && s >= 0.0 => Delay::Given(s),
        (Some(s), false) => bail!("--delay-s must be a non-negative number of seconds, not {s}"),
        (None, true) => Delay::Estimate { max_s: a.max_delay_s },
        _ => bail!("give the reference delay with --delay-s S, or --estimate-delay"),
    };
    let doc = CalDoc::load(&a.cal)?;
    let rec = Recording::read(&a.input)?;
    let (doc, fit, delay_s) = compute::swing_recording(&rec, &doc, delay).with_context(|| format!("{}: swing fit", a.input.display()))?;
    warn_all(&doc);
    let s = fit.swing;
    let summary = format!(
        "swing fit of {} pairs at delay {:.2} s: A={:.5} B={:.5} C={:.5} D={:.5} E={:.5} rad; heading error {:.2}° → {:.2}° RMS",
        fit.samples,
        delay_s,
        s.a,
        s.b,
        s.c,
        s.d,
        s.e,
        fit.before_rms_rad.to_degrees(),
        fit.residual_rms_rad.to_degrees()
    );
    emit(&doc, a.out.as_ref(), a.json, &summary)
}
