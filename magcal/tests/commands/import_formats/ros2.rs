//! `magcal import` of ROS 2 bags (MCAP and sqlite3 storage) against rosbags,
//! the independent reader: `tests/data/ros2/reference.json` (written by
//! `reference.py` from the bags `make_bags.py` wrote from the simulator's
//! `swing.csv`); the round trip to the simulator's rows and calibration,
//! `apply` judging against the bag's GNSS heading; and hostile bags.

use std::path::{Path, PathBuf};

use crate::{data, magcal, p, read_csv};

/// The bags: the name in reference.json and the file.
fn bags() -> [(&'static str, PathBuf); 2] {
    [("swing.mcap", data("ros2/swing.mcap")), ("swing_db3", data("ros2/swing_db3/swing_db3.db3"))]
}

fn reference() -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(data("ros2/reference.json")).unwrap()).unwrap()
}

/// A column of a CSV read by [`read_csv`].
fn column(table: &(Vec<String>, Vec<Vec<f64>>), name: &str) -> Vec<f64> {
    let k = table.0.iter().position(|h| h == name).unwrap_or_else(|| panic!("no {name} in {:?}", table.0));
    table.1.iter().map(|r| r[k]).collect()
}

/// Imports `bag` (with `extra` arguments): the report and the recording.
fn import(bag: &Path, out: &Path, extra: &[&str]) -> (serde_json::Value, (Vec<String>, Vec<Vec<f64>>)) {
    let mut args = vec!["import", p(bag), "--out", p(out), "--json"];
    args.extend(extra);
    let o = magcal(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (serde_json::from_slice(&o.stdout).unwrap(), read_csv(out))
}

fn angle_diff(a: f64, b: f64) -> f64 {
    ((a - b).rem_euclid(360.0) + 180.0).rem_euclid(360.0) - 180.0
}

/// The largest difference, row by row, between a column and the reference's
/// values (matched by time), angles the short way.
fn worst(rows_t: &[f64], got: &[f64], reference: &serde_json::Value, k: usize, angle: bool) -> f64 {
    let by_t: Vec<(f64, f64)> = reference.as_array().unwrap().iter().map(|r| (r[0].as_f64().unwrap(), r[k].as_f64().unwrap())).collect();
    rows_t
        .iter()
        .zip(got)
        .map(|(&t, &v)| {
            let &(_, want) = by_t.iter().find(|(rt, _)| (rt - t).abs() < 1e-9).unwrap_or_else(|| panic!("no reference sample at t = {t}"));
            if angle {
                angle_diff(v, want).abs()
            } else {
                (v - want).abs() / want.abs().max(1e-300)
            }
        })
        .fold(0.0, f64::max)
}

#[test]
fn both_storages_agree_with_rosbags() {
    let dir = tempfile::tempdir().unwrap();
    let reference = reference();
    for (name, bag) in bags() {
        let r = &reference[name];
        let (report, table) = import(&bag, &dir.path().join(format!("{name}.csv")), &[]);
        // Counts: every message of every topic, equal to rosbags'.
        assert_eq!(report["messages"], r["counts"], "{name}");
        // The corrupt messages rosbags cannot decode are the ones skipped.
        assert_eq!(r["undecodable"], serde_json::json!({"/imu/mag": 2}), "{name}");
        assert_eq!(report["skipped"], serde_json::json!({"short_cdr_message: /imu/mag": 2}), "{name}");
        let values = &r["values"];
        let t = column(&table, "t");
        assert_eq!(t.len(), values["/imu/mag"].as_array().unwrap().len(), "{name}: one row a decoded /imu/mag message");
        assert_eq!(report["field_unit"], "nT");
        // Measured: the field, rates and position equal (0 difference: the
        // same f64 arithmetic), the angles within 6e-14° (two formulae);
        // tolerances a float's rounding, a few times over.
        for (k, c) in ["mx", "my", "mz"].into_iter().enumerate() {
            let w = worst(&t, &column(&table, c), &values["/imu/mag"], k + 1, false);
            assert!(w < 1e-12, "{name} {c}: {w:e} relative");
        }
        for (k, c) in ["roll_deg", "pitch_deg", "ahrs_yaw_deg"].into_iter().enumerate() {
            let w = worst(&t, &column(&table, c), &values["/imu/data"], k + 1, true);
            assert!(w < 1e-12, "{name} {c}: {w:e}°");
        }
        for (k, c) in ["gx", "gy", "gz"].into_iter().enumerate() {
            let w = worst(&t, &column(&table, c), &values["/imu/data"], k + 4, false);
            assert!(w < 1e-12, "{name} {c}: {w:e} relative");
        }
        for (k, c) in ["lat_deg", "lon_deg"].into_iter().enumerate() {
            let w = worst(&t, &column(&table, c), &values["/gnss/fix"], k + 1, false);
            assert!(w < 1e-12, "{name} {c}: {w:e} relative");
        }
        let w = worst(&t, &column(&table, "ref_heading_deg"), &values["/gnss/heading"], 1, true);
        assert!(w < 1e-12, "{name} ref_heading_deg: {w:e}°");
        // Sources and roles: the heading topic is the reference, the IMU's
        // yaw the vehicle's own estimate.
        assert_eq!(report["column_sources"]["ref_heading_deg"]["role"], "reference");
        assert_eq!(report["column_sources"]["ahrs_yaw_deg"]["role"], "own_estimate");
        assert_eq!(report["column_sources"]["mx"]["role"], "compass");
        assert!(report["column_sources"]["mx"]["from"].as_str().unwrap().contains("/imu/mag"));
        assert!(report["clock"].as_str().unwrap().contains("header.stamp"), "{}", report["clock"]);
        let notes = report["notes"].to_string();
        assert!(notes.contains("/imu/mag taken") && notes.contains("/payload/mag (133)"), "{notes}");
        assert!(notes.contains("FLU") && notes.contains("NED"), "{notes}");
    }
}

#[test]
fn a_bag_written_from_the_simulator_imports_back_to_its_rows() {
    let dir = tempfile::tempdir().unwrap();
    let sim = read_csv(&data("ros2/swing.csv"));
    for (name, bag) in bags() {
        let (_, table) = import(&bag, &dir.path().join(format!("{name}.csv")), &[]);
        assert_eq!(column(&table, "t"), column(&sim, "t"), "{name}");
        // Asked: the field to 1e-6 relative, the attitude to 0.01°.
        // Measured: the field to 2.2e-16 relative (tesla and back), the
        // angles to 3e-14° (the quaternion and back), the rates and the
        // position equal; tolerances a few times that.
        for c in ["mx", "my", "mz"] {
            for (a, b) in column(&table, c).iter().zip(column(&sim, c)) {
                assert!((a - b).abs() <= 1e-15 * b.abs().max(1.0), "{name} {c}: {a} vs {b}");
            }
        }
        for (c, s) in [("roll_deg", "roll_deg"), ("pitch_deg", "pitch_deg"), ("ahrs_yaw_deg", "true_heading_deg"), ("ref_heading_deg", "true_heading_deg")] {
            for (a, b) in column(&table, c).iter().zip(column(&sim, s)) {
                assert!(angle_diff(*a, b).abs() < 1e-12, "{name} {c}: {a} vs {b}");
            }
        }
        for c in ["gx", "gy", "gz", "lat_deg", "lon_deg"] {
            for (a, b) in column(&table, c).iter().zip(column(&sim, c)) {
                assert!((a - b).abs() <= 1e-15 * b.abs().max(1e-3), "{name} {c}: {a} vs {b}");
            }
        }
    }
}

/// `magcal fit --json` on a recording: the model, bias and matrix.
fn fit(input: &Path) -> (String, Vec<f64>) {
    // One model named: the bag carries a heading topic the CSV has not, so
    // `auto` judges the two by different references (the heading, the
    // field) and may keep either of two candidates 0.01° apart.
    let o = magcal(&["fit", "--input", p(input), "--model", "attitude", "--lat", "36.9", "--lon", "50.6", "--date", "2021.0", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let mut v: Vec<f64> = doc["bias"].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
    for row in doc["matrix"].as_array().unwrap() {
        v.extend(row.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()));
    }
    (doc["model"].as_str().unwrap().to_string(), v)
}

#[test]
fn fit_on_the_imported_bag_gives_the_simulators_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let (model, want) = fit(&data("ros2/swing.csv"));
    for (name, bag) in bags() {
        let out = dir.path().join(format!("{name}.csv"));
        import(&bag, &out, &[]);
        let (m, got) = fit(&out);
        assert_eq!(m, model, "{name}");
        // Measured: 2e-14 relative at most (the field's last bits through
        // tesla).
        for (a, b) in got.iter().zip(&want) {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-3), "{name}: {got:?} vs {want:?}");
        }
    }
}

/// `magcal apply --json` of `cal` on a recording: the summary.
fn apply(input: &Path, cal: &Path, out: &Path) -> serde_json::Value {
    let o = magcal(&["apply", "--input", p(input), "--cal", p(cal), "--out", p(out), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).unwrap()
}

#[test]
fn apply_judges_the_imported_bag_against_its_gnss_heading() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let cal = d.join("cal.json");
    let o = magcal(&["fit", "--input", p(&data("ros2/swing.csv")), "--lat", "36.9", "--lon", "50.6", "--date", "2021.0", "--out", p(&cal)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let on_csv = apply(&data("ros2/swing.csv"), &cal, &d.join("a.csv"));
    assert_eq!(on_csv["heading_reference"], "true_heading_deg");
    for (name, bag) in bags() {
        let rec = d.join(format!("{name}.csv"));
        import(&bag, &rec, &[]);
        let s = apply(&rec, &cal, &d.join(format!("{name}.applied.csv")));
        // The bag's /gnss/heading (a GNSS compass's, here the simulator's
        // true heading) is the reference: the same heading error as against
        // the simulator's truth (measured: equal to 2e-15°).
        assert_eq!(s["heading_reference"], "ref_heading_deg", "{name}");
        assert_eq!(s["rows"], 266);
        let (a, b) = (s["heading_rms_deg"].as_f64().unwrap(), on_csv["heading_rms_deg"].as_f64().unwrap());
        assert!((a - b).abs() < 1e-12, "{name}: {a} vs {b}");
    }
}

#[test]
fn topic_picks_another_magnetometer() {
    let dir = tempfile::tempdir().unwrap();
    let reference = reference();
    for (name, bag) in bags() {
        let (report, table) = import(&bag, &dir.path().join(format!("{name}.csv")), &["--topic", "/payload/mag"]);
        let t = column(&table, "t");
        assert_eq!(t.len(), 133, "{name}");
        assert!(report["column_sources"]["mx"]["from"].as_str().unwrap().contains("/payload/mag"));
        assert!(report["notes"].to_string().contains("/payload/mag of /imu/mag, /payload/mag (--topic)"), "{}", report["notes"]);
        let w = worst(&t, &column(&table, "mx"), &reference[name]["values"]["/payload/mag"], 1, false);
        assert!(w < 1e-12, "{name}: {w:e}");
        let o = magcal(&["import", p(&bag), "--out", p(&dir.path().join("x.csv")), "--topic", "/gnss/fix"]);
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("--topic /gnss/fix: not a sensor_msgs/msg/MagneticField topic") && e.contains("/imu/mag, /payload/mag"), "{e}");
    }
}

/// Runs `magcal import` on `bytes` written to a file: its exit status and
/// stderr; fails on a panic.
fn import_bytes(dir: &Path, bytes: &[u8], format: &str) -> (bool, String) {
    let log = dir.join("hostile.bag");
    std::fs::write(&log, bytes).unwrap();
    let o = magcal(&["import", p(&log), "--format", format, "--out", p(&dir.join("hostile.csv"))]);
    let e = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(!e.contains("panicked"), "{e}");
    (o.status.success(), e)
}

#[test]
fn hostile_bags_are_refused_or_counted_never_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // No magnetometer topic: refused, naming the topics found.
    for (bag, format) in [("ros2/nomag.mcap", "mcap"), ("ros2/nomag_db3/nomag_db3.db3", "sqlite3")] {
        let (ok, e) = import_bytes(d, &std::fs::read(data(bag)).unwrap(), format);
        assert!(!ok, "{bag}");
        assert!(e.contains("no sensor_msgs/msg/MagneticField topic in the bag") && e.contains("/imu/data (sensor_msgs/msg/Imu)"), "{e}");
    }
    let mcap = std::fs::read(data("ros2/swing.mcap")).unwrap();
    let db3 = std::fs::read(data("ros2/swing_db3/swing_db3.db3")).unwrap();
    // Wrong magic.
    let mut bad = mcap.clone();
    bad[1] = b'X';
    let (ok, e) = import_bytes(d, &bad, "mcap");
    assert!(!ok && e.contains("not an MCAP file"), "{e}");
    let mut bad = db3.clone();
    bad[0] = b'X';
    let (ok, e) = import_bytes(d, &bad, "sqlite3");
    assert!(!ok && e.contains("not an SQLite database"), "{e}");
    // Only the database's header.
    let (ok, e) = import_bytes(d, &db3[..100], "sqlite3");
    assert!(!ok && e.contains("SQLite database cut short: 100 bytes where its header counts"), "{e}");
    // Empty and cut inside the header.
    for (bytes, format) in [(&mcap[..0], "mcap"), (&mcap[..5], "mcap"), (&db3[..0], "sqlite3"), (&db3[..50], "sqlite3")] {
        let (ok, e) = import_bytes(d, bytes, format);
        assert!(!ok, "{format} {}: {e}", bytes.len());
    }
    // MCAP cut short: the chunk holding the cut is lost, the rest refused or
    // imported with the damage counted.
    for cut in [mcap.len() / 3, mcap.len() / 2, mcap.len() - 10] {
        let (ok, e) = import_bytes(d, &mcap[..cut], "mcap");
        assert!(!ok || e.contains("the MCAP file is damaged or cut short after its message"), "cut {cut}: {e}");
    }
    // sqlite3 cut short at a page boundary and inside a page: refused
    // (SQLite finds the database malformed; the header's page count says why).
    for cut in [db3.len() / 2, db3.len() / 2 + 1000, db3.len() - 4096] {
        let (ok, e) = import_bytes(d, &db3[..cut], "sqlite3");
        assert!(!ok && e.contains(&format!("SQLite database cut short: {cut} bytes where its header counts")), "cut {cut}: {e}");
    }
}
