//! `magcal import` of PX4 ULog against pyulog (PX4's own Python reader):
//! `tests/data/px4-ulog/reference.py` read the committed fixtures with
//! pyulog 1.3.0 and wrote `reference.json` (the data messages per topic and
//! instance, dropouts, appended sections, and every row's columns computed
//! from pyulog's arrays); `sim_to_ulog.py` wrote a simulated recording as a
//! ULog with the standard library only.

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::Value;

use crate::{data, magcal, p};

fn reference() -> Value {
    let text = std::fs::read_to_string(data("px4-ulog/reference.json")).expect("reference.json");
    serde_json::from_str(&text).expect("reference.json is JSON")
}

/// The CSV's header and its rows (empty cells NaN).
fn read_csv(path: &Path) -> BTreeMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).expect("csv");
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().expect("header").split(',').map(str::to_string).collect();
    let mut cols: BTreeMap<String, Vec<f64>> = header.iter().map(|h| (h.clone(), Vec::new())).collect();
    for line in lines {
        for (h, cell) in header.iter().zip(line.split(',')) {
            cols.get_mut(h).unwrap().push(if cell.is_empty() { f64::NAN } else { cell.parse().unwrap() });
        }
    }
    cols
}

/// Runs `magcal import FILE --out CSV --json ARGS`: the report and the columns.
fn import(file: &str, args: &[&str]) -> (Value, BTreeMap<String, Vec<f64>>) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec.csv");
    let log = data(&format!("px4-ulog/{file}"));
    let mut all = vec!["import", p(&log), "--out", p(&out), "--json"];
    all.extend_from_slice(args);
    let o = magcal(&all);
    assert!(o.status.success(), "{file} {args:?}: {}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).expect("--json report");
    (report, read_csv(&out))
}

#[test]
fn ulog_counts_and_rows_agree_with_pyulog() {
    let reference = reference();
    for (file, r) in reference.as_object().unwrap() {
        for case in r["cases"].as_array().unwrap() {
            let args: Vec<&str> = case["args"].as_array().unwrap().iter().map(|a| a.as_str().unwrap()).collect();
            let (report, cols) = import(file, &args);
            // Every topic's data messages, instance by instance: equal.
            let ours: BTreeMap<&str, u64> =
                report["messages"].as_object().unwrap().iter().filter(|(k, _)| k.contains('/')).map(|(k, v)| (k.as_str(), v.as_u64().unwrap())).collect();
            let theirs: BTreeMap<&str, u64> = r["pyulog_counts"].as_object().unwrap().iter().map(|(k, v)| (k.as_str(), v.as_u64().unwrap())).collect();
            assert_eq!(ours, theirs, "{file}");
            assert_eq!(report["skipped"]["dropouts"].as_u64().unwrap_or(0), r["dropouts"].as_u64().unwrap(), "{file}");
            let appended = r["appended_sections"].as_u64().unwrap();
            assert_eq!(report["notes"].as_array().unwrap().iter().any(|n| n.as_str().unwrap() == format!("{appended} appended data sections read")), appended > 0, "{file}");
            assert_eq!(report["rows"].as_u64().unwrap(), case["rows"].as_u64().unwrap(), "{file} {args:?}");
            assert_eq!(report["field_unit"], "gauss");
            // Every row's value. Measured agreement: t to 1e-9 s, the field
            // to 1e-13 gauss, angles to 1e-10° (the reference is written to
            // 12 significant digits); the tolerances are a few times that
            // rounding.
            for (name, values) in case["columns"].as_object().unwrap() {
                let tol = match name.as_str() {
                    "t" => 1e-6,
                    "mx" | "my" | "mz" | "gx" | "gy" | "gz" => 1e-9,
                    "lat_deg" | "lon_deg" => 1e-8,
                    _ => 1e-7,
                };
                let expected: Vec<f64> = values.as_array().unwrap().iter().map(|v| v.as_f64().unwrap_or(f64::NAN)).collect();
                if expected.iter().all(|v| v.is_nan()) {
                    assert!(!cols.contains_key(name.as_str()), "{file} {args:?}: {name} written though pyulog has no value");
                    continue;
                }
                let got = cols.get(name.as_str()).unwrap_or_else(|| panic!("{file} {args:?}: no column {name}"));
                assert_eq!(got.len(), expected.len(), "{file} {args:?} {name}");
                for (i, (g, e)) in got.iter().zip(&expected).enumerate() {
                    assert!(g.is_nan() == e.is_nan() && (g.is_nan() || (g - e).abs() <= tol), "{file} {args:?} {name} row {i}: {g} vs pyulog's {e}");
                }
            }
        }
    }
}

#[test]
fn ulog_report_says_what_the_field_is() {
    // sensor_mag of v1.11: the driver's correction undone, the instances,
    // the rotation not applied, the dropout.
    let (report, _) = import("sample_log_small_cut.ulg", &[]);
    let notes: Vec<&str> = report["notes"].as_array().unwrap().iter().map(|n| n.as_str().unwrap()).collect();
    let has = |s: &str| notes.iter().any(|n| n.contains(s));
    assert!(has("2 instances in the log ([0, 1]); instance 0 imported"), "{notes:#?}");
    assert!(has("1 = device id 592905 (CAL_MAG1) CAL_MAG_PRIME"), "{notes:#?}");
    assert!(has("undone with CAL_MAG0"), "{notes:#?}");
    assert!(has("SENS_BOARD_ROT = 4"), "{notes:#?}");
    assert!(has("30 ms of messages lost"), "{notes:#?}");
    assert!(has("sensor_mag instance 0 has 6 samples, vehicle_magnetometer 319"), "{notes:#?}");
    assert_eq!(report["column_sources"]["ahrs_yaw_deg"]["role"], "own_estimate");
    assert_eq!(report["column_sources"]["mx"]["role"], "compass");
    // On the ground (0.1 m/s): no course at speed, so no reference column.
    assert!(report["column_sources"]["ref_heading_deg"].is_null());
    assert!(report["column_sources"]["course_deg"]["from"].as_str().unwrap().contains("vehicle_gps_position instance 0 cog_rad"));
    // vehicle_magnetometer: the corrected field, said.
    let (report, _) = import("sample_log_small_cut.ulg", &["--topic", "vehicle_magnetometer"]);
    assert!(report["notes"].as_array().unwrap().iter().any(|n| n.as_str().unwrap().starts_with("vehicle_magnetometer is PX4's corrected field")));
    // The older sensor_combined: corrected too, one row per new sample.
    let (report, _) = import("sample_appended_multiple_cut.ulg", &[]);
    let notes = report["notes"].as_array().unwrap();
    assert!(notes.iter().any(|n| n.as_str().unwrap().starts_with("sensor_combined.magnetometer_ga (older PX4) is the corrected field")));
}

#[test]
fn ulog_refusals() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec.csv");
    let log = data("px4-ulog/sample_log_small_cut.ulg");
    let bytes = std::fs::read(&log).unwrap();
    let run = |bytes: &[u8], args: &[&str]| {
        let f = dir.path().join("x.ulg");
        std::fs::write(&f, bytes).unwrap();
        let mut all = vec!["import", p(&f), "--out", p(&out), "--format", "ulog"];
        all.extend_from_slice(args);
        let o = magcal(&all);
        (o.status.success(), String::from_utf8_lossy(&o.stderr).to_string())
    };
    let (ok, err) = run(&bytes[..10], &[]);
    assert!(!ok && err.contains("truncated in its header (10 of 16 bytes)"), "{err}");
    let (ok, err) = run(&bytes[..2000], &[]);
    assert!(!ok && err.contains("ends before its data section"), "{err}");
    let mut wrong = bytes.clone();
    wrong[0] = b'X';
    let (ok, err) = run(&wrong, &[]);
    assert!(!ok && err.contains("not a PX4 ULog"), "{err}");
    let (ok, err) = run(&bytes, &["--instance", "2"]);
    assert!(!ok && err.contains("no instance 2") && err.contains("[0, 1]"), "{err}");
    let (ok, err) = run(&bytes, &["--topic", "sensor_baro"]);
    assert!(!ok && err.contains("--topic sensor_baro") && err.contains("sensor_mag, vehicle_magnetometer"), "{err}");
    // Cut in the middle of the data, mid-message: read to there, the tail counted.
    let (ok, err) = run(&bytes[..bytes.len() - 1000], &[]);
    assert!(ok && err.contains("truncated tail bytes"), "{err}");
    // The simulated log without its sensor_mag subscription: no magnetometer.
    let sim = std::fs::read(data("px4-ulog/sim_swing.ulg")).unwrap();
    let at = sim.windows(10).position(|w| w == b"sensor_mag").unwrap();
    let mut no_mag = sim.clone();
    no_mag[at..at + 10].copy_from_slice(b"sensor_xxx");
    let (ok, err) = run(&no_mag, &[]);
    assert!(!ok && err.contains("has no magnetometer") && err.contains("vehicle_attitude/0"), "{err}");
    // By content, not by name: detected without --format.
    let o = magcal(&["import", p(&log), "--out", p(&out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A simulated swing written as a ULog (sim_to_ulog.py), imported back and
/// fitted: the same calibration as the recording's own.
#[test]
fn ulog_import_fits_like_the_recording() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    let o = magcal(&["import", p(&data("px4-ulog/sim_swing.ulg")), "--out", p(&rec)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (a, b) = (dir.path().join("a.json"), dir.path().join("b.json"));
    let o = magcal(&["fit", "--input", p(&data("px4-ulog/sim_swing.csv")), "--field-nt", "47000", "--out", p(&a)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = magcal(&["fit", "--input", p(&rec), "--columns", "mx=mx:gauss,my=my:gauss,mz=mz:gauss", "--field-nt", "47000", "--out", p(&b)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let read = |f: &Path| -> Value { serde_json::from_str(&std::fs::read_to_string(f).unwrap()).unwrap() };
    let (a, b) = (read(&a), read(&b));
    assert_eq!(a["model"], b["model"]);
    // Measured: bias within 4e-5 nT, matrix within 3e-8 (the field went
    // through float32 gauss).
    for k in 0..3 {
        let (x, y) = (a["bias"][k].as_f64().unwrap(), b["bias"][k].as_f64().unwrap());
        assert!((x - y).abs() < 1e-3, "bias {k}: {x} vs {y}");
        for j in 0..3 {
            let (x, y) = (a["matrix"][k][j].as_f64().unwrap(), b["matrix"][k][j].as_f64().unwrap());
            assert!((x - y).abs() < 1e-6, "matrix {k}{j}: {x} vs {y}");
        }
    }
}
