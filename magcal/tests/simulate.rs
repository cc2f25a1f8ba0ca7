//! `magcal simulate`: the bench's effects runs are reachable from the CLI
//! (the README's five-effects numbers come from commands a reader can run),
//! and no size flag makes it allocate or write without bound.

use std::path::Path;
use std::process::{Command, Output};

use magcal_sim::effects::Effects;
use magcal_sim::scenario::effects_data;
use magcal_sim::SensorModel;

fn magcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_magcal")).args(args).output().expect("run magcal")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// `simulate swing|run|validation --runs effects --effects all` with the
/// bench's seeds (s, s + 100, s + 200) and rates (5, 2, 2 Hz) writes the
/// very recordings (and truths) `cargo xtask bench`'s effects section
/// scores for seed s.
#[test]
fn the_cli_writes_the_benchs_effects_runs() {
    let dir = tempfile::tempdir().unwrap();
    let seed = 2;
    let bench = effects_data(&SensorModel::paper_like(), seed, &Effects::all()).unwrap();
    for (name, sim, cli_seed, rate) in [("swing", &bench.swing, seed, "5"), ("run", &bench.run, seed + 100, "2"), ("validation", &bench.validation, seed + 200, "2")] {
        let want = dir.path().join(format!("bench_{name}.csv"));
        sim.write(&want).unwrap();
        let got = dir.path().join(format!("cli_{name}.csv"));
        let s = cli_seed.to_string();
        let out = magcal(&["simulate", name, "--runs", "effects", "--effects", "all", "--seed", &s, "--rate-hz", rate, "--out", p(&got)]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let (a, b) = (std::fs::read(&want).unwrap(), std::fs::read(&got).unwrap());
        assert!(a.len() > 100_000 && a == b, "{name}: the CLI's recording differs from the bench's ({} vs {} bytes)", b.len(), a.len());
        let (a, b) = (std::fs::read(want.with_extension("truth.json")).unwrap(), std::fs::read(got.with_extension("truth.json")).unwrap());
        assert!(a == b, "{name}: truth differs");
    }
    // The same run from the documented flags alone (the paper's base with
    // the bench's legs and speeds): the same rows (its truth records the
    // paper's 0.1 m/s current, replaced by the current effect's).
    let flags = dir.path().join("flags_run.csv");
    let out = magcal(&["simulate", "run", "--effects", "all", "--leg-m", "5000", "--speed-mps", "1.2", "--speed-back-mps", "0.9", "--seed", "102", "--rate-hz", "2", "--out", p(&flags)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read(&flags).unwrap() == std::fs::read(dir.path().join("bench_run.csv")).unwrap());
}

/// Every size flag is bounded before any work, with the limit named:
/// `--leg-m 1e12` used to abort allocating 40 TB, `--leg-m 2e6` to write
/// 1.6 GB.
#[test]
fn size_flags_are_bounded_with_the_limit_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    for (args, limit) in [
        (vec!["--leg-m", "1e12"], "100000 m"),
        (vec!["--leg-m", "2e6"], "100000 m"),
        (vec!["--speed-mps", "50"], "10 m/s"),
        (vec!["--leg-m", "100000", "--speed-mps", "0.2", "--rate-hz", "50"], "1e6 rows"),
        (vec!["--rate-hz", "5000"], "1000 Hz"),
        (vec!["--leg-m", "NaN"], "must be positive"),
        (vec!["--current-to-deg", "inf"], "must be finite"),
    ] {
        let mut all = vec!["simulate", "run", "--out", p(&out)];
        all.extend(&args);
        let started = std::time::Instant::now();
        let o = magcal(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && o.status.code() == Some(1), "{args:?}: {:?} {err}", o.status);
        assert!(err.contains(limit), "{args:?}: {err}");
        assert!(started.elapsed().as_secs_f64() < 5.0, "{args:?}");
        assert!(!out.exists(), "{args:?} wrote a file");
    }
    let o = magcal(&["simulate", "swing", "--rate-hz", "1000", "--effects", "thrusters", "--thrust-test", "--out", p(&out)]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("1e6 rows"), "{}", String::from_utf8_lossy(&o.stderr));
}
