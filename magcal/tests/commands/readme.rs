//! The README's newcomer path and the guide's walks: every `magcal` command
//! of the ```sh blocks of `README.md`, then of `docs/GUIDE.md`, run as
//! written, in order, in one empty folder (so each command has only what the
//! commands before it wrote, and the repository's `tests/data`, which both
//! name from the repository's root). Skipped, and why:
//!
//! * lines that are not `magcal` (`cargo xtask …`, building and flashing the
//!   firmware): the build, QEMU and a probe, not the CLI;
//! * `identify`, `session`, `log`, `stream`: they talk to a board (a serial port, or
//!   the firmware in QEMU: `cargo xtask demo` and tests/e2e run those);
//! * `merge`: its inputs are the board's and the navigation computer's logs
//!   from `log` on a vehicle (`magcal/tests/commands/merge.rs` covers it);
//! * `report --session session/`: the folder `session` writes.

use std::path::Path;
use std::process::Command;

/// The markdown files whose ```sh blocks are run, in this order.
const WALKS: [&str; 2] = ["README.md", "docs/GUIDE.md"];

/// A markdown file's ```sh blocks, line by line, trailing `# comments` removed.
fn sh_lines(readme: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let mut in_sh = false;
    for line in readme.lines() {
        let t = line.trim();
        if t.starts_with("```") {
            in_sh = !in_sh && t == "```sh";
            continue;
        }
        if in_sh && !t.is_empty() {
            let code = t.split(" #").next().unwrap_or("").trim();
            lines.push(code.to_string());
        }
    }
    lines
}

/// Why a README line is not run here (`None`: it is run).
fn skipped(words: &[&str]) -> Option<&'static str> {
    match words {
        [first, ..] if *first != "magcal" => Some("not a magcal command (cargo: build, QEMU, probe)"),
        [_, "identify" | "session" | "log" | "stream", ..] => Some("talks to a board (serial port or QEMU)"),
        [_, "merge", ..] => Some("its inputs come from `log` on a vehicle"),
        [_, "report", "--session", ..] => Some("needs the folder `session` writes"),
        _ => None,
    }
}

#[test]
fn the_readmes_commands_run_as_written() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = tempfile::tempdir().unwrap();
    // Commands on the repository's own data name it from the root
    // (`tests/data/...`): the folder sees it there, read-only by intent.
    std::os::unix::fs::symlink(root.join("tests").canonicalize().unwrap(), dir.path().join("tests")).unwrap();
    let (mut ran, mut skips) = (Vec::new(), Vec::new());
    let lines = WALKS.iter().flat_map(|f| sh_lines(&std::fs::read_to_string(root.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"))));
    for line in lines {
        let words: Vec<&str> = line.split_whitespace().collect();
        if let Some(why) = skipped(&words) {
            skips.push(format!("{line}: {why}"));
            continue;
        }
        let out = Command::new(env!("CARGO_BIN_EXE_magcal")).args(&words[1..]).current_dir(dir.path()).output().unwrap();
        assert!(out.status.success(), "walk command failed: {line}\n{}", String::from_utf8_lossy(&out.stderr));
        ran.push(line);
    }
    eprintln!("ran {} README commands; skipped:\n  {}", ran.len(), skips.join("\n  "));
    // The walk on real data (glider, BROAD, yacht), the guide's simulate →
    // fit → backstep → swing → report → card → export chains, the importer
    // of every format and apply (about 35 commands as of this writing): files
    // whose blocks stopped being found would otherwise pass with nothing run.
    assert!(ran.len() >= 30, "only {} walk commands found to run: {ran:?}", ran.len());
    for sub in ["simulate", "igrf", "fit", "backstep", "swing", "ortho", "report", "card", "export", "apply", "import"] {
        assert!(ran.iter().any(|l| l.starts_with(&format!("magcal {sub} "))), "no `magcal {sub}` run from the README");
    }
    // What they wrote is there.
    for f in ["glider.json", "broad05.json", "compass.json", "cal1.json", "cal3.json", "report/index.html", "compass.parm", "cal_final.json"] {
        assert!(dir.path().join(f).exists(), "{f} not written");
    }
}
