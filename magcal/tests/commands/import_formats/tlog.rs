//! `magcal import` of a MAVLink telemetry log (a real BlueROV2's topside
//! `.tlog`, `tests/data/ardusub-bluerov2/small.tlog`) against pymavlink's
//! reading of it (`reference.json`, written by `reference.py` beside it):
//! message counts, the raw field (ArduPilot's correction undone), the gyro,
//! the attitude; corrupt, truncated and foreign input; the output into
//! `magcal fit`.

use std::path::Path;

use serde_json::Value;

use crate::{data, magcal, p, read_csv};

fn reference() -> Value {
    let text = std::fs::read_to_string(data("ardusub-bluerov2/reference.json")).unwrap();
    serde_json::from_str::<Value>(&text).unwrap()["tlog"].clone()
}

/// Imports `log` (format from the content unless `args` names it) and
/// returns the report and the recording.
fn import(log: &Path, args: &[&str]) -> (Value, Vec<String>, Vec<Vec<f64>>) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rec.csv");
    let mut all = vec!["import", p(log), "--out", p(&out), "--json"];
    all.extend_from_slice(args);
    let o = magcal(&all);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: Value = serde_json::from_slice(&o.stdout).unwrap();
    let (header, rows) = read_csv(&out);
    (report, header, rows)
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap()
}

#[test]
fn tlog_import_agrees_with_pymavlink() {
    let r = reference();
    let (report, header, rows) = import(&data("ardusub-bluerov2/small.tlog"), &[]);
    assert_eq!(report["format"], "tlog", "found from the content");
    // Counts: every message kind as pymavlink counts it; its BAD_DATA are
    // the frames whose checksum fails (4 on this cut and on the full log).
    let mut counts = r["counts"].as_object().unwrap().clone();
    let bad = counts.remove("BAD_DATA").unwrap();
    assert_eq!(report["messages"].as_object().unwrap(), &counts);
    assert_eq!(report["skipped"]["frames_with_bad_checksum"], bad);
    assert_eq!(report["skipped"].as_object().unwrap().len(), 1, "nothing else skipped: {}", report["skipped"]);
    assert_eq!(report["field_unit"], "mGauss");

    let raw_imu = r["RAW_IMU"].as_array().unwrap();
    assert_eq!(rows.len(), raw_imu.len(), "one row per RAW_IMU");
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {header:?}"));
    let (t, gx, roll, pitch, yaw) = (col("t"), col("gx"), col("roll_deg"), col("pitch_deg"), col("ahrs_yaw_deg"));
    let mag = [col("mx"), col("my"), col("mz")];
    let (mut worst_field, mut worst_att, mut with_att): (f64, f64, usize) = (0.0, 0.0, 0);
    for (row, x) in rows.iter().zip(raw_imu) {
        assert!((row[t] - f(&x["time_usec"]) * 1e-6).abs() < 1e-9, "the autopilot's clock");
        for k in 0..3 {
            worst_field = worst_field.max((row[mag[k]] - f(&x["raw"][k])).abs());
            assert!((row[gx + k] - f(&x["gyro"][k]) * 1e-3).abs() < 1e-12, "gyro mrad/s → rad/s");
        }
        match x["attitude_deg"].as_array() {
            Some(a) => {
                with_att += 1;
                for (c, v) in [roll, pitch, yaw].into_iter().zip(a) {
                    let d = (row[c] - f(v) + 180.0).rem_euclid(360.0) - 180.0;
                    worst_att = worst_att.max(d.abs());
                }
            }
            None => assert!(row[roll].is_nan() && row[yaw].is_nan()),
        }
    }
    // Measured: 1.1e-13 mGauss and 5.7e-14° (the same arithmetic in double).
    eprintln!("tlog vs pymavlink: field {worst_field:.1e} mGauss, attitude {worst_att:.1e}° over {with_att} rows");
    assert!(worst_field < 1e-9 && worst_att < 1e-9, "{worst_field} {worst_att}");
    assert!(with_att >= raw_imu.len() - 2, "{with_att}");

    // The sources: the compass, the vehicle's own yaw, no reference here (the
    // GPS is fed over GPS_INPUT and stands still).
    let sources = &report["column_sources"];
    assert_eq!(sources["mx"]["role"], "compass");
    assert!(sources["mx"]["from"].as_str().unwrap().contains("correction undone"));
    assert_eq!(sources["ahrs_yaw_deg"]["role"], "own_estimate");
    assert_eq!(sources["gx"]["role"], "sensor");
    assert!(!header.iter().any(|h| h == "ref_heading_deg"), "{header:?}");
    let notes = report["notes"].to_string();
    assert!(notes.contains("GPS_INPUT") && notes.contains("not used as a reference"), "{notes}");
    assert!(notes.contains("2 instances"), "{notes}");
}

#[test]
fn the_second_compass_is_scaled_imu2() {
    let r = reference();
    let (report, header, rows) = import(&data("ardusub-bluerov2/small.tlog"), &["--format", "tlog", "--instance", "1"]);
    let s2 = r["SCALED_IMU2"].as_array().unwrap();
    assert_eq!(rows.len(), s2.len());
    let mx = header.iter().position(|h| h == "mx").unwrap();
    let mut worst: f64 = 0.0;
    for (row, x) in rows.iter().zip(s2) {
        assert!((row[0] - f(&x["time_boot_ms"]) * 1e-3).abs() < 1e-9);
        for k in 0..3 {
            worst = worst.max((row[mx + k] - f(&x["raw"][k])).abs());
        }
    }
    // Measured 0 (DIA2 = 1, ODI2 = 0: only the offsets).
    assert!(worst < 1e-9, "{worst}");
    assert!(report["column_sources"]["mx"]["from"].as_str().unwrap().starts_with("SCALED_IMU2"));
    // The gyro is still IMU 0's (SCALED_IMU2's IMU is absent on this vehicle).
    assert!(report["column_sources"]["gx"]["from"].as_str().unwrap().contains("RAW_IMU"));
}

/// The records of the fixture: (offset, length).
fn records(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut o = 0;
    while o + 11 <= bytes.len() {
        let n = bytes[o + 9] as usize;
        let len = match bytes[o + 8] {
            0xFE => 8 + 8 + n,
            _ => 8 + 12 + n + if bytes[o + 10] & 1 != 0 { 13 } else { 0 },
        };
        out.push((o, len));
        o += len;
    }
    out
}

#[test]
fn corrupt_truncated_and_foreign_logs() {
    let bytes = std::fs::read(data("ardusub-bluerov2/small.tlog")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, b: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, b).unwrap();
        path
    };
    let (clean, _, clean_rows) = import(&data("ardusub-bluerov2/small.tlog"), &[]);
    let recs = records(&bytes);

    // Cut inside the last record: the tail counted, the rest read.
    let (last_o, _) = *recs.last().unwrap();
    let cut = write("cut.tlog", &bytes[..last_o + 15]);
    let (report, _, _) = import(&cut, &[]);
    assert_eq!(report["skipped"]["truncated_tail_bytes"], 15);

    // Garbage inside: 1 000 bytes of noise between two records, and 20
    // records' checksums broken: each counted, the import goes on.
    let (mid, _) = recs[recs.len() / 2];
    let mut bad = bytes[..mid].to_vec();
    let mut x = 12345u32;
    bad.extend((0..1000).map(|_| {
        x = x.wrapping_mul(1_103_515_245).wrapping_add(12345);
        (x >> 16) as u8
    }));
    bad.extend(&bytes[mid..]);
    for &(o, len) in recs.iter().skip(100).step_by(50).take(20) {
        let o = if o >= mid { o + 1000 } else { o };
        bad[o + len - 3] ^= 0xA5; // the last payload byte
    }
    let (report, _, rows) = import(&write("bad.tlog", &bad), &["--format", "tlog"]);
    let skipped = &report["skipped"];
    let total = |r: &Value| r["messages"].as_object().unwrap().values().map(|v| v.as_u64().unwrap()).sum::<u64>();
    assert_eq!(skipped["frames_with_bad_checksum"].as_u64().unwrap(), 4 + 20, "{skipped}");
    assert_eq!(skipped["bytes_skipped_to_resynchronise"], 1000, "{skipped}");
    assert_eq!(total(&clean) - total(&report), 20, "only the broken frames lost");
    assert!(rows.len() >= clean_rows.len() - 20);

    // Not a tlog: refused by name, with --format or without.
    let csv = write("rec.tlog", b"t,mx,my,mz\n0,1,2,3\n");
    let o = magcal(&["import", p(&csv), "--format", "tlog", "--out", p(&dir.path().join("o.csv"))]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("not a MAVLink telemetry log"), "{}", String::from_utf8_lossy(&o.stderr));
    // Wrong start bytes: not recognised from the content.
    let wrong: Vec<u8> = bytes.iter().map(|&b| if b == 0xFE || b == 0xFD { 0xFC } else { b }).collect();
    let o = magcal(&["import", p(&write("wrong.tlog", &wrong)), "--out", p(&dir.path().join("o.csv"))]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("not recognised"), "{}", String::from_utf8_lossy(&o.stderr));
    // Truncated inside its first record.
    let o = magcal(&["import", p(&write("short.tlog", &bytes[..12])), "--format", "tlog", "--out", p(&dir.path().join("o.csv"))]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("truncated"), "{}", String::from_utf8_lossy(&o.stderr));
    // No magnetometer: the RAW_IMU and SCALED_IMU2 records taken out.
    let no_mag: Vec<u8> = recs
        .iter()
        .filter(|&&(o, _)| {
            let id = if bytes[o + 8] == 0xFE { bytes[o + 13] as u32 } else { u32::from_le_bytes([bytes[o + 15], bytes[o + 16], bytes[o + 17], 0]) };
            id != 27 && id != 116
        })
        .flat_map(|&(o, len)| bytes[o..o + len].iter().copied())
        .collect();
    let o = magcal(&["import", p(&write("nomag.tlog", &no_mag)), "--out", p(&dir.path().join("o.csv"))]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("no magnetometer") && err.contains("ATTITUDE 866"), "{err}");
}

/// Item 7: the recording goes straight into `magcal fit`, which reads its
/// columns and judges the data (this short dive turns through few headings:
/// the gyro-aided fit says the data do not constrain a calibration).
#[test]
fn the_import_goes_into_fit() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    let o = magcal(&["import", p(&data("ardusub-bluerov2/small.tlog")), "--out", p(&rec)]);
    assert!(o.status.success());
    // The site: the tlog's own GPS position (48.386° N, 124.631° W) and date.
    let site = ["--lat", "48.386", "--lon", "-124.631", "--date", "2023-05-04"];
    let cal = dir.path().join("cal.json");
    let mut args = vec!["fit", "--input", p(&rec), "--model", "gyro", "--out", p(&cal)];
    args.extend(site);
    let o = magcal(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("gyro fit") && err.contains("do not constrain a full calibration"), "{err}");
    assert!(!err.contains("column") && !err.contains("gx"), "past the column checks: {err}");
}

/// A simulated swing written as a tlog (`tests/data/sim-tlog/`, pymavlink's
/// encoder) imports back to the simulator's rows, and `magcal fit` finds the
/// same calibration from both.
#[test]
fn a_simulated_swing_round_trips_through_a_tlog() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("swing.csv");
    let o = magcal(&["simulate", "swing", "--seed", "1", "--rate-hz", "2", "--out", p(&csv)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (report, header, rows) = import(&data("sim-tlog/swing.tlog"), &[]);
    assert_eq!(report["messages"]["RAW_IMU"], 2660);
    let (sim_header, sim) = read_csv(&csv);
    assert_eq!(rows.len(), sim.len(), "one row per simulated sample");
    let at = |h: &[String], name: &str| h.iter().position(|x| x == name).unwrap();
    let mut worst_att: f64 = 0.0;
    for (row, s) in rows.iter().zip(&sim) {
        assert!((row[0] - 100.0 - s[0]).abs() < 1e-6, "the boot clock starts at 100 s");
        for name in ["mx", "my", "mz"] {
            assert_eq!(row[at(&header, name)], s[at(&sim_header, name)], "the field exact");
        }
        for name in ["roll_deg", "pitch_deg"] {
            worst_att = worst_att.max((row[at(&header, name)] - s[at(&sim_header, name)]).abs());
        }
    }
    eprintln!("tlog rows vs the simulator's: attitude worst {worst_att:.1e}°");
    // Measured 1.7e-6° (radians as f32).
    assert!(worst_att < 1e-5, "{worst_att}");

    let tl = dir.path().join("tlog.csv");
    assert!(magcal(&["import", p(&data("sim-tlog/swing.tlog")), "--out", p(&tl)]).status.success());
    let fit = |input: &Path, out: &Path| {
        // One model named: the tlog carries a gyro the CSV has not, so
        // `auto` judges the two by different references (the gyro's yaw,
        // the field) and may keep either of two candidates that tie.
        let o = magcal(&["fit", "--input", p(input), "--model", "attitude", "--lat", "36.9", "--lon", "50.6", "--date", "2021.0", "--out", p(out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        serde_json::from_str::<Value>(&std::fs::read_to_string(out).unwrap()).unwrap()
    };
    let (a, b) = (fit(&csv, &dir.path().join("a.json")), fit(&tl, &dir.path().join("b.json")));
    assert_eq!(a["model"], b["model"]);
    let numbers = |v: &Value| -> Vec<f64> { v["bias"].as_array().unwrap().iter().chain(v["matrix"].as_array().unwrap().iter().flat_map(|r| r.as_array().unwrap())).map(f).collect() };
    let worst = numbers(&a).iter().zip(numbers(&b)).map(|(x, y)| (x - y).abs() / x.abs().max(1e-3)).fold(0.0, f64::max);
    // Measured 2.4e-7 relative (the attitude's f32 rounding).
    eprintln!("fit from the tlog vs from the CSV: worst {worst:.1e} relative");
    assert!(worst < 2e-6, "{worst}");
}
