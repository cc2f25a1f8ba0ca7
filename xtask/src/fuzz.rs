//! The fuzz targets (`fuzz/`), built and run without cargo-fuzz.
//!
//! `cargo fuzz build --sanitizer none -O` is a plain `cargo build --release`
//! of the fuzz crate for the host triple with SanitizerCoverage switched on
//! through `RUSTFLAGS`, all stable flags (cargo-fuzz 0.13.2, `project.rs`);
//! `libfuzzer-sys` compiles libFuzzer itself and supplies `main`. So the
//! same command is run here, and each target binary is then run with
//! libFuzzer's own options, as `cargo fuzz run` does. The build lands where
//! cargo-fuzz puts it (`fuzz/target/<host>/release/`), so
//! `cd fuzz && cargo fuzz run --sanitizer none -O TARGET` still works for
//! whoever has cargo-fuzz.

use std::path::{Path, PathBuf};

/// `nice` from coreutils.
const NICE: &str = "/usr/bin/nice";
use std::process::Command;

use anyhow::{bail, Context, Result};

/// The fuzz targets: each decoder that takes outside bytes, and `commands`:
/// recordings, documents, NMEA logs and option values through the
/// library's command entry points; `import`: every vehicle log format
/// through the one importer.
pub const TARGETS: [&str; 6] = ["frame_decoder", "coefficient_record", "csv_reader", "caldoc_loader", "commands", "import"];

/// Time box of one target, s.
pub const SECONDS_PER_TARGET: u32 = 10;

/// cargo-fuzz's flags for `--sanitizer none` on Linux: SanitizerCoverage
/// with 8-bit counters, the PC table, compare tracing and stack depth (what
/// libFuzzer's feedback reads), no branch folding, `cfg(fuzzing)`, one
/// codegen unit in release (cargo-fuzz 0.13.2, `project.rs`; dead code is
/// stripped, as there: kept, the firmware's unused paths would need a
/// critical-section implementation on the host).
const RUSTFLAGS: &str = "-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 -Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table -Cllvm-args=-sanitizer-coverage-trace-compares -Cllvm-args=-simplifycfg-branch-fold-threshold=0 --cfg fuzzing -Cllvm-args=-sanitizer-coverage-stack-depth -Ccodegen-units=1";

fn dir() -> PathBuf {
    super::root().join("fuzz")
}

/// The host's target triple (`rustc -vV`): the fuzz build names it so that
/// `RUSTFLAGS` reach only the target's code, not build scripts.
pub fn host_triple() -> Result<String> {
    let out = Command::new("rustc").arg("-vV").output().context("running rustc -vV")?;
    let text = String::from_utf8_lossy(&out.stdout);
    match text.lines().find_map(|l| l.strip_prefix("host: ")) {
        Some(h) => Ok(h.trim().to_string()),
        None => bail!("rustc -vV names no host triple"),
    }
}

/// The build of every target (`cargo fuzz build --sanitizer none -O`).
pub fn build_command(host: &str) -> Command {
    let mut c = super::cargo();
    c.current_dir(dir())
        .args(["build", "--release", "--config", "profile.release.debug=\"line-tables-only\"", "--bins", "--target", host])
        .env("RUSTFLAGS", RUSTFLAGS)
        .env("CARGO_FUZZ", "1");
    c
}

/// One target's time-boxed run (`cargo fuzz run --sanitizer none -O TARGET
/// CORPUS... -- -max_total_time=10`): new inputs go to the working corpus,
/// a crash to `fuzz/artifacts/TARGET/`.
pub fn run_command(host: &str, target: &str) -> Command {
    let fuzz = dir();
    let artifacts = fuzz.join("artifacts").join(target);
    let _ = std::fs::create_dir_all(&artifacts);
    let exe = fuzz.join("target").join(host).join("release").join(target);
    // libFuzzer's time box is wall time: at the lowest priority (nice 19)
    // the run takes only the CPU the other lanes leave idle.
    let mut c = if Path::new(NICE).is_file() {
        let mut c = Command::new(NICE);
        c.args(["-n", "19"]).arg(exe);
        c
    } else {
        Command::new(exe)
    };
    c.current_dir(&fuzz).arg(format!("-artifact_prefix={}/", artifacts.display())).args(corpus(target)).arg(format!("-max_total_time={SECONDS_PER_TARGET}"));
    c
}

/// The corpus directories of a fuzz target: the working corpus (new inputs
/// go there; ignored by git) and, where there are any, the committed seeds.
fn corpus(target: &str) -> Vec<PathBuf> {
    let fuzz = dir();
    let work = fuzz.join("corpus").join(target);
    let seeds = fuzz.join("seeds").join(target);
    let _ = std::fs::create_dir_all(&work);
    if seeds.is_dir() {
        vec![work, seeds]
    } else {
        vec![work]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_build_instruments_only_the_targets_code_like_cargo_fuzz() {
        let c = build_command("x86_64-unknown-linux-gnu");
        let args: Vec<_> = c.get_args().map(|a| a.to_string_lossy().into_owned()).collect();
        assert!(args.windows(2).any(|w| w == ["--target", "x86_64-unknown-linux-gnu"]), "{args:?}");
        let flags = c.get_envs().find(|(k, _)| *k == "RUSTFLAGS").and_then(|(_, v)| v).map(|v| v.to_string_lossy().into_owned()).unwrap_or_default();
        for needed in ["-Cpasses=sancov-module", "-sanitizer-coverage-inline-8bit-counters", "-sanitizer-coverage-pc-table", "--cfg fuzzing"] {
            assert!(flags.contains(needed), "{needed} missing from {flags}");
        }
        // No sanitizer, so no nightly flag.
        assert!(!flags.contains("-Z"), "{flags}");
    }

    #[test]
    fn a_run_is_time_boxed_and_reads_the_seeds() {
        let c = run_command("h", "frame_decoder");
        let args: Vec<_> = c.get_args().map(|a| a.to_string_lossy().into_owned()).collect();
        assert_eq!(args.last().map(String::as_str), Some("-max_total_time=10"));
        assert!(args.iter().any(|a| a.ends_with("fuzz/seeds/frame_decoder")), "{args:?}");
        let program: Vec<String> = std::iter::once(c.get_program()).chain(c.get_args()).map(|a| a.to_string_lossy().into_owned()).collect();
        assert!(program.iter().any(|a| a.ends_with("fuzz/target/h/release/frame_decoder")), "{program:?}");
    }
}
