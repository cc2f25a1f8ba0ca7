//! `magcal import --dataflash` against an independent reader: pymavlink's
//! `DFReader_binary` reads the same log, which this test writes the way
//! ArduPilot does (FMT, PARM, MAG as `Compass::Write_Compass_instance` in
//! libraries/AP_Compass/AP_Compass_Logging.cpp: the *corrected* field of
//! `AP_Compass_Backend::correct_field`, cast to int16, with the offsets and
//! motor offsets beside it). The expected raw field is undone here from
//! pymavlink's values with correct_field's formula
//! `field = s·Mat·(raw + Ofs) + MO`.
//!
//! pymavlink is installed with pip when missing; if that fails the test
//! says SKIPPED loudly and passes.

use std::path::Path;
use std::process::{Command, Output};
use super::{magcal, read_csv};

fn size(c: char) -> usize {
    match c {
        'b' | 'B' | 'M' => 1,
        'h' | 'H' | 'c' | 'C' => 2,
        'i' | 'I' | 'e' | 'E' | 'L' | 'f' | 'n' => 4,
        'd' | 'q' | 'Q' => 8,
        'N' => 16,
        'Z' => 64,
        _ => panic!("{c}"),
    }
}

/// A field value to pack with its format character.
enum V {
    U(u64),
    I(i64),
    F(f64),
    S(&'static str),
}

struct Log {
    bytes: Vec<u8>,
    formats: Vec<(u8, &'static str)>,
}

impl Log {
    fn fmt(&mut self, type_id: u8, name: &str, format: &'static str, labels: &str) {
        let len = 3 + format.chars().map(size).sum::<usize>();
        self.bytes.extend([0xA3, 0x95, 128, type_id, len as u8]);
        for (s, n) in [(name, 4), (format, 16), (labels, 64)] {
            let mut v = s.as_bytes().to_vec();
            v.resize(n, 0);
            self.bytes.extend(v);
        }
        self.formats.push((type_id, format));
    }

    fn msg(&mut self, type_id: u8, values: &[V]) {
        let format = self.formats.iter().find(|f| f.0 == type_id).unwrap().1;
        self.bytes.extend([0xA3, 0x95, type_id]);
        for (c, v) in format.chars().zip(values) {
            match (c, v) {
                ('B', V::U(x)) => self.bytes.push(*x as u8),
                ('h', V::I(x)) => self.bytes.extend((*x as i16).to_le_bytes()),
                ('c', V::F(x)) => self.bytes.extend(((x * 100.0).round() as i16).to_le_bytes()),
                ('C', V::F(x)) => self.bytes.extend(((x * 100.0).round() as u16).to_le_bytes()),
                ('e', V::F(x)) => self.bytes.extend(((x * 100.0).round() as i32).to_le_bytes()),
                ('L', V::F(x)) => self.bytes.extend(((x * 1e7).round() as i32).to_le_bytes()),
                ('I', V::U(x)) => self.bytes.extend((*x as u32).to_le_bytes()),
                ('H', V::U(x)) => self.bytes.extend((*x as u16).to_le_bytes()),
                ('f', V::F(x)) => self.bytes.extend((*x as f32).to_le_bytes()),
                ('Q', V::U(x)) => self.bytes.extend(x.to_le_bytes()),
                ('N', V::S(s)) => {
                    let mut b = s.as_bytes().to_vec();
                    b.resize(16, 0);
                    self.bytes.extend(b);
                }
                _ => panic!("bad value for {c}"),
            }
        }
    }
}

const PARAMS: [(&str, f64); 7] = [
    ("COMPASS_DIA_X", 1.02),
    ("COMPASS_DIA_Y", 0.98),
    ("COMPASS_DIA_Z", 1.01),
    ("COMPASS_ODI_X", 0.01),
    ("COMPASS_ODI_Y", -0.005),
    ("COMPASS_ODI_Z", 0.008),
    ("COMPASS_SCALE", 1.05),
];
const OFS: [f64; 3] = [-120.0, 85.0, -40.0];
const MOT_PER_A: [f64; 3] = [0.5, -0.3, 0.2];

fn truth_raw(k: usize) -> [f64; 3] {
    let a = k as f64 * 0.07;
    [300.0 * a.cos() + 50.0, -300.0 * a.sin() - 20.0, 420.0 + 30.0 * (0.3 * a).sin()]
}

/// The log: 100 MAG samples (10 Hz) of compass 0 and as many of compass 1,
/// ATT at the same times, GPS at 5 Hz (3D fix for the first half, none
/// after), BAT current; three junk bytes in the middle.
fn write_log() -> Vec<u8> {
    let mut log = Log { bytes: vec![], formats: vec![] };
    log.fmt(64, "PARM", "QNf", "TimeUS,Name,Value");
    log.fmt(65, "MAG", "QBhhhhhhhhhBI", "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ,MOX,MOY,MOZ,Health,S");
    log.fmt(66, "ATT", "QccccCCff", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw");
    log.fmt(67, "GPS", "QBBIHBcLLeffff", "TimeUS,I,Status,GMS,GWk,NSats,HDop,Lat,Lng,Alt,Spd,GCrs,VZ,Yaw");
    log.fmt(68, "BAT", "QBfffffcf", "TimeUS,Inst,Volt,VoltR,Curr,CurrTot,EnrgTot,Temp,Res");
    for (n, v) in PARAMS {
        log.msg(64, &[V::U(1000), V::S(n), V::F(v)]);
    }
    let (d, o) = ([1.02, 0.98, 1.01], [0.01, -0.005, 0.008]);
    let mat = [[d[0], o[0], o[1]], [o[0], d[1], o[2]], [o[1], o[2], d[2]]];
    for k in 0..100usize {
        let t_us = 2_000_000 + k as u64 * 100_000;
        if k == 50 {
            log.bytes.extend([0x00, 0xA3, 0x11]);
        }
        let current = 5.0 + (k % 20) as f64;
        log.msg(66, &[V::U(t_us), V::F(0.0), V::F(10.0 * (k as f64 * 0.1).sin()), V::F(0.0), V::F(-3.0 + 0.05 * k as f64), V::F(0.0), V::F((k as f64 * 3.7) % 360.0), V::F(0.0), V::F(0.0)]);
        if k % 2 == 0 {
            let status = if k < 50 { 3 } else { 1 };
            log.msg(67, &[V::U(t_us), V::U(0), V::U(status), V::U(0), V::U(0), V::U(12), V::F(0.8), V::F(36.9 + k as f64 * 1e-5), V::F(50.6 - k as f64 * 1e-5), V::F(-2.0), V::F(if k < 20 { 0.2 } else { 1.6 }), V::F(k as f64 * 2.0), V::F(0.0), V::F(0.0)]);
        }
        log.msg(68, &[V::U(t_us), V::U(0), V::F(15.8), V::F(15.9), V::F(current), V::F(0.0), V::F(0.0), V::F(25.0), V::F(0.01)]);
        for inst in 0..2u64 {
            let raw = truth_raw(k).map(|r| r + inst as f64 * 1000.0);
            let mo = MOT_PER_A.map(|m| m * current);
            let y = [0, 1, 2].map(|i| 1.05 * (mat[i][0] * (raw[0] + OFS[0]) + mat[i][1] * (raw[1] + OFS[1]) + mat[i][2] * (raw[2] + OFS[2])) + mo[i]);
            // (int16_t) truncates towards zero, as Write_Compass_instance does.
            let v = [y[0].trunc(), y[1].trunc(), y[2].trunc(), OFS[0], OFS[1], OFS[2], mo[0].trunc(), mo[1].trunc(), mo[2].trunc()];
            let mut vals = vec![V::U(t_us), V::U(inst)];
            vals.extend(v.iter().map(|x| V::I(*x as i64)));
            vals.extend([V::U(1), V::U(t_us)]);
            log.msg(65, &vals);
        }
    }
    log.bytes
}

const DUMP: &str = r#"
import sys, json
from pymavlink import DFReader
log = DFReader.DFReader_binary(sys.argv[1], zero_time_base=True)
out = {"MAG": [], "ATT": [], "GPS": [], "BAT": [], "PARM": []}
while True:
    m = log.recv_msg()
    if m is None:
        break
    if m.get_type() in out:
        d = m.to_dict()
        d.pop("mavpackettype", None)
        out[m.get_type()].append(d)
print(json.dumps(out))
"#;

fn pymavlink_available() -> bool {
    let have = || Command::new("python3").args(["-c", "import pymavlink.DFReader"]).output().is_ok_and(|o| o.status.success());
    if have() {
        return true;
    }
    let _ = Command::new("python3").args(["-m", "pip", "install", "--quiet", "pymavlink"]).output();
    have()
}

#[derive(serde::Deserialize)]
struct Dump {
    #[serde(rename = "MAG")]
    mag: Vec<serde_json::Map<String, serde_json::Value>>,
    #[serde(rename = "ATT")]
    att: Vec<serde_json::Map<String, serde_json::Value>>,
    #[serde(rename = "GPS")]
    gps: Vec<serde_json::Map<String, serde_json::Value>>,
    #[serde(rename = "BAT")]
    bat: Vec<serde_json::Map<String, serde_json::Value>>,
    #[serde(rename = "PARM")]
    parm: Vec<serde_json::Map<String, serde_json::Value>>,
}

fn f(m: &serde_json::Map<String, serde_json::Value>, k: &str) -> f64 {
    m[k].as_f64().unwrap_or_else(|| panic!("{k} in {m:?}"))
}

#[test]
fn dataflash_import_agrees_with_pymavlink() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("dive.bin");
    std::fs::write(&bin, write_log()).unwrap();
    let rec = dir.path().join("dive.csv");
    let out = magcal(&["import", "--dataflash", bin.to_str().unwrap(), "--out", rec.to_str().unwrap(), "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["rows"], 100);
    assert_eq!(report["messages"]["MAG"], 200);
    assert!(report["skipped"]["corrupt_bytes"].as_u64().unwrap() >= 2, "the junk is counted: {report}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("corrupt bytes"));
    let (header, rows) = read_csv(&rec);
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {header:?}"));
    let (t, mx, my, mz, roll, pitch, course, lat, yaw, cur) =
        (col("t"), col("mx"), col("my"), col("mz"), col("roll_deg"), col("pitch_deg"), col("ref_heading_deg"), col("lat_deg"), col("ahrs_yaw_deg"), col("motor_current_a"));

    // Against the physics of the writer: truncation to whole mGauss through
    // (s·Mat)⁻¹ (≈ 1/1.05) leaves at most ~1.5 mGauss per axis.
    let mut worst_truth: f64 = 0.0;
    for (k, r) in rows.iter().enumerate() {
        let tr = truth_raw(k);
        for a in 0..3 {
            worst_truth = worst_truth.max((r[[mx, my, mz][a]] - tr[a]).abs());
        }
    }
    eprintln!("import vs the raw field written: worst {worst_truth:.3} mGauss");
    assert!(worst_truth < 2.0, "{worst_truth}");

    if !pymavlink_available() {
        eprintln!("SKIPPED: pymavlink is not installed and `python3 -m pip install pymavlink` failed: the DataFlash import was not checked against pymavlink's reader");
        return;
    }
    let dump = Command::new("python3").args(["-c", DUMP, bin.to_str().unwrap()]).output().unwrap();
    assert!(dump.status.success(), "{}", String::from_utf8_lossy(&dump.stderr));
    let d: Dump = serde_json::from_slice(&dump.stdout).unwrap();
    let params: std::collections::HashMap<String, f64> = d.parm.iter().map(|p| (p["Name"].as_str().unwrap().to_string(), f(p, "Value"))).collect();
    let g = |n: &str| params[n];
    let s = g("COMPASS_SCALE");
    let m = [
        [g("COMPASS_DIA_X"), g("COMPASS_ODI_X"), g("COMPASS_ODI_Y")],
        [g("COMPASS_ODI_X"), g("COMPASS_DIA_Y"), g("COMPASS_ODI_Z")],
        [g("COMPASS_ODI_Y"), g("COMPASS_ODI_Z"), g("COMPASS_DIA_Z")],
    ]
    .map(|r| r.map(|v| v * s));
    // (s·Mat)⁻¹ by the adjugate.
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let inv = |i: usize, j: usize| {
        let (r0, r1, c0, c1) = ((j + 1) % 3, (j + 2) % 3, (i + 1) % 3, (i + 2) % 3);
        (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det
    };
    let mag0: Vec<_> = d.mag.iter().filter(|x| f(x, "I") == 0.0).collect();
    assert_eq!(mag0.len(), rows.len());
    let mut worst: f64 = 0.0;
    for (r, mm) in rows.iter().zip(&mag0) {
        assert!((r[t] - f(mm, "TimeUS") * 1e-6).abs() < 1e-9);
        let y = [f(mm, "MagX") - f(mm, "MOX"), f(mm, "MagY") - f(mm, "MOY"), f(mm, "MagZ") - f(mm, "MOZ")];
        let ofs = [f(mm, "OfsX"), f(mm, "OfsY"), f(mm, "OfsZ")];
        for a in 0..3 {
            let raw = inv(a, 0) * y[0] + inv(a, 1) * y[1] + inv(a, 2) * y[2] - ofs[a];
            worst = worst.max((r[[mx, my, mz][a]] - raw).abs());
        }
    }
    eprintln!("import vs pymavlink + correct_field's inverse: worst {worst:.2e} mGauss");
    assert!(worst < 1e-3, "{worst}");
    // Attitude at the MAG times (ATT logged at the same TimeUS).
    for (r, a) in rows.iter().zip(&d.att) {
        assert!((r[roll] - f(a, "Roll")).abs() < 1e-9 && (r[pitch] - f(a, "Pitch")).abs() < 1e-9);
        assert!((r[yaw] - f(a, "Yaw")).abs() < 1e-9);
    }
    // GPS: course only with a 3D fix at speed; position with the fix.
    for (k, r) in rows.iter().enumerate() {
        let gp = &d.gps[k / 2];
        let fix = f(gp, "Status") >= 3.0;
        assert_eq!(r[lat].is_finite(), fix, "row {k}");
        if fix {
            assert!((r[lat] - f(gp, "Lat")).abs() < 1e-9);
        }
        assert_eq!(r[course].is_finite(), fix && f(gp, "Spd") >= 0.5, "row {k}");
        if r[course].is_finite() {
            assert!((r[course] - f(gp, "GCrs")).abs() < 1e-4);
        }
        assert!((r[cur] - f(&d.bat[k], "Curr")).abs() < 1e-6);
    }
}

#[test]
fn non_dataflash_input_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let bin = dir.path().join("x.bin");
    std::fs::write(&bin, "t,mx,my,mz\n0,1,2,3\n").unwrap();
    let out = magcal(&["import", "--dataflash", bin.to_str().unwrap(), "--out", dir.path().join("x.csv").to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("not an ArduPilot DataFlash .bin log"), "{err}");
    assert!(!dir.path().join("x.csv").exists());
}

// ---- `magcal import --nmea` ----------------------------------------------

fn nmea_data(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/nmea").join(name)
}

/// A CSV's header and rows.
type Csv = (Vec<String>, Vec<Vec<f64>>);

/// Imports `log` into a temporary folder: (the command's output, the CSV
/// when written, the folder).
fn import_nmea(log: &Path, extra: &[&str]) -> (Output, Option<Csv>, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    let mut args = vec!["import", "--nmea", log.to_str().unwrap(), "--out", rec.to_str().unwrap()];
    args.extend_from_slice(extra);
    let out = magcal(&args);
    let csv = rec.exists().then(|| read_csv(&rec));
    (out, csv, dir)
}

fn column(csv: &Csv, name: &str) -> Vec<f64> {
    let i = csv.0.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} in {:?}", csv.0));
    csv.1.iter().map(|r| r[i]).collect()
}

/// A real log (tests/data/nmea/gofree-merrimac-head.nmea: a moored yacht's
/// network, SignalK's sample, Apache-2.0): the counts measured on its 774
/// lines, and its values as the sentences state them.
#[test]
fn nmea_import_of_a_real_log() {
    let (out, csv, _dir) = import_nmea(&nmea_data("gofree-merrimac-head.nmea"), &["--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // 18 epochs 19:57:19 … 19:57:36 of RMC, GGA, GLL, VTG, ZDA; 168 HDG and
    // 18 VHW, of which the 3 and the 1 after the last timed sentence cannot
    // be timed.
    assert_eq!(r["detail"]["nmea0183"]["used"], serde_json::json!({"GGA": 18, "GLL": 18, "HDG": 165, "RMC": 18, "VHW": 17, "VTG": 18, "ZDA": 18}));
    assert_eq!((r["detail"]["nmea0183"]["sentences"].as_u64(), r["detail"]["nmea0183"]["unknown"].as_u64(), r["detail"]["nmea0183"]["unknown_types"]["!AIVDM"].as_u64()), (Some(774), Some(498), Some(192)));
    assert_eq!((r["detail"]["nmea0183"]["bad_checksum"].as_u64(), r["detail"]["nmea0183"]["partial"].as_u64(), r["detail"]["nmea0183"]["untimed_after_last_time"].as_u64()), (Some(0), Some(0), Some(4)));
    // 165 HDG + 17 VHW + 18 × (RMC, GGA, GLL, VTG) rows; ZDA gives only times.
    assert_eq!(r["rows"], 254);
    assert_eq!((r["detail"]["nmea0183"]["start_utc"].as_str(), r["duration_s"].as_f64()), (Some("2014-04-16T19:57:19Z"), Some(17.0)));
    // Moored (0–0.1 kn): no course at 0.5 m/s, no HDT: no reference.
    assert_eq!(r["detail"]["nmea0183"]["reference"], "none");
    assert_eq!(r["detail"]["nmea0183"]["compass_source"], "SDHDG");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("warning: skipped 502 (by kind: 498 unknown type; 4 untimed)"), "{stderr}");
    assert!(stderr.contains("18 ZDA sentences gave a two-digit year"), "{stderr}");
    let csv = csv.unwrap();
    assert_eq!(csv.0, ["t", "lat_deg", "lon_deg", "speed_mps", "compass_heading_deg", "variation_deg", "course_deg", "gps_speed_mps"]);
    // VHW: moored, 0.0 kn through the water.
    let water: Vec<f64> = column(&csv, "speed_mps").into_iter().filter(|v| v.is_finite()).collect();
    assert!(water.len() == 17 && water.iter().all(|&v| v == 0.0), "{water:?}");
    let heading: Vec<f64> = column(&csv, "compass_heading_deg").into_iter().filter(|h| h.is_finite()).collect();
    assert_eq!(heading.len(), 165);
    assert!(heading.iter().all(|&h| h == 181.7 || h == 181.8), "{heading:?}");
    // Variation: HDG's 0.6 E and RMC's 0.7 E, east positive.
    let variation: Vec<f64> = column(&csv, "variation_deg").into_iter().filter(|v| v.is_finite()).collect();
    assert_eq!((variation.iter().filter(|&&v| v == 0.6).count(), variation.iter().filter(|&&v| v == 0.7).count()), (165, 18));
    // The first fix, 5310.8115 N 00525.7025 E: 53 + 10.8115/60, 5 + 25.7025/60.
    let (lat, lon) = (column(&csv, "lat_deg"), column(&csv, "lon_deg"));
    assert!((lat[0] - 53.180_191_666_666_67).abs() < 1e-12 && (lon[0] - 5.428_375).abs() < 1e-12);
    let t = column(&csv, "t");
    assert!(t.windows(2).all(|w| w[0] <= w[1]) && t[0] == 0.0 && *t.last().unwrap() == 17.0);
}

/// The real n2kd log has two compasses and no sentence with a time: refused,
/// nothing written.
#[test]
fn nmea_real_log_without_time_is_refused() {
    let (out, csv, _dir) = import_nmea(&nmea_data("n2kd-183-merrimac-head.nmea"), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains("no sentence gives a time"), "{err}");
    assert!(csv.is_none());
}

fn cirrus_csv(name: &str) -> Vec<(f64, f64)> {
    // 2021-08-25Thh:mm:ss → seconds of the day (the log stays within one day).
    let text = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/cirrus-yacht").join(name)).unwrap();
    let mut rows: Vec<(f64, f64)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let (stamp, value) = l.split_once(',').unwrap();
            let hms: Vec<f64> = stamp[11..].split(':').map(|x| x.parse().unwrap()).collect();
            (hms[0] * 3600.0 + hms[1] * 60.0 + hms[2], value.parse().unwrap())
        })
        .collect();
    // As cirrus_to_nmea.py wrote them: in time order, stable within a second.
    rows.sort_by(|a, b| a.0.total_cmp(&b.0));
    rows
}

/// The real Cirrus yacht readings (tests/data/cirrus-yacht, MIT) re-encoded
/// as $HCHDM/$GPRMC (tests/data/nmea/cirrus_to_nmea.py; not a captured
/// log): the import gives back every value and times within the readings'
/// one-second stamps and the GPS interval.
#[test]
fn nmea_import_gives_back_the_cirrus_readings() {
    let (out, csv, _dir) = import_nmea(&nmea_data("cirrus-hdm-rmc.nmea"), &["--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (compass, cog) = (cirrus_csv("Calibration_Cirrus_v3_compass.csv"), cirrus_csv("Calibration_Cirrus_v3_cog.csv"));
    let start = cog[0].0;
    assert_eq!(r["detail"]["nmea0183"]["start_utc"], "2021-08-25T16:47:01Z");
    // 4 compass readings before the first course (16:47:00), 72 after the
    // last course's second and 5 within it (written after its RMC): the
    // course was stored only above 0.3 kn; no gap over 10 s.
    let before = compass.iter().filter(|c| c.0 < start).count();
    let after = compass.iter().filter(|c| c.0 >= cog.last().unwrap().0).count();
    assert_eq!((before, after), (4, 72 + 5));
    assert_eq!((r["detail"]["nmea0183"]["untimed_before_first_time"].as_u64(), r["detail"]["nmea0183"]["untimed_after_last_time"].as_u64(), r["detail"]["nmea0183"]["untimed_in_gaps"].as_u64()), (Some(4), Some(77), Some(0)));
    // No speed stored: the course cannot be the reference.
    assert_eq!(r["detail"]["nmea0183"]["reference"], "none");
    assert!(String::from_utf8_lossy(&out.stderr).contains("HCHDM's magnetic heading, taken as the compass's own reading"));
    let csv = csv.unwrap();
    assert_eq!(csv.0, ["t", "compass_heading_deg", "course_deg"]);
    let (t, heading, course) = (column(&csv, "t"), column(&csv, "compass_heading_deg"), column(&csv, "course_deg"));
    // Every course back at its own second.
    let courses: Vec<(f64, f64)> = t.iter().zip(&course).filter(|(_, c)| c.is_finite()).map(|(&t, &c)| (t + start, c)).collect();
    assert_eq!(courses, cog);
    // Every timed compass reading back, in order, at a time within its
    // stamp's second widened by the GPS interval (courses are 0–4 s apart).
    let headings: Vec<(f64, f64)> = t.iter().zip(&heading).filter(|(_, h)| h.is_finite()).map(|(&t, &h)| (t + start, h)).collect();
    let timed = &compass[before..compass.len() - after];
    assert_eq!(headings.len(), timed.len());
    let mut worst: f64 = 0.0;
    for ((t_import, h_import), (stamp, h)) in headings.iter().zip(timed) {
        assert_eq!(h_import, h);
        worst = worst.max((t_import - (stamp + 0.5)).abs());
    }
    // Measured: 1.33 s (a reading stamped S lies in [S, S + 1); the spread
    // puts it between the courses around it).
    eprintln!("Cirrus: worst |t − (stamp + 0.5 s)| = {worst:.3} s");
    assert!(worst <= 1.5, "{worst}");
}

/// Hostile files: clear refusals (nothing written) or counts, never a panic.
#[test]
fn nmea_hostile_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let refused = |name: &str, bytes: &[u8], says: &str| {
        let log = dir.path().join(name);
        std::fs::write(&log, bytes).unwrap();
        let (out, csv, _d) = import_nmea(&log, &[]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{name}: {err}");
        assert!(csv.is_none(), "{name}: nothing written");
        assert!(!err.contains("panicked"), "{name}: {err}");
    };
    refused("empty.nmea", b"", "the file is empty (0 bytes)");
    let binary: Vec<u8> = (0..4096u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    refused("binary.nmea", &binary, "a binary file, not an NMEA 0183 text log");
    refused("ais.nmea", b"!AIVDM,1,1,,A,14eG;o@034o8sd<L9i:a;WF>062D,0*7D\r\n!AIVDM,1,1,,B,14eG;o@034o8sd<L9i:a;WF>062D,0*7E\r\n", "2 `!` sentences (AIS");
    refused("nul.nmea", &[0u8; 5000], "a binary file");
    // A 100 MB line without a newline after a real log: held to 1024 bytes,
    // counted partial; the log before it imported.
    let mut big = std::fs::read(nmea_data("gofree-merrimac-head.nmea")).unwrap();
    big.extend(std::iter::repeat_n(b'A', 100 << 20));
    let log = dir.path().join("big.nmea");
    std::fs::write(&log, &big).unwrap();
    drop(big);
    let (out, _, _d) = import_nmea(&log, &["--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!((r["detail"]["nmea0183"]["partial"].as_u64(), r["detail"]["nmea0183"]["partial_reasons"]["too_long"].as_u64(), r["rows"].as_u64()), (Some(1), Some(1), Some(254)));
    // The hand-made log: CRLF and LF, a NUL byte, a lower-case checksum, RMC
    // with missing fields (make_mixed.py's lines 15 and 27).
    let (out, csv, _d) = import_nmea(&nmea_data("mixed.nmea"), &["--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["detail"]["nmea0183"]["partial_reasons"], serde_json::json!({"bad_checksum_field": 1, "bad_date": 1, "bad_number": 1, "not_ascii": 1, "out_of_range": 1, "too_few_fields": 2}));
    assert_eq!(r["rows"], 16);
    // Line 27's RMC without speed and course gives its position only.
    let csv = csv.unwrap();
    assert!(column(&csv, "lat_deg").iter().any(|&l| (l - (48.0 + 7.041 / 60.0)).abs() < 1e-12));
}

/// `--nmea` and `--dataflash`: one of them, not both; the output never an input.
#[test]
fn nmea_arguments() {
    let dir = tempfile::tempdir().unwrap();
    let log = nmea_data("mixed.nmea");
    let out_path = dir.path().join("x.csv");
    let both = magcal(&["import", "--nmea", log.to_str().unwrap(), "--dataflash", log.to_str().unwrap(), "--out", out_path.to_str().unwrap()]);
    assert!(!both.status.success() && String::from_utf8_lossy(&both.stderr).contains("cannot be used with"));
    let none = magcal(&["import", "--out", out_path.to_str().unwrap()]);
    assert!(!none.status.success() && String::from_utf8_lossy(&none.stderr).contains("<LOG|--dataflash <DATAFLASH>|--nmea <NMEA>>"));
    let instance = magcal(&["import", "--nmea", log.to_str().unwrap(), "--mag-instance", "1", "--out", out_path.to_str().unwrap()]);
    assert!(!instance.status.success() && String::from_utf8_lossy(&instance.stderr).contains("--instance"));
    assert!(!out_path.exists());
    let copy = dir.path().join("log.nmea");
    std::fs::copy(&log, &copy).unwrap();
    let same = magcal(&["import", "--nmea", copy.to_str().unwrap(), "--out", copy.to_str().unwrap()]);
    assert!(!same.status.success() && String::from_utf8_lossy(&same.stderr).contains("would be overwritten"));
    assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(&log).unwrap());
}
