//! The fuzz targets (`fuzz/`): replayed in the host tests, fuzzed by
//! `cargo xtask fuzz`, built and run without cargo-fuzz.
//!
//! Each target's body is a plain function in `fuzz/fuzz_targets/*_drive.rs`
//! (the libFuzzer target only calls it). `cargo xtask test` runs every
//! target over its committed seeds (`fuzz/seeds/TARGET/`), the working
//! corpus of earlier fuzzing (`fuzz/corpus/TARGET/`) and any crash saved
//! there (`fuzz/artifacts/TARGET/`) through that function in the normal
//! host test build ([`replay`]): an input that panics fails the suite, and no
//! second build of the host crates with coverage instrumentation is made.
//! Fuzzing proper, which needs that build, is `cargo xtask fuzz`:
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

use std::path::PathBuf;
use std::process::Command;

use anyhow::{bail, Context, Result};

/// The fuzz targets: each decoder that takes outside bytes, and `commands`:
/// recordings, documents, NMEA logs and option values through the
/// library's command entry points; `import`: every vehicle log format
/// through the one importer.
pub const TARGETS: [&str; 6] = ["frame_decoder", "coefficient_record", "csv_reader", "caldoc_loader", "commands", "import"];

/// Time box of one target, s, when `cargo xtask fuzz` is given none.
pub const SECONDS_PER_TARGET: u32 = 60;

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
/// CORPUS... -- -max_total_time=SECONDS`): new inputs go to the working
/// corpus, a crash to `fuzz/artifacts/TARGET/` (both replayed by the host
/// tests from then on).
pub fn run_command(host: &str, target: &str, seconds: u32) -> Command {
    let fuzz = dir();
    let artifacts = fuzz.join("artifacts").join(target);
    let _ = std::fs::create_dir_all(&artifacts);
    let mut c = Command::new(fuzz.join("target").join(host).join("release").join(target));
    c.current_dir(&fuzz).arg(format!("-artifact_prefix={}/", artifacts.display())).args(corpus(target)).arg(format!("-max_total_time={seconds}"));
    c
}

/// `cargo xtask fuzz [--seconds N] [TARGET]...`: builds the targets with
/// cargo-fuzz's flags and fuzzes each (every target when none is named)
/// for `N` seconds of wall time.
pub fn cmd_fuzz(args: &[String]) -> Result<()> {
    let mut seconds = SECONDS_PER_TARGET;
    let mut targets = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--seconds" {
            let v = it.next().context("--seconds needs a number of seconds")?;
            seconds = v.parse().with_context(|| format!("--seconds {v}: not a whole number of seconds"))?;
        } else if let Some(t) = TARGETS.iter().find(|t| **t == a.as_str()) {
            targets.push(*t);
        } else {
            bail!("unknown fuzz target or option `{a}` (targets: {}; usage: cargo xtask fuzz [--seconds N] [TARGET]...)", TARGETS.join(", "));
        }
    }
    if targets.is_empty() {
        targets = TARGETS.to_vec();
    }
    let host = host_triple()?;
    super::say("fuzz targets: build with cargo-fuzz's flags (release, SanitizerCoverage)");
    super::run(&mut build_command(&host))?;
    let mut crashed = Vec::new();
    for target in targets {
        super::say(&format!("fuzzing {target} for {seconds} s (libFuzzer)"));
        if super::run(&mut run_command(&host, target, seconds)).is_err() {
            crashed.push(target);
        }
    }
    if !crashed.is_empty() {
        bail!("libFuzzer stopped on {} (the input is in fuzz/artifacts/TARGET/; `cargo xtask test` replays it)", crashed.join(", "));
    }
    Ok(())
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

// The targets' bodies, the very files the libFuzzer targets include.
#[cfg(test)]
#[path = "../../fuzz/fuzz_targets/caldoc_loader_drive.rs"]
mod caldoc_loader_drive;
#[cfg(test)]
#[path = "../../fuzz/fuzz_targets/coefficient_record_drive.rs"]
mod coefficient_record_drive;
#[cfg(test)]
#[path = "../../fuzz/fuzz_targets/commands_drive.rs"]
mod commands_drive;
#[cfg(test)]
#[path = "../../fuzz/fuzz_targets/csv_reader_drive.rs"]
mod csv_reader_drive;
#[cfg(test)]
#[path = "../../fuzz/fuzz_targets/frame_decoder_drive.rs"]
mod frame_decoder_drive;
#[cfg(test)]
#[path = "../../fuzz/fuzz_targets/import_drive.rs"]
mod import_drive;

/// Every fuzz target over its seeds, its working corpus and its saved
/// crashes, through the target's own body: one test per target, which
/// names each input that panics. `cargo xtask test` runs these as the fuzz
/// suite (`fuzz::replay::`).
#[cfg(test)]
mod replay {
    use std::panic::{catch_unwind, AssertUnwindSafe};

    use super::dir;

    /// Runs every input of `target` through `drive`; panics naming the
    /// inputs that panicked, or when the target has no committed seed.
    fn replay(target: &str, drive: fn(&[u8])) {
        let fuzz = dir();
        let mut inputs = Vec::new();
        for folder in ["seeds", "corpus", "artifacts"] {
            let entries = match std::fs::read_dir(fuzz.join(folder).join(target)) {
                Ok(entries) => entries,
                // The working corpus and the crashes exist once fuzzed.
                Err(_) if folder != "seeds" => continue,
                Err(e) => panic!("fuzz/seeds/{target}/: {e}: nothing to replay"),
            };
            let mut paths: Vec<_> = entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| p.is_file()).collect();
            paths.sort();
            if folder == "seeds" {
                assert!(!paths.is_empty(), "fuzz/seeds/{target}/ holds no seed: nothing to replay");
            }
            inputs.extend(paths);
        }
        let panicked: Vec<String> = inputs
            .iter()
            .filter(|path| match std::fs::read(path) {
                Ok(bytes) => catch_unwind(AssertUnwindSafe(|| drive(&bytes))).is_err(),
                Err(e) => panic!("reading {}: {e}", path.display()),
            })
            .map(|p| p.display().to_string())
            .collect();
        assert!(panicked.is_empty(), "{target}: {} of {} inputs panic: {}", panicked.len(), inputs.len(), panicked.join(", "));
    }

    #[test]
    fn frame_decoder() {
        replay("frame_decoder", super::frame_decoder_drive::drive);
    }

    #[test]
    fn coefficient_record() {
        replay("coefficient_record", super::coefficient_record_drive::drive);
    }

    #[test]
    fn csv_reader() {
        replay("csv_reader", super::csv_reader_drive::drive);
    }

    #[test]
    fn caldoc_loader() {
        replay("caldoc_loader", super::caldoc_loader_drive::drive);
    }

    #[test]
    fn commands() {
        replay("commands", super::commands_drive::drive);
    }

    #[test]
    fn import() {
        replay("import", super::import_drive::drive);
    }

    #[test]
    fn every_target_is_replayed() {
        // The six tests above, one per target of `fuzz/Cargo.toml`.
        let manifest = std::fs::read_to_string(dir().join("Cargo.toml")).unwrap_or_default();
        let bins = manifest.matches("[[bin]]").count();
        assert_eq!(bins, super::TARGETS.len(), "fuzz/Cargo.toml has {bins} targets, TARGETS {}", super::TARGETS.len());
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
        let c = run_command("h", "frame_decoder", 10);
        let args: Vec<_> = c.get_args().map(|a| a.to_string_lossy().into_owned()).collect();
        assert_eq!(args.last().map(String::as_str), Some("-max_total_time=10"));
        assert!(args.iter().any(|a| a.ends_with("fuzz/seeds/frame_decoder")), "{args:?}");
        let program: Vec<String> = std::iter::once(c.get_program()).chain(c.get_args()).map(|a| a.to_string_lossy().into_owned()).collect();
        assert!(program.iter().any(|a| a.ends_with("fuzz/target/h/release/frame_decoder")), "{program:?}");
    }
}
