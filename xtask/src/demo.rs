//! The demo session (the main job, shortened in `cargo xtask test`): the
//! firmware booted in QEMU, `magcal session` against it with the simulated
//! vehicle, the saved session reproduced offline, and the report checked in
//! headless Chromium.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context, Result};
use host_tools::doc::SessionSummary;
use host_tools::doc::CalDoc;

use super::{browser, root, run, say};
use crate::suite::{note, Suite};

/// `target/demo/summary.json`: the session's summary with where its logs,
/// report and deviation card are.
#[derive(serde::Serialize)]
pub struct DemoSummary {
    #[serde(flatten)]
    pub session: SessionSummary,
    firmware_log: PathBuf,
    /// The report page (self-contained HTML).
    pub report: PathBuf,
    /// The deviation card of the validation run against the truth.
    deviation_card: Option<DemoCard>,
    /// The report in headless Chromium (when a browser is installed).
    pub report_check: Option<ReportCheck>,
}

/// The deviation card's files.
#[derive(serde::Serialize)]
pub struct DemoCard {
    text: PathBuf,
    csv: PathBuf,
    json: PathBuf,
}

/// The report's browser check.
#[derive(serde::Serialize)]
pub struct ReportCheck {
    pub screenshot: PathBuf,
    /// Browser start to screenshot, s.
    pub render_s: f64,
    /// `ok`, or what is wrong.
    pub verdict: String,
}

/// Runs the saved session's `reproduce` commands (fit → backstep → swing)
/// on its recordings and checks they give the session's final coefficients
/// (field calibration, swing, and the current and temperature terms when
/// there are any: backstep reads `motor_current_a`/`temp_c` and swing
/// `speed_mps` from the saved run).
fn reproduce_offline(magcal: &Path, dir: &Path) -> Result<()> {
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let p = |n: &str| dir.join(n).to_string_lossy().to_string();
    run(Command::new(magcal).args(["fit", "--input", &p("swing.csv"), "--model", "axis", "--out", &p("offline_step1.json")]).args(site).stdout(Stdio::null()))?;
    run(Command::new(magcal).args(["backstep", "--input", &p("run.csv"), "--cal", &p("offline_step1.json"), "--swing-input", &p("swing.csv"), "--out", &p("offline_backstep.json")]).args(site).stdout(Stdio::null()).stderr(Stdio::null()))?;
    run(Command::new(magcal).args(["swing", "--input", &p("run.csv"), "--cal", &p("offline_backstep.json"), "--estimate-delay", "--out", &p("offline_final.json")]).stdout(Stdio::null()).stderr(Stdio::null()))?;
    let read = |n: &str| -> Result<CalDoc> { Ok(CalDoc::load(&dir.join(n))?) };
    let (a, b) = (read("cal_final.json")?, read("offline_final.json")?);
    let flat = |d: &CalDoc| -> Vec<f64> {
        let mut out: Vec<f64> = d.bias.to_vec();
        out.extend(d.matrix.iter().flatten());
        out.extend(d.swing.iter().flat_map(|s| [s.a, s.b, s.c, s.d, s.e]));
        out.extend(d.current.iter().flat_map(|c| c.bias_per_a));
        out.extend(d.temperature.iter().flat_map(|t| std::iter::once(t.ref_c).chain(t.gain_per_c)));
        out
    };
    let (fa, fb) = (flat(&a), flat(&b));
    if fa.len() < 17 || fa.len() != fb.len() || fa.iter().zip(&fb).any(|(x, y)| (x - y).abs() > 1e-9 * x.abs().max(1e-3)) {
        bail!("offline {fb:?} differs from the session's {fa:?}");
    }
    eprintln!("   the saved session reproduces offline (fit → backstep → swing) to 1e-9");
    Ok(())
}

/// Boots the firmware in QEMU and runs `magcal session` against it with the
/// simulated vehicle and the real-vehicle `effects` (`magcal session
/// --effects`); writes `<out_dir>/summary.json` and returns it.
pub fn demo_session(elf: &Path, magcal: &Path, out_dir: &Path, plan: &str, effects: &str) -> Result<DemoSummary> {
    use host_tools::board::{QemuBoard, QemuOptions};

    std::fs::create_dir_all(out_dir)?;
    say("booting the firmware on QEMU netduinoplus2 (STM32F405): USART1 = host link, USART2 = the simulated bridges");
    let mut opts = QemuOptions::new(elf);
    let log = out_dir.join("firmware.log");
    opts.log = Some(log.clone());
    opts.sensor_port = true;
    let board = QemuBoard::boot(&opts)?;
    let feed = board.sensor_port().context("QEMU did not open USART2's pty")?.to_string();
    eprintln!("   link {} · sensor feed {}", board.link_port(), feed);

    say(&format!("running the calibration session (magcal session --plan {plan} --effects {effects})"));
    let session_dir = out_dir.join("session");
    let out = Command::new(magcal)
        .args(["session", "--port", board.link_port(), "--sim-feed", &feed])
        .args(["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01", "--plan", plan, "--effects", effects, "--json"])
        .arg("--out")
        .arg(&session_dir)
        .stderr(Stdio::inherit())
        .output()
        .context("running magcal session")?;
    board.shutdown();
    if !out.status.success() {
        bail!("magcal session failed (firmware log: {})", log.display());
    }
    let session: SessionSummary = serde_json::from_slice(&out.stdout).context("magcal session --json output")?;
    let report_dir = session_dir.join("report");
    let report = report_dir.join("index.html");
    if !report.is_file() {
        bail!("the session wrote no report ({})", report.display());
    }
    let card = DemoCard { text: report_dir.join("deviation_card.txt"), csv: report_dir.join("deviation_card.csv"), json: report_dir.join("deviation_card.json") };
    let deviation_card = [&card.text, &card.csv, &card.json].iter().all(|p| p.is_file()).then_some(card);
    if deviation_card.is_none() {
        eprintln!("   no deviation card: the session had no validation run with a truth heading");
    }
    let report_check = browser::find().map(|_| match browser::check_report(&report) {
        Ok(r) => {
            eprintln!("   report in headless Chromium: {:.2} s, {:.1} % ink, console empty", r.render_s, r.ink * 100.0);
            ReportCheck { screenshot: r.png, render_s: r.render_s, verdict: "ok".into() }
        }
        Err(e) => ReportCheck { screenshot: PathBuf::new(), render_s: f64::NAN, verdict: format!("{e:#}") },
    });
    let summary = DemoSummary { session, firmware_log: log, report, deviation_card, report_check };
    std::fs::write(out_dir.join("summary.json"), serde_json::to_string_pretty(&summary)?)?;
    let v = summary.session.validation;
    eprintln!(
        "   true heading RMS on the validation run: {:.2}° before → {:.2}° after (predicted {:.2}°, observed/predicted {:.2}); |F| − {} after: {:.1} nT; coefficients verified: {}",
        v.map_or(f64::NAN, |v| v.heading_rms_deg_before),
        v.map_or(f64::NAN, |v| v.heading_rms_deg_after),
        summary.session.predicted_heading_rms_deg.unwrap_or(f64::NAN),
        summary.session.heading_rms_observed_over_predicted.unwrap_or(f64::NAN),
        if v.is_some_and(|v| v.field_against_truth) { "true local field" } else { "IGRF" },
        v.map_or(f64::NAN, |v| v.field_error_nt_after),
        summary.session.coefficients_verified
    );
    eprintln!("   report: {}", summary.report.display());
    if let Some(c) = &summary.deviation_card {
        eprintln!("   deviation card: {} (also .csv, .json)", c.text.display());
    }
    eprintln!("   summary: {}", out_dir.join("summary.json").display());
    Ok(summary)
}

/// The demo gate of `cargo xtask test`: the shortened session against the
/// QEMU board, within bounds and reproducible offline. Returns the summary
/// too (the browser gate reads its report check).
pub fn session_gate(elf: &Path, magcal: &Path) -> (Suite, Option<DemoSummary>) {
    // With the real-vehicle effects but the anomaly (magcal_sim::SHORT_TEST_EFFECTS):
    // the chain's |F| reference is IGRF, so with the anomaly the field
    // error against the true field exceeds this check's bound; the demo
    // runs all five.
    let out_dir = root().join("target").join("demo-test");
    let demo = demo_session(elf, magcal, &out_dir, "short", magcal_sim::SHORT_TEST_EFFECTS);
    let ok = match &demo {
        Ok(s) => {
            let v = s.session.validation;
            let before = v.map_or(f64::NAN, |v| v.heading_rms_deg_before);
            let after = v.map_or(f64::NAN, |v| v.heading_rms_deg_after);
            let field = v.map_or(f64::NAN, |v| v.field_error_nt_after);
            let verified = s.session.coefficients_verified;
            let reproduced = reproduce_offline(magcal, &out_dir.join("session"));
            if let Err(e) = &reproduced {
                note(&format!("the saved session does not reproduce offline: {e:#}"));
            }
            // Measured 2026-11-22 (short plan, no effects): 8.97° → 0.24°, 11.0 nT (were ≤ 0.5°, ≤ 50 nT).
            // With the effects, offline (sim vehicle.rs tests): 0.27°, 16 nT.
            let ok = verified && after <= 0.35 && after < before / 5.0 && field <= 30.0 && reproduced.is_ok();
            if !ok {
                note(&format!("demo session out of bounds: heading {before:.2}° → {after:.2}°, field {field:.1} nT, verified {verified}"));
            }
            ok
        }
        Err(e) => {
            note(&format!("demo session failed: {e:#}"));
            false
        }
    };
    (Suite::gate("demo session: heading ≤ 0.35° and field ≤ 30 nT after, verified upload", ok), demo.ok())
}

/// The report gate: the demo session's page in a real browser. (That the
/// check fails a blank page and a console error is proven by browser.rs's
/// unit tests, which run in the host suite with the browser installed.)
pub fn report_gate(demo: Option<&DemoSummary>) -> Suite {
    say("the report in headless Chromium: a non-blank screenshot and an empty console");
    let page = match demo {
        Some(s) => s.report.clone(),
        None => root().join("target").join("demo-test").join("session").join("report").join("index.html"),
    };
    // The demo session checked its own page when the browser was there.
    let ok = match demo.and_then(|s| s.report_check.as_ref()) {
        Some(c) if c.verdict == "ok" => {
            note(&format!("   {}: rendered in {:.2} s by the demo session; screenshot {}", page.display(), c.render_s, c.screenshot.display()));
            true
        }
        Some(c) => {
            note(&format!("the report fails in the browser: {}", c.verdict));
            false
        }
        None => match browser::check_report(&page) {
            Ok(r) => {
                note(&format!("   {}: rendered in {:.2} s, {:.1} % ink, console empty; screenshot {}", page.display(), r.render_s, r.ink * 100.0, r.png.display()));
                true
            }
            Err(e) => {
                note(&format!("the report fails in the browser: {e:#}"));
                false
            }
        },
    };
    Suite::gate("report in headless Chromium: non-blank, empty console, self-contained", ok)
}
