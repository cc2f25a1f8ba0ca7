//! `cargo xtask test`: every suite, in three phases.
//!
//! 1. **tools**: what a fresh machine lacks (rustup target, clippy, QEMU and
//!    Chromium through apt). Nothing is `cargo install`ed: the on-target
//!    runner is `cargo xtask qemu-test`.
//! 2. **build**, three cargo builds side by side (they lock different build
//!    directories): the host (every host test binary, the `magcal` binary
//!    the end-to-end suite and the demo run, and clippy); the thumb target
//!    (the board release build, the on-target tests in the same release
//!    profile, clippy); and the firmware log decoder
//!    (`xtask/defmt-print`, a workspace of its own). Each host crate is
//!    compiled once: the host tests are built in one `cargo test --no-run`
//!    over the workspace and their binaries are run directly, so no later
//!    cargo command resolves other features and rebuilds them.
//! 3. **run**, two lanes, each started as soon as its own builds are
//!    done (no lane waits for a build it does not use): the CPU lane (host
//!    unit tests and doctests, then every fuzz target over its seeds and
//!    corpus through the target's body, [`crate::fuzz`]) after the host
//!    build; the QEMU lane (on-target, end-to-end, demo session, report in
//!    the browser: one QEMU at a time; then the bench's targets, `cargo
//!    xtask bench --ci`) after the host and thumb builds and the log
//!    decoder. Fuzzing proper (libFuzzer on a build of its own with
//!    coverage instrumentation) is `cargo xtask fuzz`, not part of this run.
//!
//! The summary gives each suite's counts and the time each phase took, and
//! the last line is `N passed, N failed`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Result};

use crate::suite::{capture, count, note, run_suite, summary, Phases, Suite};
use crate::{cargo, demo, firmware_elf, root, size, TARGET};

/// A test binary from the host build.
#[derive(Debug, Clone, PartialEq)]
struct TestBinary {
    package: String,
    /// `lib`, `bin NAME` or `test NAME`.
    target: String,
    exe: PathBuf,
    /// The package's directory: cargo runs a test binary there.
    dir: PathBuf,
}

/// What the host build produced.
struct HostBuilt {
    /// The host build failed: its output's verdict.
    failed: Option<Suite>,
    tests: Vec<TestBinary>,
    magcal: Option<PathBuf>,
    /// clippy on calib-core and protocol passed.
    lint: bool,
}

/// What the thumb build produced.
struct ThumbBuilt {
    size: Suite,
    on_target_built: bool,
    lint: bool,
}

/// Runs every suite and prints the summary.
pub fn cmd_test() -> Result<()> {
    let started = Instant::now();
    let phases = Phases::default();
    phases.time("tools (rustup target, clippy, apt: QEMU, Chromium)", crate::ensure_tools)?;
    // Before any thread starts (none reads the environment yet): the folder
    // the log decoder is built into goes first on the PATH.
    crate::log_decoder_on_path();
    // Each lane starts when its own build is done: the CPU lane after the
    // host build, the QEMU lane after the host build, the thumb build and
    // the log decoder.
    let (host, fuzz, qemu, host_lint) = std::thread::scope(|s| {
        let phases = &phases;
        let thumb = s.spawn(|| phases.time("thumb: board release build, on-target test binaries, clippy", build_thumb));
        let decoder = s.spawn(|| phases.time("log decoder build (defmt-print)", crate::build_log_decoder));
        let host = phases.time("CPU lane: host build (test binaries, magcal, clippy)", build_host);
        let e2e_tests: Vec<TestBinary> = host.tests.iter().filter(|t| t.package == "e2e-tests").cloned().collect();
        let magcal = host.magcal.clone();
        let qemu = s.spawn(move || {
            let thumb = thumb.join().unwrap_or_else(|_| ThumbBuilt { size: Suite::gate(SIZE, false), on_target_built: false, lint: false });
            if !decoder.join().unwrap_or(false) {
                crate::forget_log_decoder();
            }
            let suites = qemu_lane(phases, thumb.on_target_built, &e2e_tests, magcal.as_deref());
            (thumb.size, thumb.lint, suites)
        });
        let host_suite = phases.time("CPU lane: host unit tests and doctests", || host_suite(&host));
        let fuzz = phases.time("CPU lane: fuzz targets over their seeds and corpus", || fuzz_suite(&host));
        (host_suite, fuzz, qemu.join(), host.lint)
    });
    let Ok((size, thumb_lint, qemu)) = qemu else { bail!("a lane panicked") };
    let [on_target, e2e, demo, report, bench] = qemu;
    let lints = Suite::gate("no-panic lints (firmware, calib-core, protocol)", host_lint && thumb_lint);
    let suites = vec![host, on_target, lints, size, e2e, fuzz, demo, report, bench];
    let (passed, failed, all_ok) = summary(&suites);
    eprintln!("{}", phases.table(started.elapsed()));
    println!("{passed} passed, {failed} failed");
    if failed > 0 || !all_ok {
        bail!("some suites failed");
    }
    Ok(())
}

const SIZE: &str = "board build within flash/RAM budget";

/// The host build: every test binary of the workspace but the on-target
/// suite (which is the thumb build's), in one `cargo test --no-run`, then
/// clippy on the no_std crates.
fn build_host() -> HostBuilt {
    const NAME: &str = "host unit tests (calib-core, protocol, firmware library, host-tools, xtask)";
    let out = capture(
        "build: host test binaries (cargo test --workspace --exclude target-tests --no-run)",
        cargo().args(["test", "--workspace", "--exclude", "target-tests", "--no-run", "--message-format=json-render-diagnostics"]),
    );
    let (failed, tests, magcal) = match out {
        Ok(o) if o.success => {
            let (tests, magcal) = artifacts(&o.lines);
            (None, tests, magcal)
        }
        Ok(o) => (Some(count(NAME, &o)), vec![], None),
        Err(e) => {
            note(&format!("host build: {e:#}"));
            (Some(Suite::gate(NAME, false)), vec![], None)
        }
    };
    // No unwrap/expect/panic (and, in firmware and protocol, no unchecked
    // indexing) on outside data: the crates deny those clippy lints, so a
    // clippy run that completes is the check.
    let lint = capture("lints: clippy on calib-core and protocol (deny unwrap_used, expect_used, panic, indexing_slicing)", cargo().args(["clippy", "-q", "-p", "calib-core", "-p", "magcal-protocol"]));
    HostBuilt { failed, tests, magcal, lint: lint.is_ok_and(|o| o.success) }
}

/// The thumb build: the board release build and its size gate, the
/// on-target test binaries, clippy on the firmware.
fn build_thumb() -> ThumbBuilt {
    let firmware = capture(
        "build: the firmware (board release build; the same binary boots on QEMU)",
        cargo().args(["build", "--release", "-p", "firmware", "--target", TARGET]),
    );
    let size_ok = firmware.is_ok_and(|o| o.success)
        && match size::measure(&firmware_elf()) {
            Ok(u) => {
                u.print();
                u.check_budget().map_err(|e| note(&format!("firmware size check failed: {e:#}"))).is_ok()
            }
            Err(e) => {
                note(&format!("firmware size check failed: {e:#}"));
                false
            }
        };
    // In the board's own release profile: what is tested is what is flashed,
    // and the dependencies are the firmware build's (67 → 10 CPU-s on a fresh
    // target folder). Overflow checks are the host tests' job on the same code.
    let on_target = capture("build: on-target test binaries (the board's release profile)", cargo().args(["test", "--release", "--no-run", "-p", "target-tests", "--target", TARGET]));
    let lint = capture("lints: clippy on the firmware for the board", cargo().args(["clippy", "-q", "-p", "firmware", "--target", TARGET, "--lib", "--bins"]));
    ThumbBuilt { size: Suite::gate(SIZE, size_ok), on_target_built: on_target.is_ok_and(|o| o.success), lint: lint.is_ok_and(|o| o.success) }
}

/// The test binaries and the `magcal` binary among cargo's JSON messages.
fn artifacts(lines: &[String]) -> (Vec<TestBinary>, Option<PathBuf>) {
    let mut tests = Vec::new();
    let mut magcal = None;
    for line in lines.iter().filter(|l| l.starts_with('{')) {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else { continue };
        if v["reason"] != "compiler-artifact" {
            continue;
        }
        let Some(exe) = v["executable"].as_str().map(PathBuf::from) else { continue };
        let name = v["target"]["name"].as_str().unwrap_or_default();
        let kind = v["target"]["kind"][0].as_str().unwrap_or_default();
        if v["profile"]["test"] != true {
            if kind == "bin" && name == "magcal" {
                magcal = Some(exe);
            }
            continue;
        }
        let dir = v["manifest_path"].as_str().map(PathBuf::from).and_then(|m| m.parent().map(Path::to_path_buf)).unwrap_or_else(root);
        let package = package_name(v["package_id"].as_str().unwrap_or_default());
        let target = if kind == "lib" { "lib".to_string() } else { format!("{kind} {name}") };
        tests.push(TestBinary { package, target, exe, dir });
    }
    (tests, magcal)
}

/// `path+file:///w/tests/e2e#e2e-tests@0.1.0` → `e2e-tests`;
/// `path+file:///w/calib-core#0.1.0` → `calib-core`.
fn package_name(id: &str) -> String {
    let (path, frag) = id.rsplit_once('#').unwrap_or((id, ""));
    match frag.split_once('@') {
        Some((name, _)) => name.to_string(),
        None => path.rsplit('/').next().unwrap_or(path).to_string(),
    }
}

/// Runs one test binary as `cargo test` would (in its package's directory).
fn test_binary(t: &TestBinary) -> Command {
    let mut c = Command::new(&t.exe);
    c.current_dir(&t.dir).env("CARGO_MANIFEST_DIR", &t.dir).env("CARGO_PKG_NAME", &t.package);
    c
}

fn host_suite(built: &HostBuilt) -> Suite {
    const NAME: &str = "host unit tests (calib-core, protocol, firmware library, host-tools, xtask)";
    if let Some(failed) = &built.failed {
        return failed.clone();
    }
    let mut suite = Suite { name: NAME, passed: 0, failed: 0, ok: true, failures: vec![], flaky: vec![] };
    for t in built.tests.iter().filter(|t| t.package != "e2e-tests") {
        let title = format!("host unit tests: {} {}", t.package, t.target);
        let mut c = test_binary(t);
        if is_xtask_bin(t) {
            // The fuzz suite's, counted there.
            c.args(["--skip", FUZZ_REPLAY]);
        }
        suite.absorb(run_suite(NAME, &title, &mut c).unwrap_or_else(|_| Suite::gate(NAME, false)));
    }
    let doc = run_suite(NAME, "host doctests", cargo().args(["test", "--doc", "--no-fail-fast", "--workspace", "--exclude", "target-tests"]));
    suite.absorb(doc.unwrap_or_else(|_| Suite::gate(NAME, false)));
    suite
}

/// The test that replays the fuzz targets' inputs: xtask's own unit tests
/// under `fuzz::replay::` (one test per target).
const FUZZ_REPLAY: &str = "fuzz::replay::";

/// xtask's unit-test binary, which holds the fuzz replay.
fn is_xtask_bin(t: &TestBinary) -> bool {
    t.package == "xtask" && t.target == "bin xtask"
}

/// Every fuzz target over its committed seeds, the working corpus and any
/// saved crash, through the target's body in the host test build
/// (`crate::fuzz`, `replay`): one count per target.
fn fuzz_suite(built: &HostBuilt) -> Suite {
    const NAME: &str = "fuzz targets replayed: frame decoder, coefficient record, CSV reader, calibration JSON, commands, vehicle logs";
    if built.failed.is_some() {
        return Suite::gate(NAME, false);
    }
    let Some(t) = built.tests.iter().find(|t| is_xtask_bin(t)) else { return Suite::gate(NAME, false) };
    let mut c = test_binary(t);
    c.arg(FUZZ_REPLAY);
    run_suite(NAME, "fuzz targets over their seeds and corpus (xtask fuzz::replay)", &mut c).unwrap_or_else(|_| Suite::gate(NAME, false))
}

/// The QEMU lane: on-target, end-to-end, the demo session and its report,
/// then the bench's targets (the MCU section boots `mcu-bench` in QEMU).
fn qemu_lane(phases: &Phases, on_target_built: bool, e2e_tests: &[TestBinary], magcal: Option<&Path>) -> [Suite; 5] {
    let on_target = phases.time("QEMU lane: on-target tests", || on_target_suite(on_target_built));
    let elf = firmware_elf();
    let e2e = phases.time("QEMU lane: end-to-end", || e2e_suite(e2e_tests, magcal, &elf));
    let (demo, summary) = phases.time("QEMU lane: demo session", || match magcal {
        Some(m) => demo::session_gate(&elf, m),
        None => (Suite::gate("demo session: heading ≤ 0.35° and field ≤ 30 nT after, verified upload", false), None),
    });
    let report = phases.time("QEMU lane: report in headless Chromium", || demo::report_gate(summary.as_ref()));
    let bench = phases.time("QEMU lane: bench targets (cargo xtask bench --ci)", bench_targets_suite);
    [on_target, e2e, demo, report, bench]
}

/// The bench's targets (`cargo xtask bench --ci`: MCU instructions, the
/// effects, varied sites, integrity and real-data tables at CI sizes), run
/// by this very xtask binary (the workspace's dev profile, opt-level 1:
/// no build of its own); one count per target.
fn bench_targets_suite() -> Suite {
    const NAME: &str = "bench targets: MCU, effects, varied sites, integrity, real data";
    let Ok(me) = std::env::current_exe() else { return Suite::gate(NAME, false) };
    let mut c = Command::new(me);
    c.current_dir(root()).args(["bench", "--ci"]);
    run_suite(NAME, "bench targets (cargo xtask bench --ci)", &mut c).unwrap_or_else(|_| Suite::gate(NAME, false))
}

fn on_target_suite(built: bool) -> Suite {
    const NAME: &str = "on-target tests on the Cortex-M4F under QEMU";
    if !built {
        return Suite::gate(NAME, false);
    }
    // tests/thumb-runner hands each test binary to this very xtask
    // (`qemu-test`) instead of building it again through cargo.
    let mut c = cargo();
    c.args(["test", "--release", "--no-fail-fast", "-p", "target-tests", "--target", TARGET]);
    if let Ok(me) = std::env::current_exe() {
        c.env("MAGCAL_XTASK", me);
    }
    run_suite(NAME, "on-target tests on the Cortex-M4F under QEMU", &mut c).unwrap_or_else(|_| Suite::gate(NAME, false))
}

/// The end-to-end binaries, each test that fails run once more on its own.
fn e2e_suite(tests: &[TestBinary], magcal: Option<&Path>, elf: &Path) -> Suite {
    const NAME: &str = "end-to-end: firmware in QEMU, magcal over a pty";
    let Some(magcal) = magcal else { return Suite::gate(NAME, false) };
    let mut suite = Suite { name: NAME, passed: 0, failed: 0, ok: true, failures: vec![], flaky: vec![] };
    for t in tests {
        let run = |filter: Option<&str>| {
            let mut c = test_binary(t);
            c.env("MAGCAL_FIRMWARE_ELF", elf).env("MAGCAL_BIN", magcal);
            if let Some(name) = filter {
                c.args(["--exact", name]);
            }
            let title = format!("end-to-end: {}{}", t.target, filter.map(|n| format!(", {n} once more")).unwrap_or_default());
            run_suite(NAME, &title, &mut c).unwrap_or_else(|_| Suite::gate(NAME, false))
        };
        suite.absorb(retry_flaky(run(None), |name| run(Some(name))));
    }
    suite
}

/// The end-to-end tests run real time against an emulated board on a
/// shared machine: a test that fails is run once more on its own, and one
/// that then passes is reported as flaky (in the summary), not hidden. A
/// test that fails twice fails the suite.
fn retry_flaky(mut first: Suite, again: impl Fn(&str) -> Suite) -> Suite {
    let failed = first.failed_tests();
    if first.ok || failed.len() as u64 != first.failed {
        // Nothing to retry, or a failure that is not a test (a crash).
        return first;
    }
    let mut all_passed = true;
    for name in &failed {
        let second = again(name);
        if second.ok && second.passed == 1 {
            first.flaky.push(name.clone());
        } else {
            all_passed = false;
        }
    }
    if all_passed {
        first.passed += first.failed;
        first.failed = 0;
        first.ok = true;
    }
    first
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn package_names_are_read_from_cargo_package_ids() {
        assert_eq!(package_name("path+file:///w/tests/e2e#e2e-tests@0.1.0"), "e2e-tests");
        assert_eq!(package_name("path+file:///w/calib-core#0.1.0"), "calib-core");
    }

    #[test]
    fn test_binaries_and_the_magcal_binary_are_found_in_cargo_messages() {
        let lines = [
            r#"{"reason":"compiler-artifact","package_id":"path+file:///w/tests/e2e#e2e-tests@0.1.0","manifest_path":"/w/tests/e2e/Cargo.toml","target":{"kind":["test"],"name":"link"},"profile":{"test":true},"executable":"/w/target/debug/deps/link-1"}"#,
            r#"{"reason":"compiler-artifact","package_id":"path+file:///w/magcal#0.1.0","manifest_path":"/w/magcal/Cargo.toml","target":{"kind":["bin"],"name":"magcal"},"profile":{"test":false},"executable":"/w/target/debug/magcal"}"#,
            r#"{"reason":"compiler-artifact","package_id":"path+file:///w/calib-core#0.1.0","manifest_path":"/w/calib-core/Cargo.toml","target":{"kind":["lib"],"name":"calib_core"},"profile":{"test":false},"executable":null}"#,
            "   Compiling calib-core v0.1.0",
        ]
        .map(String::from);
        let (tests, magcal) = artifacts(&lines);
        assert_eq!(magcal, Some(PathBuf::from("/w/target/debug/magcal")));
        assert_eq!(tests, [TestBinary { package: "e2e-tests".into(), target: "test link".into(), exe: "/w/target/debug/deps/link-1".into(), dir: "/w/tests/e2e".into() }]);
    }

    fn suite(passed: u64, failed: &[&str]) -> Suite {
        let failures = failed.iter().map(|n| format!("test {n} ... FAILED")).collect();
        Suite { name: "e", passed, failed: failed.len() as u64, ok: failed.is_empty(), failures, flaky: vec![] }
    }

    #[test]
    fn a_test_that_passes_when_run_again_is_flaky_and_one_that_fails_twice_fails() {
        let flaky = retry_flaky(suite(5, &["a"]), |_| suite(1, &[]));
        assert_eq!((flaky.passed, flaky.failed, flaky.ok), (6, 0, true));
        assert_eq!(flaky.flaky, ["a"]);
        let broken = retry_flaky(suite(5, &["a", "b"]), |n| if n == "a" { suite(1, &[]) } else { suite(0, &["b"]) });
        assert_eq!((broken.passed, broken.failed, broken.ok), (5, 2, false));
    }
}
