//! Project workflows, run as `cargo xtask <command>`:
//!
//! * `test` — every suite: host unit tests, the on-target suite on the
//!   Cortex-M4F under QEMU, the board release build with its flash/RAM
//!   report, and the end-to-end suite (firmware in QEMU, magcal over a pty).
//!   Ends with the plain line `N passed, N failed`.
//! * `demo` — the main job: boots the firmware in QEMU and runs a session
//!   against it through magcal's serial code.
//! * `size` — the board build's flash and RAM use.
//!
//! Each installs what is missing on a fresh machine (the rustup target,
//! `qemu-system-arm` and `chromium` through apt-get when root, the
//! cargo-installed runner and log decoder) and says what it is doing.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};

use anyhow::{bail, Context, Result};
use host_tools::data::results::SessionSummary;
use host_tools::data::CalDoc;

mod bench;
mod browser;
mod size;

const TARGET: &str = "thumbv7em-none-eabihf";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => cmd_test(),
        Some("demo") => cmd_demo(),
        Some("size") => cmd_size().map(|_| ()),
        Some("bench") => bench::run(&root().join("target").join("bench")),
        Some("check-report") => cmd_check_report(args.get(1).map(PathBuf::from)),
        _ => {
            eprintln!("usage: cargo xtask <test|demo|size|bench>");
            eprintln!("  test   run every suite (host, on-target in QEMU, end-to-end)");
            eprintln!("  demo   boot the firmware in QEMU and run a session against it");
            eprintln!("  size   flash/RAM of the board release build");
            eprintln!("  bench  accuracy benchmarks (target/bench/results.{{json,md}})");
            eprintln!("  check-report [PAGE]  render a report in headless Chromium and check it (default: target/demo/session/report/index.html)");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn root() -> PathBuf {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    root.canonicalize().unwrap_or(root)
}

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(root());
    c
}

fn say(msg: &str) {
    eprintln!("\n== {msg}");
}

fn have(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

fn run(cmd: &mut Command) -> Result<()> {
    let status = cmd.status().with_context(|| format!("running {cmd:?}"))?;
    if !status.success() {
        bail!("{cmd:?} failed ({status})");
    }
    Ok(())
}

/// Installs what the workflows need and is missing.
fn ensure_tools() -> Result<()> {
    let installed = Command::new("rustup").args(["target", "list", "--installed"]).output();
    match installed {
        Ok(out) if String::from_utf8_lossy(&out.stdout).lines().any(|l| l.trim() == TARGET) => {}
        Ok(_) => {
            say(&format!("installing the Rust target {TARGET}"));
            run(Command::new("rustup").args(["target", "add", TARGET]))?;
        }
        Err(e) => bail!("rustup not found ({e}); install the {TARGET} target for your toolchain"),
    }
    if !Command::new("cargo").args(["clippy", "--version"]).stdout(Stdio::null()).stderr(Stdio::null()).status().map(|s| s.success()).unwrap_or(false) {
        say("installing clippy (rustup component add clippy)");
        run(Command::new("rustup").args(["component", "add", "clippy"]))?;
    }
    let mut apt_updated = false;
    for (present, package, why) in [(have("qemu-system-arm"), "qemu-system-arm", "the emulated board"), (browser::find().is_some(), browser::PACKAGE, "the report's browser check")] {
        if present {
            continue;
        }
        let is_root = Command::new("id").arg("-u").output().map(|o| o.stdout.starts_with(b"0")).unwrap_or(false);
        if !is_root {
            bail!("{package} is missing ({why}): install it (Debian/Ubuntu: sudo apt-get install -y {package})");
        }
        say(&format!("installing {package} (apt-get) for {why}"));
        if !apt_updated {
            run(Command::new("apt-get").arg("update").arg("-q"))?;
            apt_updated = true;
        }
        run(Command::new("apt-get").args(["install", "-y", "-q", package]).env("DEBIAN_FRONTEND", "noninteractive"))?;
    }
    for (tool, krate) in [("embedded-test-qemu-runner", "embedded-test-qemu-runner"), ("defmt-print", "defmt-print"), ("cargo-fuzz", "cargo-fuzz")] {
        if !have(tool) {
            say(&format!("installing {tool} (cargo install --locked {krate})"));
            run(Command::new("cargo").args(["install", "--locked", krate]))?;
        }
    }
    Ok(())
}

/// Outcome of one suite.
struct Suite {
    name: &'static str,
    passed: u64,
    failed: u64,
    ok: bool,
    /// The failing tests and their panic lines, repeated in the summary so
    /// that the tail of a long log says what failed.
    failures: Vec<String>,
    /// Tests that failed once and passed when run again (end-to-end only).
    flaky: Vec<String>,
}

/// Runs a cargo command, echoing its output and adding up libtest's
/// `test result:` lines.
fn run_suite(name: &'static str, cmd: &mut Command) -> Result<Suite> {
    say(name);
    let mut child = cmd.stdout(Stdio::piped()).spawn().with_context(|| format!("running {cmd:?}"))?;
    let (mut passed, mut failed) = (0, 0);
    let mut failures = Vec::new();
    if let Some(out) = child.stdout.take() {
        let mut keep_next = false;
        for line in BufReader::new(out).lines() {
            let line = line?;
            println!("{line}");
            if let Some((p, f)) = parse_test_result(&line) {
                passed += p;
                failed += f;
            }
            if keep_next {
                failures.push(format!("    {}", line.trim()));
                keep_next = false;
            }
            if line.starts_with("test ") && line.ends_with("FAILED") {
                failures.push(line.clone());
            } else if line.contains("panicked at") {
                failures.push(format!("  {}", line.trim()));
                keep_next = true;
            }
        }
    }
    let ok = child.wait()?.success();
    if !ok && failed == 0 {
        // A build error or a crashed runner counts as a failure.
        failed = 1;
    }
    Ok(Suite { name, passed, failed, ok, failures, flaky: Vec::new() })
}

/// `test result: ok. 5 passed; 0 failed; ...` → (5, 0).
fn parse_test_result(line: &str) -> Option<(u64, u64)> {
    let rest = line.trim().strip_prefix("test result: ")?;
    let mut passed = None;
    let mut failed = None;
    for part in rest.split(';') {
        let words: Vec<&str> = part.split_whitespace().collect();
        match words.as_slice() {
            [.., n, "passed"] => passed = n.parse().ok(),
            [n, "failed"] => failed = n.parse().ok(),
            _ => {}
        }
    }
    Some((passed?, failed?))
}

fn firmware_elf() -> PathBuf {
    root().join("target").join(TARGET).join("release").join("firmware")
}

fn build_firmware() -> Result<PathBuf> {
    say("building the firmware (board release build; the same binary boots on QEMU)");
    run(cargo().args(["build", "--release", "-p", "firmware", "--target", TARGET]))?;
    Ok(firmware_elf())
}

fn build_magcal() -> Result<PathBuf> {
    say("building magcal");
    run(cargo().args(["build", "-p", "magcal", "--bin", "magcal"]))?;
    Ok(root().join("target").join("debug").join("magcal"))
}

fn cmd_size() -> Result<size::Usage> {
    let elf = build_firmware()?;
    let usage = size::measure(&elf)?;
    usage.print();
    usage.check_budget()?;
    Ok(usage)
}

fn cmd_test() -> Result<()> {
    ensure_tools()?;
    let mut suites = Vec::new();
    suites.push(run_suite(
        "host unit tests (calib-core, protocol, firmware library, host-tools, xtask)",
        cargo().args(["test", "--no-fail-fast", "--workspace", "--exclude", "target-tests", "--exclude", "e2e-tests"]),
    )?);
    suites.push(run_suite(
        "on-target tests on the Cortex-M4F under QEMU",
        cargo().args(["test", "--no-fail-fast", "-p", "target-tests", "--target", TARGET]),
    )?);
    // No unwrap/expect/panic (and, in firmware and protocol, no unchecked
    // indexing) on outside data: the crates deny those clippy lints, so a
    // clippy run that completes is the check.
    say("lints: clippy with the crates' deny(unwrap_used, expect_used, panic, indexing_slicing)");
    let lint_ok = run(cargo().args(["clippy", "-q", "-p", "firmware", "--target", TARGET, "--lib", "--bins"])).is_ok()
        && run(cargo().args(["clippy", "-q", "-p", "calib-core", "-p", "magcal-protocol"])).is_ok();
    suites.push(Suite { name: "no-panic lints (firmware, calib-core, protocol)", passed: u64::from(lint_ok), failed: u64::from(!lint_ok), ok: lint_ok, failures: vec![], flaky: vec![] });
    let size_ok = match cmd_size() {
        Ok(_) => true,
        Err(e) => {
            eprintln!("firmware size check failed: {e:#}");
            false
        }
    };
    suites.push(Suite { name: "board build within flash/RAM budget", passed: u64::from(size_ok), failed: u64::from(!size_ok), ok: size_ok, failures: vec![], flaky: vec![] });
    let elf = firmware_elf();
    let magcal = build_magcal()?;
    let e2e = |filter: Option<&str>| {
        let mut c = cargo();
        c.args(["test", "--no-fail-fast", "-p", "e2e-tests"]).env("MAGCAL_FIRMWARE_ELF", &elf).env("MAGCAL_BIN", &magcal);
        if let Some(name) = filter {
            c.args(["--", "--exact", name]);
        }
        c
    };
    let mut e2e_suite = run_suite("end-to-end: firmware in QEMU, magcal over a pty", &mut e2e(None))?;
    // The end-to-end tests run real time against an emulated board on a
    // shared machine: a test that fails is run once more on its own, and
    // one that then passes is reported as flaky (in the summary), not
    // hidden. A test that fails twice fails the suite.
    let failed_names: Vec<String> = e2e_suite
        .failures
        .iter()
        .filter_map(|l| l.strip_prefix("test ").and_then(|r| r.strip_suffix(" ... FAILED")).map(str::to_string))
        .collect();
    if e2e_suite.ok || failed_names.len() as u64 != e2e_suite.failed {
        // Nothing to retry, or a failure that is not a test (a build error).
    } else {
        let mut all_passed = true;
        for name in &failed_names {
            let again = run_suite("end-to-end: the failed test once more", &mut e2e(Some(name)))?;
            if again.ok && again.passed == 1 {
                e2e_suite.flaky.push(name.clone());
            } else {
                all_passed = false;
            }
        }
        if all_passed {
            e2e_suite.passed += e2e_suite.failed;
            e2e_suite.failed = 0;
            e2e_suite.ok = true;
        }
    }
    suites.push(e2e_suite);

    // Fuzzing, time-boxed: each decoder that takes outside bytes.
    say("fuzzing (cargo fuzz, libFuzzer, 10 s a target)");
    let mut fuzz_passed = 0;
    let mut fuzz_failed = 0;
    let fuzz_built = run(cargo().current_dir(root().join("fuzz")).args(["fuzz", "build", "--sanitizer", "none", "-O"])).is_ok();
    for target in ["frame_decoder", "coefficient_record", "csv_reader", "caldoc_loader"] {
        let ok = fuzz_built
            && run(cargo().current_dir(root().join("fuzz")).args(["fuzz", "run", "--sanitizer", "none", "-O", target]).args(fuzz_corpus(target)).args(["--", "-max_total_time=10"])).is_ok();
        if ok { fuzz_passed += 1 } else { fuzz_failed += 1 }
    }
    suites.push(Suite { name: "fuzz: frame decoder, coefficient record, CSV reader, calibration JSON", passed: fuzz_passed, failed: fuzz_failed, ok: fuzz_failed == 0, failures: vec![], flaky: vec![] });

    // The main job, shortened: the whole session against the QEMU board.
    say("demo session (shortened plan) against the firmware in QEMU");
    // With the real-vehicle effects but the anomaly (magcal_sim::SHORT_TEST_EFFECTS):
    // the chain's |F| reference is IGRF, so with the anomaly the field
    // error against the true field exceeds this check's bound; the demo
    // runs all five.
    let demo = demo_session(&elf, &magcal, &root().join("target").join("demo-test"), "short", magcal_sim::SHORT_TEST_EFFECTS);
    let demo_ok = match &demo {
        Ok(s) => {
            let v = s.session.validation;
            let before = v.map_or(f64::NAN, |v| v.heading_rms_deg_before);
            let after = v.map_or(f64::NAN, |v| v.heading_rms_deg_after);
            let field = v.map_or(f64::NAN, |v| v.field_error_nt_after);
            let verified = s.session.coefficients_verified;
            let reproduced = reproduce_offline(&magcal, &root().join("target").join("demo-test").join("session"));
            if let Err(e) = &reproduced {
                eprintln!("the saved session does not reproduce offline: {e:#}");
            }
            // Measured 2026-11-22 (short plan, no effects): 8.97° → 0.24°, 11.0 nT (were ≤ 0.5°, ≤ 50 nT).
            // With the effects, offline (sim vehicle.rs tests): 0.27°, 16 nT.
            let ok = verified && after <= 0.35 && after < before / 5.0 && field <= 30.0 && reproduced.is_ok();
            if !ok {
                eprintln!("demo session out of bounds: heading {before:.2}° → {after:.2}°, field {field:.1} nT, verified {verified}");
            }
            ok
        }
        Err(e) => {
            eprintln!("demo session failed: {e:#}");
            false
        }
    };
    suites.push(Suite { name: "demo session: heading ≤ 0.35° and field ≤ 30 nT after, verified upload", passed: u64::from(demo_ok), failed: u64::from(!demo_ok), ok: demo_ok, failures: vec![], flaky: vec![] });

    // The demo session's report in a real browser. (That the check fails a
    // blank page and a console error is proven by browser.rs's unit tests,
    // which run above with the browser installed.)
    say("the report in headless Chromium: a non-blank screenshot and an empty console");
    let page = match &demo {
        Ok(s) => s.report.clone(),
        Err(_) => root().join("target").join("demo-test").join("session").join("report").join("index.html"),
    };
    // The demo session checked its own page when the browser was there.
    let checked = demo.as_ref().ok().and_then(|s| s.report_check.as_ref());
    let browser_ok = match checked {
        Some(c) if c.verdict == "ok" => {
            eprintln!("   {}: rendered in {:.2} s by the demo session; screenshot {}", page.display(), c.render_s, c.screenshot.display());
            true
        }
        Some(c) => {
            eprintln!("the report fails in the browser: {}", c.verdict);
            false
        }
        None => match browser::check_report(&page) {
        Ok(r) => {
            eprintln!("   {}: rendered in {:.2} s, {:.1} % ink, console empty; screenshot {}", page.display(), r.render_s, r.ink * 100.0, r.png.display());
            true
        }
        Err(e) => {
            eprintln!("the report fails in the browser: {e:#}");
            false
        }
        },
    };
    suites.push(Suite { name: "report in headless Chromium: non-blank, empty console, self-contained", passed: u64::from(browser_ok), failed: u64::from(!browser_ok), ok: browser_ok, failures: vec![], flaky: vec![] });

    eprintln!();
    for s in &suites {
        for f in &s.failures {
            eprintln!("failed in {}: {f}", s.name);
        }
        for f in &s.flaky {
            eprintln!("FLAKY in {}: {f} failed, then passed when run again", s.name);
        }
    }
    eprintln!("== summary");
    let (mut passed, mut failed) = (0, 0);
    for s in &suites {
        eprintln!("  {:<72} {:>4} passed {:>3} failed{}", s.name, s.passed, s.failed, if s.ok { "" } else { "  <- FAILED" });
        passed += s.passed;
        failed += s.failed;
    }
    println!("{passed} passed, {failed} failed");
    if failed > 0 || suites.iter().any(|s| !s.ok) {
        bail!("some suites failed");
    }
    Ok(())
}

/// Renders a report page in headless Chromium (installing it when missing)
/// and checks it: non-blank, empty console, self-contained.
fn cmd_check_report(page: Option<PathBuf>) -> Result<()> {
    if browser::find().is_none() {
        ensure_tools()?;
    }
    let page = page.unwrap_or_else(|| root().join("target").join("demo").join("session").join("report").join("index.html"));
    let r = browser::check_report(&page)?;
    eprintln!("{}: rendered in {:.2} s, {:.1} % ink, console empty; screenshot {}", page.display(), r.render_s, r.ink * 100.0, r.png.display());
    Ok(())
}

fn cmd_demo() -> Result<()> {
    ensure_tools()?;
    let elf = build_firmware()?;
    let usage = size::measure(&elf)?;
    usage.print();
    let magcal = build_magcal()?;
    let out_dir = root().join("target").join("demo");
    let summary = demo_session(&elf, &magcal, &out_dir, "demo", "all")?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}

/// The corpus directories of a fuzz target: the working corpus (new inputs
/// go there; ignored by git) and, where there are any, the committed seeds.
fn fuzz_corpus(target: &str) -> Vec<PathBuf> {
    let fuzz = root().join("fuzz");
    let work = fuzz.join("corpus").join(target);
    let seeds = fuzz.join("seeds").join(target);
    let _ = std::fs::create_dir_all(&work);
    if seeds.is_dir() {
        vec![work, seeds]
    } else {
        vec![work]
    }
}

/// `target/demo/summary.json`: the session's summary with where its logs,
/// report and deviation card are.
#[derive(serde::Serialize)]
struct DemoSummary {
    #[serde(flatten)]
    session: SessionSummary,
    firmware_log: PathBuf,
    /// The report page (self-contained HTML).
    report: PathBuf,
    /// The deviation card of the validation run against the truth.
    deviation_card: Option<DemoCard>,
    /// The report in headless Chromium (when a browser is installed).
    report_check: Option<ReportCheck>,
}

/// The deviation card's files.
#[derive(serde::Serialize)]
struct DemoCard {
    text: PathBuf,
    csv: PathBuf,
    json: PathBuf,
}

/// The report's browser check.
#[derive(serde::Serialize)]
struct ReportCheck {
    screenshot: PathBuf,
    /// Browser start to screenshot, s.
    render_s: f64,
    /// `ok`, or what is wrong.
    verdict: String,
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
fn demo_session(elf: &Path, magcal: &Path, out_dir: &Path, plan: &str, effects: &str) -> Result<DemoSummary> {
    use host_tools::board::qemu::{QemuBoard, QemuOptions};

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

#[cfg(test)]
mod tests {
    use super::parse_test_result;

    #[test]
    fn libtest_summaries_are_counted() {
        assert_eq!(
            parse_test_result("test result: ok. 12 passed; 0 failed; 1 ignored; 0 measured; 0 filtered out; finished in 0.01s"),
            Some((12, 0))
        );
        assert_eq!(parse_test_result("test result: FAILED. 5 passed; 1 failed; 0 ignored"), Some((5, 1)));
        assert_eq!(parse_test_result("running 6 tests"), None);
    }
}
