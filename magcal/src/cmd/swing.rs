//! `magcal swing`: the Fourier (swinging) heading calibration against a
//! reference heading — of a magnetometer's heading (with its field
//! calibration, `--cal`), or of a heading-only compass's own heading (a
//! recording with `compass_heading_deg` and no `--cal`).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::compute::{swing_compass, DeclinationSource};
use host_tools::compute::{self, Delay, WaterCurrentMode};
use host_tools::doc::CalDoc;

use super::{check_out, emit, warn_all};

/// Arguments of `magcal swing`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
    /// Recording with t, mx, my, mz, roll_deg, pitch_deg, ref_heading_deg;
    /// or, for a heading-only compass (no --cal), t, compass_heading_deg,
    /// ref_heading_deg.
    #[arg(long)]
    input: PathBuf,
    /// The field calibration to start from (none: the recording is a
    /// heading-only compass's, and the swing is fitted to its heading).
    #[arg(long)]
    cal: Option<PathBuf>,
    /// Known delay of the reference behind the heading, seconds.
    #[arg(long, conflicts_with = "estimate_delay", allow_hyphen_values = true)]
    delay_s: Option<f64>,
    /// Estimate the delay from the data.
    #[arg(long)]
    estimate_delay: bool,
    /// Upper bound of the delay search, seconds.
    #[arg(long, default_value_t = 5.0)]
    max_delay_s: f64,
    /// Lower bound of the delay search, seconds (default 0 for a
    /// magnetometer; −max for a compass, whose damping can put its heading
    /// behind the reference).
    #[arg(long, allow_hyphen_values = true)]
    min_delay_s: Option<f64>,
    /// Declination for a heading-only compass, degrees east (default: the
    /// log's own `variation_deg`; without either, A holds it).
    #[arg(long, allow_hyphen_values = true)]
    declination_deg: Option<f64>,
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
    /// Refuse a delay search that stopped at its window's edge (by default
    /// it is warned about and written in `quality.swing.delay_search.at_edge_s`).
    #[arg(long)]
    strict: bool,
    /// Use a weak field calibration (its own reference check failed: `fit
    /// --allow-weak`): kept, and said.
    #[arg(long)]
    allow_weak: bool,
}

/// With `--strict`, a delay search stopped at its window's edge is refused.
fn strict_edge(a: &Args, q: Option<&host_tools::doc::SwingQuality>) -> Result<()> {
    if let (true, Some(q)) = (a.strict, q) {
        if let Some((Some(b), [lo, hi])) = q.delay_search.as_ref().map(|d| (d.at_edge_s, d.window_s)) {
            bail!(
                "{}: the delay search stopped at its window's edge ({:.2} s found in [{lo}, {hi}] s, at {b} s): the delay is the window's, not the data's; widen --min-delay-s/--max-delay-s, or give --delay-s (refused with --strict)",
                a.input.display(),
                q.delay_s
            );
        }
    }
    Ok(())
}

/// Runs `magcal swing`.
pub fn run(a: Args) -> Result<()> {
    if let Some(out) = &a.out {
        let mut inputs = vec![a.input.as_path()];
        inputs.extend(a.cal.as_deref());
        check_out("--out", out, &inputs)?;
    }
    let compass = a.cal.is_none();
    let min_s = a.min_delay_s.unwrap_or(if compass { -a.max_delay_s } else { 0.0 });
    let delay = match (a.delay_s, a.estimate_delay) {
        (Some(s), false) if s.is_finite() && (compass || s >= 0.0) && s.abs() < 3600.0 => Delay::Given(s),
        (Some(s), false) => bail!("--delay-s must be a{} number of seconds, not {s}", if compass { "" } else { " non-negative" }),
        (None, true) if a.max_delay_s.is_finite() && min_s.is_finite() && a.max_delay_s > min_s => Delay::Estimate { min_s, max_s: a.max_delay_s },
        (None, true) => bail!("the delay search needs --min-delay-s below --max-delay-s (got {min_s} and {})", a.max_delay_s),
        _ => bail!("give the reference delay with --delay-s S, or --estimate-delay"),
    };
    if let Some(d) = a.declination_deg {
        if compass && !(d.is_finite() && d.abs() <= 180.0) {
            bail!("--declination-deg must be within ±180, not {d}");
        }
    }
    let mode = if a.no_current { WaterCurrentMode::Off } else { WaterCurrentMode::Auto };
    let Some(cal) = &a.cal else { return run_compass(&a, delay, mode) };
    if a.declination_deg.is_some() {
        bail!("--declination-deg is for a heading-only compass (no --cal); a field calibration carries its own declination");
    }
    let (doc, said) = CalDoc::load_with(cal, a.allow_weak).map_err(|e| super::hinted(e, super::weak_hint))?;
    for w in &said {
        eprintln!("warning: {w}");
    }
    let rec = a.columns.read(&a.input)?;
    let (mut doc, fit, delay_s) =
        compute::swing_recording_with(&rec, &doc, delay, mode).with_context(|| format!("{}: swing fit", a.input.display()))?;
    warn_all(&doc);
    // What was used with --allow-weak goes into the document too (said on stderr above).
    if let Some(q) = doc.quality.swing.as_mut() {
        q.warnings.extend(said);
    }
    strict_edge(&a, doc.quality.swing.as_ref())?;
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
        "swing fit of {} pairs at delay {:.2} s:{current} A={:.5} B={:.5} C={:.5} D={:.5} E={:.5} rad; heading error {:.2}° → {:.2}° RMS{}",
        fit.samples,
        delay_s,
        s.a,
        s.b,
        s.c,
        s.d,
        s.e,
        fit.before_rms_rad.to_degrees(),
        fit.residual_rms_rad.to_degrees(),
        held_out_text(doc.quality.swing.as_ref()),
    );
    emit(&doc, &a.input, a.out.as_ref(), a.json, &summary)
}

/// The heading-only compass's swing: the document holds only the swing.
fn run_compass(a: &Args, delay: Delay, mode: WaterCurrentMode) -> Result<()> {
    let log = a.columns.read_compass(&a.input).context("a swing without --cal is a heading-only compass's: the recording needs t and compass_heading_deg (with --cal, a magnetometer's field calibration is swung)")?;
    let (doc, fit, delay_s, source) = swing_compass(&log, a.declination_deg, delay, mode).with_context(|| format!("{}: compass swing fit", a.input.display()))?;
    let q = doc.quality.swing.as_ref();
    for w in q.map(|q| q.warnings.as_slice()).unwrap_or_default() {
        eprintln!("warning: {w}");
    }
    strict_edge(a, q)?;
    let s = fit.swing;
    let declination = match (source, doc.declination_deg) {
        (DeclinationSource::InA, _) | (_, None) => "no declination (A holds it)".to_string(),
        (DeclinationSource::Given, Some(d)) => format!("declination {d:+.2}° given"),
        (DeclinationSource::Log, Some(d)) => format!("declination {d:+.2}° from the log"),
    };
    let summary = format!(
        "compass swing fit of {} pairs at delay {:.2} s, {declination}: A={:.2}° B={:.2}° C={:.2}° D={:.2}° E={:.2}°; compass − reference {:.2}° → {:.2}° RMS{}",
        fit.samples,
        delay_s,
        s.a.to_degrees(),
        s.b.to_degrees(),
        s.c.to_degrees(),
        s.d.to_degrees(),
        s.e.to_degrees(),
        fit.before_rms_rad.to_degrees(),
        fit.residual_rms_rad.to_degrees(),
        held_out_text(q),
    );
    match &a.out {
        Some(path) => {
            doc.save(path).with_context(|| format!("{}: saving the calibration", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
        None => eprintln!("note: no --out given: the calibration is printed, not saved"),
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&doc)?);
    } else {
        println!("{summary}");
    }
    Ok(())
}

/// "; held out: x° → y° RMS" when the fit has its held-out check.
fn held_out_text(q: Option<&host_tools::doc::SwingQuality>) -> String {
    match q.and_then(|q| q.held_out) {
        Some(h) => format!("; held out (each half by the other's swing): {:.2}° → {:.2}° RMS over {} pairs", h.before_rms_deg, h.after_rms_deg, h.pairs),
        None => String::new(),
    }
}

/// Whether the 12 visited compass sectors (bit `k`: 30°·k …) include two
/// at least 150° apart: a reciprocal leg or a turn through the compass.
fn has_reciprocal(visited: u16) -> bool {
    let on = |k: u32| visited & (1 << (k % 12)) != 0;
    (0..12).any(|i| on(i) && (5..=7).any(|d| on(i + d)))
}
