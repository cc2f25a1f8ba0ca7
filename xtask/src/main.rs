//! Project workflows, run as `cargo xtask <command>`:
//!
//! * `test` — every suite: host unit tests, the on-target suite on the
//!   Cortex-M4F under QEMU, the board release build with its flash/RAM
//!   report, and the end-to-end suite (firmware in QEMU, magcal over a pty).
//!   Ends with the plain line `N passed, N failed`.
//! * `demo` — the main job: boots the firmware in QEMU and runs a session
//!   against it through magcal's serial code.
//! * `size` — the board build's flash and RAM use.
//! * `bench [--section NAME]...` — the benchmarks; writes `docs/RESULTS.md`
//!   from their `results.json`; `results [--check]` renders it again (or
//!   checks that the committed one is what the renderer makes).
//!
//! * `fuzz [--seconds N] [TARGET]...` — libFuzzer on the fuzz targets
//!   (`fuzz/`), time-boxed; `test` replays their seeds, corpus and crashes.
//!
//! * `qemu-test ELF` — the on-target suite's runner (tests/thumb-runner
//!   calls it for each embedded-test binary).
//!
//! Each installs what is missing on a fresh machine (the rustup target,
//! clippy, `qemu-system-arm` and `chromium` through apt-get when root) and
//! says what it is doing. Nothing is `cargo install`ed: the QEMU runner is
//! `qemu-test` and the fuzz targets are built by plain cargo (`fuzz.rs`).

use std::path::PathBuf;
use std::process::{Command, ExitCode, Stdio};

use anyhow::{bail, Context, Result};

mod bench;
mod browser;
mod demo;
mod fuzz;
mod qemu_test;
mod results_doc;
mod size;
mod suite;
mod test;

const TARGET: &str = "thumbv7em-none-eabihf";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => test::cmd_test(),
        Some("demo") => cmd_demo(),
        Some("size") => cmd_size().map(|_| ()),
        Some("bench") if args.get(1).is_some_and(|a| a == "--ci") => bench::run_ci(&root()),
        Some("bench") => bench_sections(&args[1..]).and_then(|only| bench::run(&root().join("target").join("bench"), &only)),
        Some("results") => results_doc::cmd_results(&root(), args.get(1).map(String::as_str) == Some("--check")),
        Some("check-report") => cmd_check_report(args.get(1).map(PathBuf::from)),
        Some("fuzz") => fuzz::cmd_fuzz(&args[1..]),
        Some("qemu-test") => return qemu_test::main(&args[1..]),
        _ => {
            eprintln!("usage: cargo xtask <test|demo|size|bench>");
            eprintln!("  test   run every suite (host, on-target in QEMU, end-to-end)");
            eprintln!("  demo   boot the firmware in QEMU and run a session against it");
            eprintln!("  size   flash/RAM of the board release build");
            eprintln!("  bench [--section NAME]...  accuracy benchmarks (target/bench/results.{{json,md}}, docs/results.json, docs/RESULTS.md), their targets checked");
            eprintln!("  bench --ci  the sections that state targets, at CI sizes: the targets checked, nothing written");
            eprintln!("  results [--check]  render docs/RESULTS.md from docs/results.json (or check that it is)");
            eprintln!("  fuzz [--seconds N] [TARGET]...  libFuzzer on each fuzz target (default: all, {} s each); crashes land in fuzz/artifacts/, which `test` replays", fuzz::SECONDS_PER_TARGET);
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

/// The sections `cargo xtask bench --section NAME` (repeated, or
/// comma-separated) names; empty: every section.
fn bench_sections(args: &[String]) -> Result<Vec<String>> {
    let mut only = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let names = match a.strip_prefix("--section=") {
            Some(v) => v.to_string(),
            None if a == "--section" => it.next().cloned().context("--section needs a section name")?,
            None => bail!("unknown bench argument `{a}` (usage: cargo xtask bench [--section NAME]...)"),
        };
        only.extend(names.split(',').filter(|n| !n.is_empty()).map(str::to_string));
    }
    Ok(only)
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
pub(crate) fn ensure_tools() -> Result<()> {
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
    // QEMU without its recommends (the GTK/SDL front ends, block drivers and
    // firmware images, none used by `-display none` on the netduinoplus2;
    // its dependency closure is 115 packages instead of 1173, `apt-cache
    // depends --recurse`); Chromium with them (its fonts draw the report's
    // text that the browser check looks for).
    for (present, package, why, recommends) in [
        (have("qemu-system-arm"), "qemu-system-arm", "the emulated board", false),
        (browser::find().is_some(), browser::PACKAGE, "the report's browser check", true),
    ] {
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
        let mut apt = Command::new("apt-get");
        apt.args(["install", "-y", "-q"]).env("DEBIAN_FRONTEND", "noninteractive");
        if !recommends {
            apt.arg("--no-install-recommends");
        }
        run(apt.arg(package))?;
    }
    Ok(())
}

/// Builds the firmware log decoder (`xtask/defmt-print`, its own workspace,
/// into `target/tools`); says so and returns false when it fails (the QEMU
/// board then writes its log raw).
fn build_log_decoder() -> bool {
    let dir = root().join("xtask").join("defmt-print");
    let out = suite::capture(
        "build: the firmware log decoder (defmt-print on the defmt-decoder library)",
        cargo().current_dir(&dir).args(["build", "--locked", "--target-dir"]).arg(root().join("target").join("tools")),
    );
    out.is_ok_and(|o| o.success)
}

/// Puts the decoder built by [`build_log_decoder`] first on the PATH, where
/// host-tools' QEMU board looks for `defmt-print`.
fn use_log_decoder(built: bool) {
    let dir = root().join("target").join("tools").join("debug");
    if !built || !dir.join("defmt-print").is_file() {
        return;
    }
    let path = std::env::var_os("PATH").unwrap_or_default();
    let joined = std::env::join_paths(std::iter::once(dir).chain(std::env::split_paths(&path)));
    if let Ok(p) = joined {
        // Called while xtask is single-threaded, before the suites start.
        std::env::set_var("PATH", p);
    }
}

/// Puts the folder [`build_log_decoder`] builds into first on the PATH,
/// before the decoder is built (`cargo xtask test` builds it beside the
/// other builds); [`forget_log_decoder`] when the build fails. Call it while
/// xtask is single-threaded.
fn log_decoder_on_path() {
    let dir = root().join("target").join("tools").join("debug");
    let path = std::env::var_os("PATH").unwrap_or_default();
    if let Ok(p) = std::env::join_paths(std::iter::once(dir).chain(std::env::split_paths(&path))) {
        std::env::set_var("PATH", p);
    }
}

/// Removes a decoder left by an earlier build when this one failed, so
/// that the QEMU board does not use it (it then writes its log raw).
fn forget_log_decoder() {
    let _ = std::fs::remove_file(root().join("target").join("tools").join("debug").join("defmt-print"));
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
    use_log_decoder(build_log_decoder());
    let elf = build_firmware()?;
    let usage = size::measure(&elf)?;
    usage.print();
    let magcal = build_magcal()?;
    let out_dir = root().join("target").join("demo");
    let summary = demo::demo_session(&elf, &magcal, &out_dir, "demo", "all")?;
    println!("{}", serde_json::to_string_pretty(&summary)?);
    Ok(())
}
