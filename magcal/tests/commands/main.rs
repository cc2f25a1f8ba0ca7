//! `magcal` from the command line, one test binary (one link instead of
//! thirteen; `cargo test -p magcal --test commands <filter>` runs a part):
//! each module drives the built `magcal` as a user would, on simulated and
//! real recordings.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the built `magcal` with `args`.
pub fn magcal(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_magcal")).args(args).output().expect("run magcal")
}

/// A path as the `&str` an argument list takes.
pub fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// A CSV's header and rows, every cell a number (an empty cell NaN).
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines.map(|l| l.split(',').map(|c| if c.is_empty() { f64::NAN } else { c.parse().unwrap() }).collect()).collect();
    (header, rows)
}

/// A file of the repository's `tests/data`.
pub fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data").join(rel)
}

mod apply;
mod card;
mod cli;
mod columns;
mod export;
mod hostile;
mod import;
mod import_formats;
mod input_checks;
mod kept_weak;
mod log;
mod log_workflow;
mod merge;
mod readme;
mod reference;
mod simulate;
