//! The NMEA 2000 import against the independent reading
//! (`tests/data/nmea2000-canboat/reference.py` → `reference.json`), and on
//! damaged logs.

use std::collections::BTreeMap;
use std::path::PathBuf;

use super::pgn::{self, Decoded, Reference};
use super::text::{self, TextFormat};
use super::*;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../tests/data/nmea2000-canboat")
}

fn fixture(name: &str) -> Vec<u8> {
    std::fs::read(dir().join(name)).unwrap()
}

fn reference() -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir().join("reference.json")).unwrap()).unwrap()
}

const FILES: [&str; 3] = ["triton-head.all", "triton-head-plain.raw", "furuno-wide-turn-head.raw"];

fn opts() -> ImportOptions {
    ImportOptions::default()
}

/// A column of an import.
fn column<'a>(im: &'a Imported, name: &str) -> &'a [f64] {
    im.column(name).unwrap_or_else(|| panic!("no column {name}: {:?}", im.report.columns))
}

/// Whole messages by PGN and source, the format, the lines and the
/// refusals: equal to the reference's, on every fixture.
#[test]
fn counts_equal_the_reference() {
    let r = reference();
    for name in FILES {
        let log = text::read(&fixture(name)).unwrap();
        let e = &r["files"][name];
        let mut counts: BTreeMap<String, u64> = BTreeMap::new();
        for m in &log.messages {
            *counts.entry(format!("{}/{}", m.pgn, m.src)).or_default() += 1;
        }
        let expected: BTreeMap<String, u64> = e["by_pgn_source"].as_object().unwrap().iter().map(|(k, v)| (k.clone(), v.as_u64().unwrap())).collect();
        assert_eq!(counts, expected, "{name}");
        assert_eq!(log.messages.len() as u64, e["messages"].as_u64().unwrap(), "{name}");
        let format = if log.format == TextFormat::Fast { "FAST" } else { "PLAIN" };
        assert_eq!(format, e["format"], "{name}");
        if log.format == TextFormat::Plain {
            assert_eq!(log.frames as u64, e["lines"].as_u64().unwrap(), "{name}");
        }
        assert!(log.skipped.is_empty() && e["skipped"].as_object().unwrap().is_empty(), "{name}: {:?}", log.skipped);
    }
}

/// `a` (NaN for not available) against the reference's number or null.
fn same(a: f64, e: &serde_json::Value, tol: f64) -> bool {
    match e.as_f64() {
        Some(e) => (a - e).abs() <= tol,
        None => a.is_nan(),
    }
}

fn reference_code(r: Reference) -> Vec<u64> {
    match r {
        Reference::True => vec![0],
        Reference::Magnetic => vec![1],
        Reference::Unknown => vec![2, 3],
    }
}

/// Every message of the six PGNs read, decoded: its time to 1 µs and every
/// value to 1e-9 (measured: equal to the last digit printed, the same
/// arithmetic on the same integers), not available where the reference has
/// none; the messages in the same order.
#[test]
fn values_equal_the_reference() {
    let r = reference();
    for name in FILES {
        let log = text::read(&fixture(name)).unwrap();
        let decoded = r["files"][name]["decoded"].as_object().unwrap();
        let mut next: BTreeMap<String, usize> = BTreeMap::new();
        let mut compared = 0;
        for m in &log.messages {
            let Some(v) = pgn::decode(m.pgn, &m.data) else { continue };
            let key = format!("{}/{}", m.pgn, m.src);
            let i = next.entry(key.clone()).or_default();
            let e = &decoded[&key][*i];
            *i += 1;
            assert!((log.base_s + m.t_s - e[0].as_f64().unwrap()).abs() < 1e-6, "{name} {key} #{i}: time");
            let ok = match v {
                Decoded::Heading { heading_deg, deviation_deg, variation_deg, reference } => {
                    same(heading_deg, &e[1], 1e-9) && same(deviation_deg, &e[2], 1e-9) && same(variation_deg, &e[3], 1e-9) && reference_code(reference).contains(&e[4].as_u64().unwrap())
                }
                Decoded::RateOfTurn { rate_rad_s } => same(rate_rad_s, &e[1], 1e-15),
                Decoded::Attitude { yaw_deg, pitch_deg, roll_deg } => same(yaw_deg, &e[1], 1e-9) && same(pitch_deg, &e[2], 1e-9) && same(roll_deg, &e[3], 1e-9),
                Decoded::Position { lat_deg, lon_deg } => same(lat_deg, &e[1], 1e-12) && same(lon_deg, &e[2], 1e-12),
                Decoded::CogSog { reference, cog_deg, sog_mps } => reference_code(reference).contains(&e[1].as_u64().unwrap()) && same(cog_deg, &e[2], 1e-9) && same(sog_mps, &e[3], 1e-12),
                Decoded::Field { xyz } => (0..3).all(|k| same(xyz[k], &e[k + 1], 0.0)),
            };
            assert!(ok, "{name} {key} #{i}: {v:?} against {e}");
            compared += 1;
        }
        for (key, n) in &next {
            assert_eq!(*n, decoded[key].as_array().unwrap().len(), "{name} {key}");
        }
        assert!(compared > 500, "{name}: {compared}");
    }
}

/// The triton log: one row per 65350 sample of the Precision-9 (source 27),
/// its counts as the reference reads them; the satellite compass (source
/// 52) the reference; magnetic minus true +2.5° ± 0.2° (the data's README).
#[test]
fn triton_rows_are_the_compass_field_with_the_satellite_compass_as_reference() {
    let r = reference();
    let im = import(&fixture("triton-head.all"), &opts()).unwrap();
    let rep = &im.report;
    let field = r["files"]["triton-head.all"]["decoded"]["65350/27"].as_array().unwrap();
    assert_eq!(rep.rows, field.len());
    assert_eq!(rep.field_unit.as_deref(), Some("counts (Simnet 65350, units unpublished)"));
    for (k, name) in col::MAG.into_iter().enumerate() {
        let expected: Vec<f64> = field.iter().map(|e| e[k + 1].as_f64().unwrap()).collect();
        assert_eq!(column(&im, name), expected.as_slice(), "{name}");
    }
    let t0 = field[0][0].as_f64().unwrap();
    for (t, e) in column(&im, col::T).iter().zip(field) {
        assert!((t - (e[0].as_f64().unwrap() - t0)).abs() < 1e-6);
    }
    assert_eq!(rep.clock, "s since 2026-07-02T06:01:33.010Z (UTC, the logger's timestamps)");
    assert_eq!(rep.column_sources["compass_heading_deg"].role, Role::Compass);
    assert!(rep.column_sources["compass_heading_deg"].from.contains("source 27"));
    assert_eq!(rep.column_sources["ref_heading_deg"].role, Role::Reference);
    assert!(rep.column_sources["ref_heading_deg"].from.contains("source 52"));
    assert!(rep.column_sources["roll_deg"].from.contains("source 27") && rep.column_sources["course_deg"].from.contains("source 52"));
    // Magnetic minus true at the rows (both carried to the field's times):
    // measured +2.687°, the reference's nearest-in-time pairs +2.677° (211
    // pairs, σ 0.24°): within 0.02° of each other and 2.5° ± 0.2°.
    let (h, t) = (column(&im, col::COMPASS_HEADING_DEG), column(&im, col::REF_HEADING_DEG));
    let d: Vec<f64> = h.iter().zip(t).map(|(h, t)| rules::wrap180(h - t)).filter(|d| d.is_finite()).collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let e = r["files"]["triton-head.all"]["magnetic_minus_true"]["mean_deg"].as_f64().unwrap();
    assert!((mean - e).abs() < 0.05 && (mean - 2.5).abs() < 0.2 && d.len() > 100, "{mean} {e} {}", d.len());
    // The satellite compass's variation (0.87° E) for the compass's, which
    // sends none; others of each PGN counted.
    assert!(column(&im, col::VARIATION_DEG).iter().all(|v| (v - 0.0151f64.to_degrees()).abs() < 1e-9));
    assert_eq!(rep.skipped.get("another_source_127257"), Some(&106));
    assert_eq!(rep.messages["65350 Simnet: Magnetic Field, source 27"], 106);
}

/// The PLAIN log (the same lines in CAN frames): the same rows as the FAST
/// log's first ones, every value, while a later FAST sample is not needed
/// (the PLAIN log ends 1 s earlier than the rows compared).
#[test]
fn plain_gives_the_rows_of_fast() {
    let fast = import(&fixture("triton-head.all"), &opts()).unwrap();
    let plain = import(&fixture("triton-head-plain.raw"), &opts()).unwrap();
    assert!(plain.report.rows > 50 && plain.report.rows < fast.report.rows);
    assert_eq!(plain.report.columns, fast.report.columns);
    let end = column(&plain, col::T).last().copied().unwrap() - 1.0;
    for c in &plain.columns {
        let f = column(&fast, c.name);
        for (i, (a, b)) in c.values.iter().zip(f).enumerate().filter(|(i, _)| column(&plain, col::T)[*i] < end) {
            assert!(a == b || (a.is_nan() && b.is_nan()), "{} row {i}: {a} {b}", c.name);
        }
    }
    assert!(plain.report.notes.iter().any(|n| n.contains("canboat PLAIN")));
}

/// Without 65350: one row per magnetic heading of the compass, exactly the
/// reference's values (a heading-only log for `magcal swing`).
#[test]
fn a_heading_only_log_has_a_row_per_compass_heading() {
    let r = reference();
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    let no_field: String = text.lines().filter(|l| !l.contains(",65350,")).map(|l| format!("{l}\n")).collect();
    let im = import(no_field.as_bytes(), &opts()).unwrap();
    let e = r["files"]["triton-head.all"]["decoded"]["127250/27"].as_array().unwrap();
    assert_eq!(im.report.rows, e.len());
    assert!(im.column("mx").is_none() && im.report.field_unit.is_none());
    let expected: Vec<f64> = e.iter().map(|e| e[1].as_f64().unwrap()).collect();
    assert_eq!(column(&im, col::COMPASS_HEADING_DEG), expected.as_slice());
    assert!(column(&im, col::REF_HEADING_DEG).iter().filter(|v| v.is_finite()).count() > 200);
}

/// Lines of the triton log in Actisense's N2K ASCII give the same values.
#[test]
fn actisense_lines_read_alike() {
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    let mut acti = String::new();
    for l in text.lines().filter(|l| !l.starts_with('#')).take(400) {
        let f: Vec<&str> = l.split(',').collect();
        let (hms, prio, pgn, src, dst) = (&f[0][11..23], f[1], f[2].parse::<u32>().unwrap(), f[3].parse::<u8>().unwrap(), f[4].parse::<u8>().unwrap());
        acti += &format!("A{}{}{} {src:02X}{dst:02X}{prio} {pgn:05X} {}\n", &hms[0..2], &hms[3..5], &hms[6..12], f[6..].concat().to_uppercase());
    }
    let a = text::read(acti.as_bytes()).unwrap();
    let c = text::read(text.as_bytes()).unwrap();
    assert_eq!(a.format, TextFormat::Actisense);
    assert_eq!(a.messages.len(), 400);
    for (a, c) in a.messages.iter().zip(&c.messages) {
        assert_eq!((a.pgn, a.src, a.dst, a.prio, &a.data), (c.pgn, c.src, c.dst, c.prio, &c.data));
        assert!((a.t_s - c.t_s).abs() < 1e-6);
    }
    let im = import(acti.as_bytes(), &opts()).unwrap();
    assert!(im.report.clock.contains("06:01:33.010") && im.report.clock.contains("Actisense"), "{}", im.report.clock);
}

/// Damaged lines are refused and counted by kind, the rest read: a cut
/// line, bad hex, a wrong length, a bad timestamp, binary noise.
#[test]
fn damaged_lines_are_counted_not_fatal() {
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let n = lines.len();
    let field_line = |lines: &[String], k: usize| lines.iter().enumerate().filter(|(_, l)| l.contains(",65350,")).nth(k).unwrap().0;
    let i = field_line(&lines, 3);
    lines[i] = lines[i][..50].to_string(); // cut after 3 of its 8 bytes
    let i = field_line(&lines, 4);
    lines[i] = lines[i].replacen(",ff", ",zz", 1); // bad hex
    let i = field_line(&lines, 5);
    lines[i] = lines[i].replacen(",8,", ",7,", 1); // length 7, 8 bytes
    let i = field_line(&lines, 6);
    lines[i] = lines[i].replacen('T', "X", 1); // bad timestamp
    let i = field_line(&lines, 7);
    lines[i] = lines[i].replacen(",27,", ",999,", 1); // source out of range
    lines.push("\u{1}\u{2}garbage".into());
    let damaged = lines.join("\n").into_bytes();
    let im = import(&damaged, &opts()).unwrap();
    let s = &im.report.skipped;
    assert_eq!((s.get("wrong_length"), s.get("bad_hex"), s.get("bad_timestamp"), s.get("bad_header_number"), s.get("too_few_fields")), (Some(&2), Some(&1), Some(&1), Some(&1), Some(&1)), "{s:?}");
    assert_eq!(im.report.rows, 106 - 5);
    assert!(n > 3000);
}

/// A PLAIN log with one frame of a fast packet lost: that packet is counted
/// incomplete and its later frames without a start; every other message is
/// read.
#[test]
fn a_lost_frame_drops_only_its_packet() {
    let text = String::from_utf8(fixture("triton-head-plain.raw")).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    // The second frame of the first 130845 (151 bytes: 23 frames).
    let second = lines.iter().position(|l| l.contains(",130845,52,") && l.split(',').nth(6) == Some("01")).unwrap();
    let cut: String = lines.iter().enumerate().filter(|(i, _)| *i != second).map(|(_, l)| format!("{l}\n")).collect();
    let whole = text::read(text.as_bytes()).unwrap();
    let log = text::read(cut.as_bytes()).unwrap();
    assert_eq!(log.skipped.get("fast_packet_incomplete"), Some(&1));
    let without = *log.skipped.get("fast_packet_frame_without_start").unwrap();
    assert!(without >= 1);
    assert_eq!(log.messages.len(), whole.messages.len() - 1);
    assert_eq!(log.frames, whole.frames - 1);
    let im = import(cut.as_bytes(), &opts()).unwrap();
    assert_eq!(im.report.skipped.get("fast_packet_incomplete"), Some(&1));
}

/// The furuno log has no magnetic heading and no field (the compass's were
/// filtered out of it): refused, naming what it holds.
#[test]
fn a_log_without_a_compass_is_refused() {
    let e = import(&fixture("furuno-wide-turn-head.raw"), &opts()).unwrap_err().to_string();
    assert!(e.contains("no magnetic heading (PGN 127250") && e.contains("127257 Attitude, source 52: 141") && e.contains("other PGNs: 367"), "{e}");
    let e = import(b"hello\nworld\n", &opts()).unwrap_err().to_string();
    assert!(e.contains("no line is NMEA 2000") && e.contains("too_few_fields: 2"), "{e}");
    let e = import(b"", &opts()).unwrap_err().to_string();
    assert!(e.contains("an empty file"), "{e}");
}

/// The compass's own true heading is never the reference; with no other
/// true heading, the course at speed is.
#[test]
fn the_compass_own_true_heading_is_not_a_reference() {
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    // Source 52's true headings relabelled as source 27's.
    let relabelled: String = text.lines().map(|l| format!("{}\n", if l.contains(",127250,52,") { l.replacen(",127250,52,", ",127250,27,", 1) } else { l.to_string() })).collect();
    let im = import(relabelled.as_bytes(), &opts()).unwrap();
    assert_eq!(im.report.skipped.get("compass_own_true_heading"), Some(&106));
    let source = &im.report.column_sources["ref_heading_deg"].from;
    assert!(source.contains("129026 COG") && source.contains("source 52"), "{source}");
    assert!(im.report.notes.iter().any(|n| n.contains("not a reference")));
    // The course at 3.8 m/s, within a few degrees of the heading here.
    let (c, r) = (column(&im, col::COURSE_DEG), column(&im, col::REF_HEADING_DEG));
    assert!(c.iter().zip(r).all(|(c, r)| c == r || (c.is_nan() && r.is_nan())));
}

/// `--instance N` picks the compass by source address; one that is not a
/// compass's is refused naming the compasses found.
#[test]
fn the_instance_is_a_source_address() {
    let bytes = fixture("triton-head.all");
    let im = import(&bytes, &ImportOptions { instance: Some(27), ..opts() }).unwrap();
    assert_eq!(im.report.rows, 106);
    let e = import(&bytes, &ImportOptions { instance: Some(52), ..opts() }).unwrap_err().to_string();
    assert!(e.contains("52") && e.contains("[27]"), "{e}");
}

/// Random and damaged bytes: never a panic.
#[test]
fn random_bytes_never_panic() {
    let base = fixture("triton-head-plain.raw");
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for _ in 0..200 {
        let mut bytes = base[..(next() as usize % 20_000)].to_vec();
        for _ in 0..(next() % 50) {
            if let Some(b) = bytes.get_mut(next() as usize % base.len().max(1)) {
                *b = next() as u8;
            }
        }
        let _ = import(&bytes, &opts());
        let _ = looks_like(&bytes);
        let noise: Vec<u8> = (0..(next() % 3000)).map(|_| next() as u8).collect();
        let _ = import(&noise, &opts());
    }
}

/// Detection from the first bytes: every fixture, and through the one
/// importer's [`Format::detect`].
#[test]
fn the_fixtures_are_detected() {
    for name in FILES {
        let bytes = fixture(name);
        assert_eq!(Format::detect(&bytes[..4096]), Some(Format::Nmea2000), "{name}");
    }
}

/// Two magnetic compasses: the one sending the field is the compass, the
/// other's headings are counted and named; `--instance` picks the other.
#[test]
fn of_two_compasses_the_field_sender_is_chosen() {
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    // Source 52's true headings relabelled as a magnetic compass at 60.
    let two: String = text
        .lines()
        .map(|l| if l.contains(",127250,52,") { format!("{},fd\n", l.replacen(",127250,52,", ",127250,60,", 1).rsplit_once(',').unwrap().0) } else { format!("{l}\n") })
        .collect();
    let im = import(two.as_bytes(), &opts()).unwrap();
    assert_eq!(im.report.skipped.get("another_compass_127250_magnetic"), Some(&106));
    assert!(im.report.notes.iter().any(|n| n.contains("compass: source 27 of") && n.contains("[27, 60]")), "{:?}", im.report.notes);
    // No true heading left: the course at speed is the reference.
    assert!(im.report.column_sources["ref_heading_deg"].from.contains("129026 COG"));
    let other = import(two.as_bytes(), &ImportOptions { instance: Some(60), ..opts() }).unwrap();
    assert_eq!(other.report.rows, 106);
    assert!(other.column("mx").is_none(), "source 60 sends no field: a heading-only log");
    assert!(other.report.column_sources["compass_heading_deg"].from.contains("source 60"));
}

/// Timestamps without a zone, and in seconds: the clock says which.
#[test]
fn the_clock_says_the_timestamps_form() {
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    let local = text.replace("Z,", ",");
    let im = import(local.as_bytes(), &opts()).unwrap();
    assert_eq!(im.report.clock, "s since 2026-07-02T06:01:33.010 (the logger's timestamps, zone not given)");
    assert!(im.report.notes.iter().any(|n| n.contains("no zone")));
    let seconds: String = text
        .lines()
        .map(|l| match l.split_once(',') {
            Some((stamp, rest)) if !l.starts_with('#') => format!("{:.3},{rest}\n", (stamp[17..23].parse::<f64>().unwrap() + 60.0 * stamp[14..16].parse::<f64>().unwrap())),
            _ => format!("{l}\n"),
        })
        .collect();
    let im = import(seconds.as_bytes(), &opts()).unwrap();
    assert_eq!(im.report.clock, "s since the logger's time 93.01 s (timestamps in seconds, no date)");
    assert_eq!(im.report.rows, 106);
}

/// A true heading that is the compass relayed (its magnetic heading plus a
/// variation, from a display's address) is not the reference.
#[test]
fn a_relayed_compass_is_not_a_reference() {
    let text = String::from_utf8(fixture("triton-head.all")).unwrap();
    let mut relayed = String::new();
    for l in text.lines().filter(|l| !l.contains(",127250,52,")) {
        relayed += &format!("{l}\n");
        // Source 27's magnetic heading + 0.0151 rad as a true heading from 3.
        if let Some(rest) = l.strip_suffix(",fd").filter(|l| l.contains(",127250,27,")) {
            let f: Vec<&str> = rest.split(',').collect();
            let raw = u16::from_str_radix(&format!("{}{}", f[8], f[7]), 16).unwrap() + 151;
            relayed += &format!("{},2,127250,3,255,8,ff,{:02x},{:02x},ff,7f,97,00,fc\n", f[0], raw & 0xff, raw >> 8);
        }
    }
    let im = import(relayed.as_bytes(), &opts()).unwrap();
    assert_eq!(im.report.skipped.get("true_heading_relaying_the_compass"), Some(&211));
    assert!(im.report.column_sources["ref_heading_deg"].from.contains("129026 COG"), "{:?}", im.report.column_sources);
    assert!(im.report.notes.iter().any(|n| n.contains("source 3 follow the compass")));
    // The satellite compass is not a relay: measured spread 0.22°.
    let sat = import(&fixture("triton-head.all"), &opts()).unwrap();
    assert!(!sat.report.skipped.contains_key("true_heading_relaying_the_compass"));
}
