//! What `cargo xtask test` counts and prints: a suite's outcome (from
//! libtest's `test result:` lines, or one verdict for a gate), the output of
//! commands that run side by side (each printed whole when it ends, so two
//! lanes do not interleave line by line), the time each phase took, and the
//! summary that ends with `N passed, N failed`.

use std::io::{BufRead, BufReader, Read};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};

/// Holds the terminal while one finished command's output is printed.
static PRINT: Mutex<()> = Mutex::new(());

/// Outcome of one suite.
#[derive(Debug, Clone)]
pub struct Suite {
    pub name: &'static str,
    pub passed: u64,
    pub failed: u64,
    pub ok: bool,
    /// The failing tests and their panic lines, repeated in the summary so
    /// that the tail of a long log says what failed.
    pub failures: Vec<String>,
    /// Tests that failed once and passed when run again (end-to-end only).
    pub flaky: Vec<String>,
}

impl Suite {
    /// A gate that is one check: 1 passed or 1 failed.
    pub fn gate(name: &'static str, ok: bool) -> Suite {
        Suite { name, passed: u64::from(ok), failed: u64::from(!ok), ok, failures: vec![], flaky: vec![] }
    }

    /// Adds another run's counts (e.g. the next test binary of a suite).
    pub fn absorb(&mut self, other: Suite) {
        self.passed += other.passed;
        self.failed += other.failed;
        self.ok &= other.ok;
        self.failures.extend(other.failures);
        self.flaky.extend(other.flaky);
    }

    /// The names of the tests that failed (`test NAME ... FAILED` lines).
    pub fn failed_tests(&self) -> Vec<String> {
        self.failures.iter().filter_map(|l| l.strip_prefix("test ").and_then(|r| r.strip_suffix(" ... FAILED")).map(str::to_string)).collect()
    }
}

/// A command's merged stdout and stderr, line by line, and how it ended.
pub struct Output {
    pub lines: Vec<String>,
    pub success: bool,
}

/// Runs `cmd` to the end, keeping its stdout and stderr lines (in the order
/// they arrive), then prints them in one block under `== title`.
pub fn capture(title: &str, cmd: &mut Command) -> Result<Output> {
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().with_context(|| format!("running {cmd:?}"))?;
    let lines = Mutex::new(Vec::new());
    let (out, err) = (child.stdout.take(), child.stderr.take());
    std::thread::scope(|s| {
        let keep = |r: Box<dyn Read + Send>| {
            for line in BufReader::new(r).lines().map_while(Result::ok) {
                lines.lock().unwrap_or_else(|e| e.into_inner()).push(line);
            }
        };
        if let Some(o) = out {
            s.spawn(move || keep(Box::new(o)));
        }
        if let Some(e) = err {
            s.spawn(move || keep(Box::new(e)));
        }
    });
    let success = child.wait()?.success();
    let lines = lines.into_inner().unwrap_or_else(|e| e.into_inner());
    print_block(title, &lines);
    Ok(Output { lines, success })
}

/// Prints a finished command's output as one block.
pub fn print_block(title: &str, lines: &[String]) {
    let _held = PRINT.lock().unwrap_or_else(|e| e.into_inner());
    eprintln!("\n== {title}");
    // cargo's JSON messages (the host build's) are read, not shown.
    for l in lines.iter().filter(|l| !l.starts_with("{\"reason\":")) {
        eprintln!("{l}");
    }
}

/// Prints one line without mixing it into another lane's block.
pub fn note(line: &str) {
    let _held = PRINT.lock().unwrap_or_else(|e| e.into_inner());
    eprintln!("{line}");
}

/// Runs a libtest-style command (cargo test, a test binary, the on-target
/// runner) and adds up its `test result:` lines.
pub fn run_suite(name: &'static str, title: &str, cmd: &mut Command) -> Result<Suite> {
    let out = capture(title, cmd)?;
    Ok(count(name, &out))
}

/// Counts libtest's results in a command's output. A command that failed
/// with no failing test (a build error, a crashed runner) counts as one
/// failure.
pub fn count(name: &'static str, out: &Output) -> Suite {
    let (mut passed, mut failed) = (0, 0);
    let mut failures = Vec::new();
    let mut keep_next = false;
    for line in &out.lines {
        if let Some((p, f)) = parse_test_result(line) {
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
    if !out.success && failed == 0 {
        failed = 1;
    }
    Suite { name, passed, failed, ok: out.success, failures, flaky: Vec::new() }
}

/// `test result: ok. 5 passed; 0 failed; ...` → (5, 0).
pub fn parse_test_result(line: &str) -> Option<(u64, u64)> {
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

/// Wall-clock time of each phase, in the order they ended.
#[derive(Default)]
pub struct Phases {
    done: Mutex<Vec<(String, Duration)>>,
}

impl Phases {
    /// Runs `f` and records how long it took under `name`.
    pub fn time<T>(&self, name: &str, f: impl FnOnce() -> T) -> T {
        let start = Instant::now();
        let out = f();
        self.done.lock().unwrap_or_else(|e| e.into_inner()).push((name.to_string(), start.elapsed()));
        out
    }

    /// The table printed at the end of the run.
    pub fn table(&self, total: Duration) -> String {
        let done = self.done.lock().unwrap_or_else(|e| e.into_inner());
        let mut s = String::from("== time per phase (phases in the same lane add up; the lanes run side by side)\n");
        for (name, d) in done.iter() {
            s.push_str(&format!("  {name:<72} {}\n", clock(*d)));
        }
        s.push_str(&format!("  {:<72} {}", "total", clock(total)));
        s
    }
}

/// `83.4 s` → `1:23`.
pub fn clock(d: Duration) -> String {
    let s = d.as_secs();
    format!("{:>2}:{:02}", s / 60, s % 60)
}

/// Prints the failures, flaky tests and the per-suite counts; returns the
/// totals (passed, failed, every suite ok).
pub fn summary(suites: &[Suite]) -> (u64, u64, bool) {
    eprintln!();
    for s in suites {
        for f in &s.failures {
            eprintln!("failed in {}: {f}", s.name);
        }
        for f in &s.flaky {
            eprintln!("FLAKY in {}: {f} failed, then passed when run again", s.name);
        }
    }
    eprintln!("== summary");
    let (mut passed, mut failed) = (0, 0);
    for s in suites {
        eprintln!("  {:<72} {:>4} passed {:>3} failed{}", s.name, s.passed, s.failed, if s.ok { "" } else { "  <- FAILED" });
        passed += s.passed;
        failed += s.failed;
    }
    (passed, failed, suites.iter().all(|s| s.ok))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn libtest_summaries_are_counted() {
        assert_eq!(
            parse_test_result("test result: ok. 12 passed; 0 failed; 1 ignored; 0 measured; 0 filtered out; finished in 0.01s"),
            Some((12, 0))
        );
        assert_eq!(parse_test_result("test result: FAILED. 5 passed; 1 failed; 0 ignored"), Some((5, 1)));
        assert_eq!(parse_test_result("running 6 tests"), None);
    }

    #[test]
    fn a_run_is_counted_from_its_lines_and_a_crash_is_a_failure() {
        let lines = |l: &[&str]| l.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let out = Output {
            lines: lines(&["test a ... ok", "test b ... FAILED", "thread 'b' panicked at src/x.rs:1:1:", "boom", "test result: FAILED. 1 passed; 1 failed; 0 ignored"]),
            success: false,
        };
        let s = count("s", &out);
        assert_eq!((s.passed, s.failed, s.ok), (1, 1, false));
        assert_eq!(s.failed_tests(), ["b"]);
        assert_eq!(s.failures[2], "    boom");
        let crashed = count("s", &Output { lines: lines(&["error[E0308]: mismatched types"]), success: false });
        assert_eq!((crashed.passed, crashed.failed), (0, 1));
    }

    #[test]
    fn phase_times_read_as_minutes_and_seconds() {
        assert_eq!(clock(Duration::from_secs_f64(83.4)), " 1:23");
        assert_eq!(clock(Duration::from_secs(725)), "12:05");
    }
}
