//! `magcal import` of each vehicle log format against its independent
//! reader (pymavlink, pyulog, rosbags, a decode from canboat's published
//! PGN definitions): counts and values from the reader's output committed
//! beside each fixture with the script that made it.

mod dataflash_gyro;
mod nmea2000;
mod ros2;
mod tlog;
mod ulog;

#[path = "../../../../fuzz/fuzz_targets/import_drive.rs"]
mod import_drive;

/// The `import` fuzz target's seeds (a prefix of each format's fixture) and
/// any crash it saved replay without a panic, and a seed of every format is
/// there.
#[test]
fn every_import_fuzz_input_replays_without_a_panic() {
    use host_tools::data::Format;
    let fuzz = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let mut formats = std::collections::BTreeSet::new();
    for dir in [fuzz.join("seeds/import"), fuzz.join("artifacts/import")] {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for entry in entries {
            let path = entry.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| import_drive::drive(&bytes));
            assert!(outcome.is_ok(), "{} panics", path.display());
            if let Some(&pick) = bytes.first() {
                formats.insert(Format::ALL[pick as usize % Format::ALL.len()]);
            }
        }
    }
    let missing: Vec<_> = Format::ALL.into_iter().filter(|f| !formats.contains(f)).collect();
    assert!(missing.is_empty(), "fuzz/seeds/import has no seed of {missing:?}");
}

/// An imported vehicle log is `merge`'s navigation log as it is: a
/// simulated swing written as a tlog (`tests/data/sim-tlog`), imported, its
/// field cut out as a board log on a clock 30 s behind, merged back. The
/// offset is found from the motion both see (measured 29.9986 ± 0.0022 s)
/// and every merged row carries the imported attitude at its time.
#[test]
fn an_imported_log_is_a_navigation_log_for_merge() {
    use crate::{data, magcal, p, read_csv};
    let dir = tempfile::tempdir().unwrap();
    let nav = dir.path().join("nav.csv");
    let o = magcal(&["import", p(&data("sim-tlog/swing.tlog")), "--out", p(&nav)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (header, rows) = read_csv(&nav);
    let col = |n: &str| header.iter().position(|h| h == n).unwrap_or_else(|| panic!("{n} in {header:?}"));
    let (t, mx, roll) = (col("t"), col("mx"), col("roll_deg"));
    let board = dir.path().join("board.csv");
    let mut text = String::from("t,mx,my,mz\n");
    for r in &rows {
        text += &format!("{},{},{},{}\n", r[t] - 30.0, r[mx], r[mx + 1], r[mx + 2]);
    }
    std::fs::write(&board, text).unwrap();
    let merged = dir.path().join("merged.csv");
    let o = magcal(&["merge", "--board", p(&board), "--nav", p(&nav), "--out", p(&merged), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (offset, sigma) = (m["offset_s"].as_f64().unwrap(), m["offset_sigma_s"].as_f64().unwrap());
    assert!((offset - 30.0).abs() < 0.01 && (offset - 30.0).abs() < 3.0 * sigma.max(1e-3), "offset {offset} ± {sigma}");
    let (mh, mrows) = read_csv(&merged);
    let (mt, mroll) = (mh.iter().position(|h| h == "t").unwrap(), mh.iter().position(|h| h == "roll_deg").unwrap());
    assert!(mrows.len() + 5 >= rows.len(), "{} of {} rows merged", mrows.len(), rows.len());
    // Each merged row's roll against the import's at the same time (the
    // offset's few ms of error times the roll rate: measured 0.013°).
    let mut worst: f64 = 0.0;
    for r in mrows.iter().filter(|r| r[mroll].is_finite()) {
        let k = rows.partition_point(|x| x[t] < r[mt]).min(rows.len() - 1);
        if (rows[k][t] - r[mt]).abs() < 0.01 && rows[k][roll].is_finite() {
            worst = worst.max((rows[k][roll] - r[mroll]).abs());
        }
    }
    eprintln!("merged roll vs the import's: worst {worst:.4}°");
    assert!(worst < 0.05, "merged roll differs from the import's by {worst}°");
}
