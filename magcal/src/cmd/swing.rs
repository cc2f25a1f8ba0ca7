//! `magcal swing`: the Fourier (swinging) heading calibration against a
//! reference heading.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::compute::{self, swing::WaterCurrentMode, Delay};
use host_tools::data::CalDoc;

use super::{check_out, emit, warn_all};

/// Arguments of `magcal swing`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
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
    /// Use GPS course over ground as heading, as it is (by default the water
    /// current is estimated from the surface fixes, `lat_deg`/`lon_deg`, and
    /// `speed_mps`, and the crab angle removed when the data allow; when they
    /// do not, a warning says why and course is used as it is).
    #[arg(long)]
    no_current: bool,
    /// Write the calibration document here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the calibration document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal swing`.
pub fn run(a: Args) -> Result<()> {
    if let Some(out) = &a.out {
        check_out("--out", out, &[&a.input, &a.cal])?;
    }
    let delay = match (a.delay_s, a.estimate_delay) {
        (Some(s), false) if s.is_finite() && s >= 0.0 => Delay::Given(s),
        (Some(s), false) => bail!("--delay-s must be a non-negative number of seconds, not {s}"),
        (None, true) => Delay::Estimate { max_s: a.max_delay_s },
        _ => bail!("give the reference delay with --delay-s S, or --estimate-delay"),
    };
    let doc = CalDoc::load(&a.cal)?;
    let rec = a.columns.read(&a.input)?;
    let mode = if a.no_current { WaterCurrentMode::Off } else { WaterCurrentMode::Auto };
    let (doc, fit, delay_s) =
        compute::swing::swing_recording_with(&rec, &doc, delay, mode).with_context(|| format!("{}: swing fit", a.input.display()))?;
    warn_all(&doc);
    let s = fit.swing;
    let current_removed = doc.quality.swing.as_ref().and_then(|q| q.current);
    if current_removed.is_none() && !has_reciprocal(fit.sectors.visited_mask()) {
        eprintln!(
            "warning: the headings hold one course (no reciprocal leg, no turn through the compass): against GPS course, which holds the water current's crab angle and the GPS delay, those go into A; the heading error after is against that course, not the calibration's own; swing over all headings, or run the course both ways"
        );
    }
    let current = match current_removed {
        Some(c) => format!(
            " against course less the crab angle in a current of {:.3}±{:.3} m/s north, {:.3}±{:.3} m/s east;",
            c.current_ne_mps[0], c.sigma_ne_mps[0], c.current_ne_mps[1], c.sigma_ne_mps[1]
        ),
        None => " against the reference heading as it is (GPS course holds the crab angle in a current and any delay left);".to_string(),
    };
    let summary = format!(
        "swing fit of {} pairs at delay {:.2} s:{current} A={:.5} B={:.5} C={:.5} D={:.5} E={:.5} rad; heading error {:.2}° → {:.2}° RMS",
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
    emit(&doc, &a.input, a.out.as_ref(), a.json, &summary)
}

/// Whether the 12 visited compass sectors (bit `k`: 30°·k …) include two
/// at least 150° apart: a reciprocal leg or a turn through the compass.
fn has_reciprocal(visited: u16) -> bool {
    let on = |k: u32| visited & (1 << (k % 12)) != 0;
    (0..12).any(|i| on(i) && (5..=7).any(|d| on(i + d)))
}
