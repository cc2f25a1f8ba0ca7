//! Hostile cases: references. A reference is independent of the compass it
//! judges or it is not a reference (mechanism 5 of `hostile`), and the
//! importer's, `igrf`'s and `export`'s unclear errors and labels.

use std::path::Path;

use crate::{magcal, p};

/// A sentence with its `*hh` checksum (the XOR of the bytes between `$`
/// and `*`, NMEA 0183).
fn nmea(body: &str) -> String {
    let x = body.bytes().fold(0u8, |c, b| c ^ b);
    format!("${body}*{x:02X}\n")
}

/// `ddmm.mmm,N` / `dddmm.mmm,E` of signed degrees.
fn lat_lon(lat: f64, lon: f64) -> String {
    let f = |v: f64, w: usize| {
        // In thousandths of a minute, so that rounding never gives 60.000.
        let m = (v.abs() * 60_000.0).round() as u64;
        format!("{:0w$}{:02}.{:03}", m / 60_000, m / 1000 % 60, m % 1000, w = w)
    };
    format!("{},{},{},{}", f(lat, 2), if lat >= 0.0 { "N" } else { "S" }, f(lon, 3), if lon >= 0.0 { "E" } else { "W" })
}

/// The compass's deviation written into the test log, degrees, as a
/// function of its own reading `h` (degrees): 8 sin h + 3 cos h. The
/// magnetic heading is the reading plus it; the true heading adds the
/// variation.
fn deviation_deg(h: f64) -> f64 {
    8.0 * h.to_radians().sin() + 3.0 * h.to_radians().cos()
}

/// The variation of the test log, degrees east.
const VARIATION_DEG: f64 = 2.0;

/// A boat's NMEA log written by hand: 14 legs of 30 s on compass readings
/// 137° apart (15°, 152°, 289°, …: each half of the log spread round the
/// compass), turning at 10°/s between them, 5 kn, 1 Hz. Each second: the
/// GPS's `RMC` (course = the true heading: no current, no delay), then the
/// compass's `HDG` (its reading, variation 2° E) and, when
/// `compass_hdt_talker` is given, an `HDT` of that talker: the reading plus
/// the variation, the compass's own "true" heading (not the deviation
/// removed: the compass does not know it). The RMC on 1 Jan 2026.
fn boat_log(compass_hdt_talker: Option<&str>) -> String {
    let legs: Vec<f64> = (0..14).map(|k| (15.0 + 137.0 * k as f64).rem_euclid(360.0)).collect();
    // The compass reading through legs and turns, a sample per second.
    let mut reading = Vec::new();
    for (k, &leg) in legs.iter().enumerate() {
        reading.extend(std::iter::repeat_n(leg, 30));
        if let Some(&next) = legs.get(k + 1) {
            let change = (next - leg + 180.0).rem_euclid(360.0) - 180.0;
            let steps = (change.abs() / 10.0).ceil() as usize;
            reading.extend((1..steps).map(|s| (leg + change * s as f64 / steps as f64).rem_euclid(360.0)));
        }
    }
    let (mut lat, mut lon) = (48.0f64, -5.0f64);
    let speed_kn = 5.0;
    let mut log = String::new();
    for (s, &h) in reading.iter().enumerate() {
        let truth = (h + deviation_deg(h) + VARIATION_DEG).rem_euclid(360.0);
        let step_m = speed_kn * 1852.0 / 3600.0;
        lat += step_m * truth.to_radians().cos() / 111_120.0;
        lon += step_m * truth.to_radians().sin() / (111_120.0 * lat.to_radians().cos());
        let (hh, mm, ss) = (10 + s / 3600, s / 60 % 60, s % 60);
        log += &nmea(&format!("GPRMC,{hh:02}{mm:02}{ss:02}.00,A,{},{speed_kn:.1},{truth:.1},010126,{VARIATION_DEG:.1},E,A", lat_lon(lat, lon)));
        log += &nmea(&format!("HCHDG,{h:.1},,,{VARIATION_DEG:.1},E"));
        if let Some(talker) = compass_hdt_talker {
            log += &nmea(&format!("{talker}HDT,{:.1},T", (h + VARIATION_DEG).rem_euclid(360.0)));
        }
    }
    log
}

/// A CSV's header and rows (numbers; NaN for an empty cell).
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(str::to_string).collect();
    let rows = lines.map(|l| l.split(',').map(|v| v.parse().unwrap_or(f64::NAN)).collect()).collect();
    (header, rows)
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `$HCHDG` and `$HCHDT` from the same compass with the GPS
/// course at 5 kn. The compass's HDT is its own heading plus the variation:
/// taken as the reference, the swing fitted nothing and `apply` said
/// 0.0003° after, 6° RMS off the course. The reference must be the course;
/// the corrected heading then matches the deviation written into the log.
#[test]
fn the_compass_own_hdt_is_not_the_reference() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("boat.nmea");
    std::fs::write(&log, boat_log(Some("HC"))).unwrap();
    let rec = dir.path().join("boat.csv");
    let o = magcal(&["import", "--nmea", p(&log), "--out", p(&rec), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["detail"]["nmea0183"]["reference"], "course", "{report}");
    // Every heading column says where it came from.
    assert_eq!(report["column_sources"]["compass_heading_deg"]["from"], "HCHDG", "{report}");
    assert!(report["column_sources"]["ref_heading_deg"]["from"].as_str().unwrap().contains("GPRMC"), "{report}");
    // The compass's HDT left out, counted and said.
    let hdt = report["detail"]["nmea0183"]["compass_true_headings"].as_u64().unwrap();
    assert!(hdt > 500, "{report}");
    assert!(stderr(&o).contains("HCHDT"), "{}", stderr(&o));
    let (header, _) = read_csv(&rec);
    assert!(!header.iter().any(|h| h.contains("true")), "{header:?}");

    let cal = dir.path().join("compass.json");
    let o = magcal(&["swing", "--input", p(&rec), "--delay-s", "0", "--no-current", "--out", p(&cal), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let coef = |k: &str| doc["swing"][k].as_f64().unwrap().to_degrees();
    // The deviation written in the log: B = 8°, C = 3°, A = 0 (the log's
    // variation is the declination). Measured: within 0.01° (the 0.1° of
    // the sentences' resolution).
    assert!((coef("b") - 8.0).abs() < 0.05 && (coef("c") - 3.0).abs() < 0.05 && coef("a").abs() < 0.05, "{doc}");

    let out = dir.path().join("applied.csv");
    let o = magcal(&["apply", "--input", p(&rec), "--cal", p(&cal), "--out", p(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The corrected heading against the truth written in the log (the
    // reading plus its deviation plus the variation). Measured: 0.02° max.
    let (header, rows) = read_csv(&out);
    let (ic, ih) = (header.iter().position(|h| h == "compass_heading_deg").unwrap(), header.iter().position(|h| h == "heading_deg").unwrap());
    let mut n = 0;
    for r in rows.iter().filter(|r| r[ic].is_finite()) {
        let truth = r[ic] + deviation_deg(r[ic]) + VARIATION_DEG;
        let diff = (r[ih] - truth + 180.0).rem_euclid(360.0) - 180.0;
        assert!(diff.abs() < 0.1, "{r:?}: {diff}");
        n += 1;
    }
    assert!(n > 500, "{n}");
}

/// A GNSS compass's HDT (talker GP) is independent of the magnetic compass:
/// it is the reference; a talker the importer cannot place (II, an
/// instrument bus that may relay the compass) is not, unless named.
#[test]
fn a_gnss_hdt_is_the_reference_and_a_named_talker_too() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("boat.csv");
    // GP HDT: the compass reading plus the variation here too, but from a
    // GNSS talker the importer takes it (it cannot know better).
    let log = dir.path().join("gnss.nmea");
    std::fs::write(&log, boat_log(Some("GP"))).unwrap();
    let o = magcal(&["import", "--nmea", p(&log), "--out", p(&rec), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((report["detail"]["nmea0183"]["reference"].as_str(), report["column_sources"]["ref_heading_deg"]["from"].as_str()), (Some("hdt"), Some("GPHDT")), "{report}");
    // II: not the reference by default (the course is), the reference when named.
    let log = dir.path().join("ii.nmea");
    std::fs::write(&log, boat_log(Some("II"))).unwrap();
    let o = magcal(&["import", "--nmea", p(&log), "--out", p(&rec), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["detail"]["nmea0183"]["reference"], "course", "{report}");
    assert!(stderr(&o).contains("--reference-talker II"), "{}", stderr(&o));
    let o = magcal(&["import", "--nmea", p(&log), "--out", p(&rec), "--json", "--reference-talker", "II"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(report["column_sources"]["ref_heading_deg"]["from"], "IIHDT", "{report}");
    // The compass's own talker named: refused, not taken.
    let log = dir.path().join("hc.nmea");
    std::fs::write(&log, boat_log(Some("HC"))).unwrap();
    let o = magcal(&["import", "--nmea", p(&log), "--out", p(&rec), "--reference-talker", "HC"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("HC is the compass's own talker"), "{}", stderr(&o));
}

/// A compass log as CSV: `t, compass_heading_deg, ref_heading_deg`, one row
/// a second through the same legs as [`boat_log`], the compass column
/// `compass(h)` and the reference `reference(h)` of the compass reading
/// `h` (degrees), each written to 0.1 as instruments send them.
fn compass_csv(path: &Path, compass: impl Fn(f64) -> f64, reference: impl Fn(f64) -> f64) {
    let mut text = String::from("t,compass_heading_deg,ref_heading_deg\n");
    let mut t = 0;
    for k in 0..14 {
        let leg = (15.0 + 137.0 * k as f64).rem_euclid(360.0);
        for _ in 0..40 {
            text += &format!("{t},{:.1},{:.1}\n", compass(leg), reference(leg).rem_euclid(360.0));
            t += 1;
        }
    }
    std::fs::write(path, text).unwrap();
}

/// A reference that is the compass's heading plus a constant (its
/// own HDT, whatever its talker) judges nothing. `swing` fitted A = the
/// constant and called the compass perfect; `apply` said 0.0° after. Both
/// refuse, saying the reference is the compass's own heading.
#[test]
fn swing_and_apply_refuse_to_judge_a_compass_by_itself() {
    let dir = tempfile::tempdir().unwrap();
    let own = dir.path().join("own.csv");
    compass_csv(&own, |h| h, |h| h + 2.0);
    let o = magcal(&["swing", "--input", p(&own), "--delay-s", "0", "--no-current"]);
    assert!(!o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("ref_heading_deg is the compass's own heading"), "{}", stderr(&o));
    assert!(stderr(&o).contains("+2.00°"), "{}", stderr(&o));
    // The same compass against an independent reference (the deviation of
    // the test log) is swung, and that document applied to the first log
    // is refused too.
    let fair = dir.path().join("fair.csv");
    compass_csv(&fair, |h| h, |h| h + deviation_deg(h));
    let cal = dir.path().join("cal.json");
    let o = magcal(&["swing", "--input", p(&fair), "--delay-s", "0", "--no-current", "--out", p(&cal)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = magcal(&["apply", "--input", p(&own), "--cal", p(&cal), "--out", p(&dir.path().join("a.csv"))]);
    assert!(!o.status.success(), "{}", stdout_of(&o));
    assert!(stderr(&o).contains("ref_heading_deg is the compass's own heading"), "{}", stderr(&o));
}

fn stdout_of(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A compass recorded in radians was refused as "the heading
/// hardly changes"; it is named as radians.
#[test]
fn a_compass_in_radians_is_named_as_radians() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rad.csv");
    compass_csv(&rec, |h| h.to_radians(), |h| h + deviation_deg(h));
    let o = magcal(&["swing", "--input", p(&rec), "--estimate-delay", "--no-current"]);
    assert!(!o.status.success(), "{}", stdout_of(&o));
    let e = stderr(&o);
    assert!(e.contains("compass_heading_deg looks like radians") && !e.contains("hardly changes"), "{e}");
}

/// One RMC dated a year ahead made every later sentence "earlier
/// than the one before": the rest of the log was dropped. It is refused
/// alone, counted, and the log timed without it.
#[test]
fn one_rmc_dated_a_year_ahead_is_refused_alone() {
    let dir = tempfile::tempdir().unwrap();
    let mut log = String::new();
    for s in 0..60 {
        let date = if s == 30 { "010127" } else { "010126" };
        log += &nmea(&format!("GPRMC,1000{s:02}.00,A,4800.000,N,00500.000,W,5.0,{:.1},{date},,,A", s as f64 * 6.0));
        log += &nmea(&format!("HCHDG,{:.1},,,,", s as f64 * 6.0));
    }
    let path = dir.path().join("jump.nmea");
    std::fs::write(&path, log).unwrap();
    let rec = dir.path().join("jump.csv");
    let o = magcal(&["import", "--nmea", p(&path), "--out", p(&rec), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let r: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // 59 RMC rows and 59 HDG rows (the last HDG follows the last RMC: not
    // timed); the RMC of second 30 refused, the HDG after it spread between
    // seconds 29 and 31.
    assert_eq!((r["detail"]["nmea0183"]["date_jumps"].as_u64(), r["rows"].as_u64(), r["detail"]["nmea0183"]["time_backwards"].as_u64()), (Some(1), Some(59 + 59), Some(0)), "{r}");
    assert_eq!((r["duration_s"].as_f64(), r["detail"]["nmea0183"]["start_utc"].as_str()), (Some(59.0), Some("2026-01-01T10:00:00Z")), "{r}");
    assert!(stderr(&o).contains("1 RMC/ZDA dated more than"), "{}", stderr(&o));
}

/// `igrf --model wmm2025 --date 2021` answered with the WMM2020
/// field the crate holds for 2021 and labelled it WMM2025. A date outside
/// the model's validity is refused with the range; inside it, answered.
#[test]
fn a_model_is_not_used_outside_its_years() {
    let o = magcal(&["igrf", "--lat", "45", "--lon", "10", "--date", "2021", "--model", "wmm2025"]);
    assert!(!o.status.success(), "{}", stdout_of(&o));
    assert!(stderr(&o).contains("date 2021 is outside WMM2025's validity (2025.0 to 2030.0"), "{}", stderr(&o));
    let o = magcal(&["igrf", "--lat", "45", "--lon", "10", "--date", "2030-06-01", "--model", "igrf14"]);
    assert!(!o.status.success() && stderr(&o).contains("IGRF-14's validity (1900.0 to 2030.0)"), "{}", stderr(&o));
    let o = magcal(&["igrf", "--lat", "45", "--lon", "10", "--date", "2021", "--model", "igrf14", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = magcal(&["igrf", "--lat", "45", "--lon", "10", "--date", "2029-12-01", "--model", "wmm2025", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// PX4's export refused a gain naming ArduPilot's
/// `COMPASS_SCALE`. Each stack's message names its own parameters.
#[test]
fn each_export_names_its_own_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cal.json");
    // A gain of 2 per mGauss: raw units given wrongly.
    std::fs::write(&cal, r#"{"model": "full", "bias": [0, 0, 0], "matrix": [[200, 0, 0], [0, 200, 0], [0, 0, 200]], "field_nt": 48730}"#).unwrap();
    let out = dir.path().join("x.params");
    let o = magcal(&["export", "--cal", p(&cal), "--format", "px4", "--raw-unit", "mgauss", "--out", p(&out)]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("CAL_MAG0_XSCALE") && !e.contains("COMPASS_"), "{e}");
    let o = magcal(&["export", "--cal", p(&cal), "--format", "ardupilot", "--raw-unit", "mgauss", "--out", p(&out)]);
    let e = stderr(&o);
    assert!(!o.status.success() && e.contains("COMPASS_SCALE") && !e.contains("CAL_MAG"), "{e}");
}

#[path = "../../../../fuzz/fuzz_targets/commands_drive.rs"]
mod commands_drive;

/// No command ends with a panic on any input the command-level
/// fuzzer has (its seeds, small real inputs, and any crash committed
/// beside them or left in `fuzz/artifacts/commands/`): each replayed
/// through the same entry points as the fuzz target.
#[test]
fn every_fuzz_input_replays_without_a_panic() {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz");
    let mut replayed = 0;
    for dir in [fuzz.join("seeds/commands"), fuzz.join("artifacts/commands")] {
        let Ok(entries) = std::fs::read_dir(&dir) else { continue };
        for entry in entries {
            let path = entry.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            let outcome = std::panic::catch_unwind(|| commands_drive::drive(&bytes));
            assert!(outcome.is_ok(), "{} panics", path.display());
            replayed += 1;
        }
    }
    assert!(replayed >= 3, "the seeds of fuzz/seeds/commands are missing ({replayed} inputs)");
}
