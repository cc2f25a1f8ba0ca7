//! Import speed per format: `magcal import`'s reader (the library's one
//! importer, in process, best of five) beside the independent reader its
//! tests compare against (`xtask/python/read_speed.py`: pymavlink, pyulog,
//! rosbags, the canboat-definition decoder, pynmea2; the read only, best of
//! three), in MB/s and as a ratio measured in one run, on each committed
//! fixture.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use host_tools::data::{import, Format, ImportOptions};
use serde_json::json;

/// The fixtures timed: one or two a format, in the repository.
pub const FIXTURES: [(Format, &str); 9] = [
    (Format::Dataflash, "tests/data/ardusub-bluerov2/small.BIN"),
    (Format::Tlog, "tests/data/ardusub-bluerov2/small.tlog"),
    (Format::Ulog, "tests/data/px4-ulog/sample_log_small_cut.ulg"),
    (Format::Ulog, "tests/data/px4-ulog/sample_appended_multiple_cut.ulg"),
    (Format::Mcap, "tests/data/ros2/swing.mcap"),
    (Format::Sqlite3, "tests/data/ros2/swing_db3/swing_db3.db3"),
    (Format::Nmea2000, "tests/data/nmea2000-canboat/triton-head.all"),
    (Format::Nmea2000, "tests/data/nmea2000-canboat/triton-head-plain.raw"),
    (Format::Nmea0183, "tests/data/nmea/gofree-merrimac-head.nmea"),
];

/// The independent reader's time for one file, s, or why not.
fn reader_s(root: &Path, format: Format, path: &Path) -> Result<f64, String> {
    let out = Command::new("python3")
        .arg(root.join("xtask/python/read_speed.py"))
        .arg(format.name())
        .arg(path)
        .output()
        .map_err(|e| format!("python3: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).trim().to_string());
    }
    #[derive(serde::Deserialize)]
    struct Timed {
        seconds: f64,
    }
    let t: Timed = serde_json::from_slice(&out.stdout).map_err(|e| format!("read_speed.py's output: {e}"))?;
    Ok(t.seconds)
}

/// The section's numbers and its Markdown table.
pub fn section(root: &Path) -> (serde_json::Value, String) {
    let mut md = String::from("\n| format | file | MB | rows | ours (MB/s) | independent reader (MB/s) | ours ÷ theirs |\n|---|---|---|---|---|---|---|\n");
    let mut rows = Vec::new();
    for (format, rel) in FIXTURES {
        let path = root.join(rel);
        let Ok(bytes) = std::fs::read(&path) else {
            let _ = writeln!(md, "| {} | {rel} | — | not in the tree | | | |", format.title());
            rows.push(json!({"format": format, "file": rel, "error": "not in the tree"}));
            continue;
        };
        let mb = bytes.len() as f64 / 1e6;
        let mut best_s = f64::INFINITY;
        let mut result = None;
        for _ in 0..5 {
            let start = Instant::now();
            let r = import(&bytes, format, &ImportOptions::default());
            best_s = best_s.min(start.elapsed().as_secs_f64());
            result = Some(r);
        }
        let ours = match result {
            Some(Ok(im)) => Ok(im.report.rows),
            Some(Err(e)) => Err(e.to_string()),
            None => Err("not run".into()),
        };
        let theirs = reader_s(root, format, &path);
        let ours_mbps = mb / best_s;
        let theirs_mbps = theirs.as_ref().map(|s| mb / s).ok();
        let ratio = theirs_mbps.map(|t| ours_mbps / t);
        let _ = writeln!(
            md,
            "| {} | {rel} | {mb:.2} | {} | {ours_mbps:.1} | {} | {} |",
            format.title(),
            ours.as_ref().map_or_else(|e| format!("refused: {e}"), |n| n.to_string()),
            theirs_mbps.map_or_else(|| format!("not measured: {}", theirs.as_ref().err().map_or("", |e| e.as_str())), |t| format!("{t:.2}")),
            ratio.map_or("—".into(), |r| format!("{r:.0}×"))
        );
        rows.push(json!({"format": format, "file": rel, "mb": mb, "rows": ours.as_ref().ok(), "error": ours.as_ref().err(), "ours_mb_per_s": ours_mbps, "independent_mb_per_s": theirs_mbps, "ratio": ratio}));
    }
    (json!(rows), md)
}

/// The `results.md` section "Import speed per format".
pub fn markdown(import_md: &str) -> String {
    format!("\n## Import speed per format\n\n`magcal import`'s one importer in process (best of five) beside the independent reader each format's tests compare against (`xtask/python/read_speed.py`, the read only, best of three), on the committed fixtures: `cargo test --release -p xtask bench::tests::import_speed_section -- --ignored --nocapture`.\n{import_md}")
}
