//! `magcal import` of NMEA 2000 logs in canboat's text formats
//! (`tests/data/nmea2000-canboat`: a real boat's bus, canboat samples,
//! Apache-2.0), against the independent decode `reference.py` wrote into
//! `reference.json`, and the import's output through `swing` and `card`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::{data, magcal, p};

fn fixture(name: &str) -> PathBuf {
    data(&format!("nmea2000-canboat/{name}"))
}

fn reference() -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(fixture("reference.json")).unwrap()).unwrap()
}

/// Runs `magcal import LOG --out OUT --json [extra]`: the report, stderr.
fn import(log: &Path, out: &Path, extra: &[&str]) -> (bool, serde_json::Value, String) {
    let mut args = vec!["import", p(log), "--out", p(out), "--json"];
    args.extend_from_slice(extra);
    let o = magcal(&args);
    let report = serde_json::from_slice(&o.stdout).unwrap_or(serde_json::Value::Null);
    (o.status.success(), report, String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The six PGNs' messages by `PGN/source`, from a report's `messages`
/// (`"127250 Vessel Heading, source 27": n`).
fn read_counts(report: &serde_json::Value) -> BTreeMap<String, u64> {
    report["messages"]
        .as_object()
        .unwrap()
        .iter()
        .filter_map(|(k, v)| {
            let (pgn, rest) = k.split_once(' ')?;
            let src = rest.rsplit_once("source ")?.1;
            Some((format!("{pgn}/{src}"), v.as_u64()?))
        })
        .collect()
}

/// The triton log, found from its content: one row per field sample of the
/// Precision-9, every PGN read counted as the reference counts it, the
/// columns and their sources.
#[test]
fn triton_is_imported_with_the_satellite_compass_as_reference() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("triton.csv");
    let (ok, r, err) = import(&fixture("triton-head.all"), &out, &[]);
    assert!(ok, "{err}");
    let e = &reference()["files"]["triton-head.all"];
    let six: BTreeMap<String, u64> = e["by_pgn_source"]
        .as_object()
        .unwrap()
        .iter()
        .filter(|(k, _)| ["127250/", "127251/", "127257/", "129025/", "129026/", "65350/"].iter().any(|p| k.starts_with(p)))
        .map(|(k, v)| (k.clone(), v.as_u64().unwrap()))
        .collect();
    assert_eq!(read_counts(&r), six);
    let all: u64 = e["messages"].as_u64().unwrap();
    assert_eq!(six.values().sum::<u64>() + r["messages"]["other PGNs (not read)"].as_u64().unwrap(), all);
    assert_eq!(r["rows"].as_u64(), e["decoded"]["65350/27"].as_array().map(|a| a.len() as u64));
    assert_eq!(r["format"], "nmea2000");
    assert_eq!(r["field_unit"], "counts (Simnet 65350, units unpublished)");
    assert_eq!(r["column_sources"]["ref_heading_deg"]["role"], "reference");
    assert_eq!(r["column_sources"]["compass_heading_deg"]["role"], "compass");
    let header = std::fs::read_to_string(&out).unwrap().lines().next().unwrap().to_string();
    assert_eq!(header, "t,mx,my,mz,roll_deg,pitch_deg,ref_heading_deg,lat_deg,lon_deg,gz,compass_heading_deg,variation_deg,course_deg,gps_speed_mps");
    assert!(err.contains("ref_heading_deg is source 52's true heading"), "{err}");
}

/// The PLAIN log (CAN frames) through `--format nmea2000`: the reference's
/// frames and messages.
#[test]
fn a_plain_log_is_reassembled() {
    let dir = tempfile::tempdir().unwrap();
    let (ok, r, err) = import(&fixture("triton-head-plain.raw"), &dir.path().join("plain.csv"), &["--format", "nmea2000"]);
    assert!(ok, "{err}");
    let e = &reference()["files"]["triton-head-plain.raw"];
    assert_eq!(r["rows"].as_u64(), e["decoded"]["65350/27"].as_array().map(|a| a.len() as u64));
    assert!(err.contains(&format!("canboat PLAIN, {} CAN frames", e["lines"])), "{err}");
    assert!(r["skipped"].get("fast_packet_incomplete").is_none());
}

/// The furuno wide turns hold no magnetic heading and no field (the
/// Precision-9's were filtered out of the capture): refused, saying what
/// the log holds, and nothing written.
#[test]
fn a_log_without_a_compass_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("furuno.csv");
    let (ok, _, err) = import(&fixture("furuno-wide-turn-head.raw"), &out, &[]);
    assert!(!ok);
    assert!(err.contains("nothing to calibrate: no magnetic heading (PGN 127250") && err.contains("127257 Attitude, source 52"), "{err}");
    assert!(!out.exists());
}

/// A log cut mid-line and with a corrupt line: imported, the refusals said.
#[test]
fn damaged_lines_are_counted() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(fixture("triton-head.all")).unwrap();
    let damaged = format!("{}\n2026-07-02T06:01:43.600Z,2,65350,27,255,8,zz,fd,01,f6,cd,23,02,ff\n{}", &text[..text.len() - 20], "2026-07-02T06:01:43.700Z,2,65350,27,255,8,f9,fd");
    let log = dir.path().join("damaged.all");
    std::fs::write(&log, damaged).unwrap();
    let (ok, r, err) = import(&log, &dir.path().join("d.csv"), &[]);
    assert!(ok, "{err}");
    assert_eq!((r["skipped"]["wrong_length"].as_u64(), r["skipped"]["bad_hex"].as_u64()), (Some(2), Some(1)), "{}", r["skipped"]);
    assert!(err.contains("wrong length") || err.contains("wrong_length"), "{err}");
}

/// The import's output goes into `swing` (a heading-only compass's, without
/// --cal) and `card`: the triton log is 10 s on one heading, so the swing
/// fits the constant A only and says so; measured A = −3.53° (the compass's
/// magnetic heading plus the satellite compass's variation, 0.87°, against
/// its true heading: +2.68° + 0.87°), 3.53° → 0.18° RMS; the card fills the
/// 300° sector alone.
#[test]
fn the_import_goes_into_swing_and_card() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("triton.csv");
    let (ok, _, err) = import(&fixture("triton-head.all"), &rec, &[]);
    assert!(ok, "{err}");
    let doc = dir.path().join("swing.json");
    let o = magcal(&["swing", "--input", p(&rec), "--estimate-delay", "--out", p(&doc), "--json"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("fitted the constant A only") && err.contains("declination +0.87° from the log"), "{err}");
    let d: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let swing = &d["quality"]["swing"];
    let (before, after) = (swing["before_rms_deg"].as_f64().unwrap(), swing["after_rms_deg"].as_f64().unwrap());
    assert!((before - 3.53).abs() < 0.1 && after < 0.3, "{before} {after}");
    let o = magcal(&["card", "--input", p(&rec), "--cal", p(&doc), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let card: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // Measured: 104 of 106 rows (2 without a reference yet), all in the
    // 300° sector; −3.58° → −0.05° mean, 0.16° RMS after.
    let filled: Vec<&serde_json::Value> = card["by_heading"].as_array().unwrap().iter().filter(|s| s["before"]["samples"].as_u64() > Some(0)).collect();
    assert_eq!(filled.len(), 1);
    assert_eq!((filled[0]["label"].as_str(), filled[0]["before"]["samples"].as_u64()), (Some("300°"), Some(104)));
    let after = card["after"]["rms_deg"].as_f64().unwrap();
    assert!(after < 0.3 && card["before"]["rms_deg"].as_f64().unwrap() > 3.0, "{after}");
}

/// `swing --json` on a recording, mapping the course as the reference: the
/// swing's terms (degrees), RMS before and after, held-out RMS after.
fn swing_on_course(rec: &Path) -> ([f64; 3], f64, f64, f64) {
    let o = magcal(&["swing", "--input", p(rec), "--columns", "ref_heading_deg=course_deg", "--estimate-delay", "--declination-deg", "3", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let term = |k: &str| d["swing"][k].as_f64().unwrap().to_degrees();
    let q = &d["quality"]["swing"];
    ([term("a"), term("b"), term("c")], q["before_rms_deg"].as_f64().unwrap(), q["after_rms_deg"].as_f64().unwrap(), q["held_out"]["after_rms_deg"].as_f64().unwrap())
}

/// A heading-only NMEA 2000 log (`cirrus-fast.all`: the yacht Cirrus's real
/// compass readings and GPS courses, tests/data/cirrus-yacht, MIT, written
/// as 127250 magnetic / 129026 by `cirrus_to_canboat.py`): every reading
/// back (to the 0.0001 rad of the PGN), and the heading-only swing on it
/// finds what the same readings as NMEA 0183 give. Measured: N2K B −6.97°,
/// C 18.19°, 13.65° → 4.16° RMS, held out 5.41° (1291 pairs: the course
/// carried to every compass row); NMEA 0183 B −6.98°, C 19.07°, 13.94° →
/// 3.45°, held out 4.24° (314 pairs: a row per sentence). No speed was
/// stored, so the course is mapped as the reference (as the NMEA 0183 test
/// does).
#[test]
fn a_heading_only_log_is_swung_like_its_nmea0183_twin() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("cirrus.csv");
    let (ok, r, err) = import(&fixture("cirrus-fast.all"), &rec, &[]);
    assert!(ok, "{err}");
    let compass: Vec<f64> = std::fs::read_to_string(data("cirrus-yacht/Calibration_Cirrus_v3_compass.csv")).unwrap().lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse().unwrap()).collect();
    assert_eq!(r["rows"].as_u64(), Some(compass.len() as u64));
    assert_eq!(r["column_sources"]["compass_heading_deg"]["role"], "compass");
    assert!(r["column_sources"].get("ref_heading_deg").is_none(), "no speed: no course at speed");
    let text = std::fs::read_to_string(&rec).unwrap();
    let mut imported: Vec<f64> = text.lines().skip(1).map(|l| l.split(',').nth(1).unwrap().parse().unwrap()).collect();
    let mut expected = compass.clone();
    // The rows are in time order, the CSV's readings not always: compare as sets.
    imported.sort_by(f64::total_cmp);
    expected.sort_by(f64::total_cmp);
    let worst = imported.iter().zip(&expected).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    // Half of 0.0001 rad: 0.0029°.
    assert!(worst < 0.003, "{worst}");
    let nmea = dir.path().join("cirrus-0183.csv");
    assert!(magcal(&["import", "--nmea", p(&data("nmea/cirrus-hdm-rmc.nmea")), "--out", p(&nmea)]).status.success());
    let (t2k, before, after, held) = swing_on_course(&rec);
    let (t183, ..) = swing_on_course(&nmea);
    assert!(before > 12.0 && after < 5.0 && held < 6.5, "{before} {after} {held}");
    assert!((t2k[1] - t183[1]).abs() < 0.5 && (t2k[2] - t183[2]).abs() < 1.5 && (t2k[0] - t183[0]).abs() < 1.5, "{t2k:?} {t183:?}");
}
