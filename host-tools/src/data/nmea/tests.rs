//! The reader against pynmea2 and hand-written logs.

use super::sentence::{parse_line, Line, Outcome, Partial, Sentence};
use super::*;
use serde_json::Value;

use crate::data::table::col;

const MIXED: &[u8] = include_bytes!("../../../../tests/data/nmea/mixed.nmea");
const GOFREE: &[u8] = include_bytes!("../../../../tests/data/nmea/gofree-merrimac-head.nmea");
const N2KD: &[u8] = include_bytes!("../../../../tests/data/nmea/n2kd-183-merrimac-head.nmea");
const REFERENCE: &str = include_str!("../../../../tests/data/nmea/reference.json");

/// The non-blank lines, split as the reader and reference.py split them.
fn lines(log: &[u8]) -> Vec<&[u8]> {
    log.split(|&b| b == b'\n' || b == b'\r').filter(|l| !l.iter().all(u8::is_ascii_whitespace)).collect()
}

fn read(line: &str) -> Outcome {
    match parse_line(line.as_bytes()) {
        Line::Sentence { outcome, .. } => outcome,
        other => panic!("{line}: {other:?}"),
    }
}

fn sentence(line: &str) -> Sentence {
    match read(line) {
        Outcome::Read { sentence, .. } => sentence,
        other => panic!("{line}: {other:?}"),
    }
}

/// Ours against pynmea2's (`null` = empty field), to `tol`.
fn same(ours: Option<f64>, theirs: &Value, tol: f64) -> bool {
    match (ours, theirs.as_f64()) {
        (None, None) => theirs.is_null(),
        (Some(a), Some(b)) => (a - b).abs() <= tol,
        _ => false,
    }
}

/// Where pynmea2 reads a sentence that this reader refuses, and why:
/// pynmea2 does not check field counts, ranges or characters (it
/// returns the field's text when it cannot convert it).
const DISAGREE: [(&str, usize, Partial); 6] = [
    // Truncated `$GPRMC,000003.00,A,4807.0`: pynmea2 gives latitude 0.0
    // (no hemisphere letter), this reader counts it partial.
    ("mixed.nmea", 15, Partial::TooFewFields),
    // `$HCHDG,98.3,0.0,E`: three of HDG's five fields.
    ("mixed.nmea", 16, Partial::TooFewFields),
    // `$HCHDM,abc,M`: pynmea2 returns the text `abc` as the heading.
    ("mixed.nmea", 17, Partial::BadNumber),
    // A NUL byte in the heading: pynmea2 returns the text.
    ("mixed.nmea", 26, Partial::NotAscii),
    // Heading 370°: pynmea2 does not check ranges.
    ("mixed.nmea", 28, Partial::OutOfRange),
    // 32 March: pynmea2 returns the text of the date.
    ("mixed.nmea", 35, Partial::BadDate),
];

/// Every line of the three test logs read as pynmea2 reads it
/// (tests/data/nmea/reference.py wrote the expected values): types,
/// talkers, times, positions, speeds, courses, headings and the signs of
/// variation and deviation to 1e-9 (time to 1 µs, pynmea2's
/// resolution); where pynmea2 refuses a checksum, a bad checksum here.
#[test]
fn agrees_with_pynmea2() {
    let reference: Value = serde_json::from_str(REFERENCE).unwrap();
    let mut compared = 0;
    for (name, log) in [("mixed.nmea", MIXED), ("gofree-merrimac-head.nmea", GOFREE), ("n2kd-183-merrimac-head.nmea", N2KD)] {
        let entries = reference["logs"][name].as_array().unwrap();
        let lines = lines(log);
        assert_eq!(entries.len(), lines.len(), "{name}");
        for (e, raw) in entries.iter().zip(&lines) {
            let n = e["n"].as_u64().unwrap() as usize;
            let at = format!("{name}:{n} {:?}", String::from_utf8_lossy(raw));
            let status = e["status"].as_str().unwrap();
            let parsed = parse_line(raw);
            if status == "no_sentence" {
                assert_eq!(parsed, Line::NotNmea, "{at}");
                continue;
            }
            let Line::Sentence { no_checksum, outcome, .. } = parsed else { panic!("{at}: {parsed:?}") };
            assert_eq!(no_checksum, status == "ok_no_checksum", "{at}");
            let kind = e["type"].as_str().unwrap_or("");
            match (status, &outcome) {
                ("bad_checksum", Outcome::BadChecksum { .. }) => {}
                // pynmea2 reads no `!` sentence; junk after `*hh`.
                ("parse_error", Outcome::Unknown(u)) if u == "!AIVDM" => {}
                ("parse_error", Outcome::Partial(Partial::BadChecksumField)) if (name, n) == ("mixed.nmea", 33) => {}
                ("ok", Outcome::Unknown(u)) if u.starts_with(kind) && !KNOWN.contains(&kind) => {}
                ("ok" | "ok_no_checksum", Outcome::Partial(p)) => {
                    assert!(DISAGREE.contains(&(name, n, *p)), "{at}: pynmea2 reads it, this reader says {p:?}");
                }
                ("ok" | "ok_no_checksum", Outcome::Read { talker, sentence }) => {
                    assert_eq!((talker.as_str(), sentence.kind()), (e["talker"].as_str().unwrap(), kind), "{at}");
                    assert!(e.get("unparsable").is_none(), "{at}: pynmea2 could not convert {}", e["unparsable"]);
                    check_values(sentence, e, &at);
                    compared += 1;
                }
                _ => panic!("{at}: pynmea2 {status} {kind}, this reader {outcome:?}"),
            }
        }
    }
    // mixed: 38 lines − 1 without a sentence − 1 bad checksum − 4 that
    // pynmea2 cannot read or of other types − 6 refused here (DISAGREE);
    // gofree: 168 HDG + 18 × (RMC, VTG, VHW, GGA, GLL, ZDA); n2kd: 7 HDG + 13 HDM.
    assert_eq!(compared, 26 + 276 + 20);
}

fn check_values(s: &Sentence, e: &Value, at: &str) {
    const DEG: f64 = 1e-9;
    let time_ok = |t: Option<f64>| same(t, &e["time"], 1e-6);
    let ok = match s {
        Sentence::Hdg { heading_deg, deviation_deg, variation_deg } => {
            same(*heading_deg, &e["heading"], DEG) && same(*deviation_deg, &e["deviation"], DEG) && same(*variation_deg, &e["variation"], DEG)
        }
        Sentence::Hdm { heading_deg } | Sentence::Hdt { heading_deg } => same(*heading_deg, &e["heading"], DEG),
        Sentence::Rmc { time_s, valid, date, lat_deg, lon_deg, speed_mps, course_deg, variation_deg } => {
            let date_ok = match (date, e["date"].as_array()) {
                (Some(d), Some(r)) => [d.year as u64, d.month as u64, d.day as u64] == [r[0].as_u64().unwrap(), r[1].as_u64().unwrap(), r[2].as_u64().unwrap()],
                (None, None) => true,
                _ => false,
            };
            time_ok(*time_s)
                && *valid == (e["fix_status"] == "A" && !["N", "E", "M", "S"].contains(&e["mode"].as_str().unwrap_or("")))
                && date_ok
                && same(*lat_deg, &e["lat"], DEG)
                && same(*lon_deg, &e["lon"], DEG)
                && same(speed_mps.map(|v| v / KNOT_MPS), &e["speed_kn"], 1e-9)
                && same(*course_deg, &e["course"], DEG)
                && same(*variation_deg, &e["variation"], DEG)
        }
        Sentence::Vtg { course_deg, speed_mps, valid } => {
            let speed = match e["speed_kn"].as_f64() {
                Some(kn) => Some(kn * KNOT_MPS),
                None => e["speed_kmh"].as_f64().map(|k| k / 3.6),
            };
            same(*course_deg, &e["course"], DEG) && *speed_mps == speed && *valid == (e["mode"] != "N")
        }
        Sentence::Vhw { speed_mps } => {
            let speed = match e["speed_kn"].as_f64() {
                Some(kn) => Some(kn * KNOT_MPS),
                None => e["speed_kmh"].as_f64().map(|k| k / 3.6),
            };
            *speed_mps == speed
        }
        Sentence::Gga { time_s, lat_deg, lon_deg, quality } => {
            time_ok(*time_s) && same(*lat_deg, &e["lat"], DEG) && same(*lon_deg, &e["lon"], DEG) && quality.map(u64::from) == e["quality"].as_u64()
        }
        Sentence::Gll { lat_deg, lon_deg, time_s, valid } => {
            time_ok(*time_s) && same(*lat_deg, &e["lat"], DEG) && same(*lon_deg, &e["lon"], DEG) && *valid == (e["fix_status"] == "A" && e["mode"] != "N")
        }
        Sentence::Zda { time_s, date, two_digit_year } => {
            let (y, m, d) = (e["year"].as_i64().unwrap(), e["month"].as_u64().unwrap() as u32, e["day"].as_u64().unwrap() as u32);
            // A two-digit year (pynmea2 gives it as is, e.g. 14) is not a date here.
            let date_ok = if y < 100 { *two_digit_year && date.is_none() } else { *date == Date::new(y as i32, m, d) };
            time_ok(*time_s) && date_ok
        }
    };
    assert!(ok, "{at}: ours {s:?}, pynmea2 {e}");
}

/// Field by field, with values worked out by hand from the sentences.
#[test]
fn the_fields_and_their_signs() {
    // 4807.038 N = 48 + 7.038/60 = 48.1173°; 01131.000 W = −11.516 666…°;
    // 022.4 kn = 22.4 × 1852/3600 = 11.523 555… m/s; 003.1,W = −3.1°.
    let s = sentence("$GPRMC,123519,A,4807.038,N,01131.000,W,022.4,084.4,230394,003.1,W*78");
    let Sentence::Rmc { time_s, valid, date, lat_deg, lon_deg, speed_mps, course_deg, variation_deg } = s else { panic!() };
    assert_eq!((time_s, valid, date), (Some(12.0 * 3600.0 + 35.0 * 60.0 + 19.0), true, Date::new(1994, 3, 23)));
    assert!((lat_deg.unwrap() - 48.1173).abs() < 1e-12 && (lon_deg.unwrap() + 11.516_666_666_666_667).abs() < 1e-12);
    assert!((speed_mps.unwrap() - 11.523_555_555_555_556).abs() < 1e-12);
    assert_eq!((course_deg, variation_deg), (Some(84.4), Some(-3.1)));
    // HDG: deviation 1.5 W, variation 4.2 E.
    assert_eq!(sentence("$IIHDG,045.3,1.5,W,4.2,E"), Sentence::Hdg { heading_deg: Some(45.3), deviation_deg: Some(-1.5), variation_deg: Some(4.2) });
    // Talker agnostic, lower-case checksum accepted, trailing blanks ignored.
    let Line::Sentence { outcome: Outcome::Read { talker, .. }, no_checksum: false, .. } = parse_line(b"$GNRMC,000000,A,0000.000,S,00000.000,E,0,0,010100,,*1e  ") else { panic!() };
    assert_eq!(talker, "GN");
    assert!(matches!(read("$GNRMC,000000,A,0000.000,S,00000.000,E,0,0,010100,,*1F"), Outcome::BadChecksum { given: 0x1F, computed: 0x1E }));
    // VTG: km/h only: 36 km/h = 10 m/s.
    assert_eq!(sentence("$GPVTG,,T,,M,,N,036.0,K"), Sentence::Vtg { course_deg: None, speed_mps: Some(10.0), valid: true });
    // VHW: speed through water, knots first (its headings not read).
    assert_eq!(sentence("$IIVHW,,T,,M,5.0,N,9.26,K"), Sentence::Vhw { speed_mps: Some(5.0 * 1852.0 / 3600.0) });
    assert_eq!(sentence("$IIVHW,,T,,M,,N,36.0,K"), Sentence::Vhw { speed_mps: Some(10.0) });
    // A prefix before the $ is skipped; NUL bytes before it too.
    assert!(matches!(parse_line(b"\0\0[12:00:01] $HCHDM,010.0,M"), Line::Sentence { prefixed: true, no_checksum: true, outcome: Outcome::Read { .. }, .. }));
    // Void and invalid letters.
    assert!(sentence("$GPGLL,4916.45,N,12311.12,W,225444,V").is_void());
    assert!(sentence("$GPGGA,123519,4807.038,N,01131.000,E,6,08,0.9,545.4,M,46.9,M,,").is_void());
    assert_eq!(read("$GPGLL,4916.45,X,12311.12,W,225444,A"), Outcome::Partial(Partial::BadLetter));
    assert_eq!(read("$HCHDT,100.0,M"), Outcome::Partial(Partial::BadLetter));
    assert_eq!(read("$HCHDG,100.0,1.0,,2.0,E"), Outcome::Partial(Partial::BadLetter));
    assert_eq!(read("$GPGGA,256000,4807.038,N,01131.000,E,1,08"), Outcome::Partial(Partial::BadTime));
    assert_eq!(read("$GPRMC,123519,A,4860.000,N,01131.000,E,0,0,230394,,"), Outcome::Partial(Partial::OutOfRange));
    assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,1e3,0,230394,,"), Outcome::Partial(Partial::BadNumber));
    assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,inf,0,230394,,"), Outcome::Partial(Partial::BadNumber));
    assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,-1,0,230394,,"), Outcome::Partial(Partial::OutOfRange));
    assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,1,0,290223,,"), Outcome::Partial(Partial::BadDate));
    assert_eq!(read("$gprmc,123519,A"), Outcome::Partial(Partial::BadAddress));
    assert_eq!(read("$GPRMC"), Outcome::Partial(Partial::TooFewFields));
    assert_eq!(read("$GPRMC,1*5"), Outcome::Partial(Partial::BadChecksumField));
    assert_eq!(read("$GPRMC,1*+5"), Outcome::Partial(Partial::BadChecksumField));
    assert_eq!(read("$PGRME,15.0,M,45.0,M,25.0,M*1C"), Outcome::Unknown("PGRME".into()));
    assert_eq!(read("$GPGSV,1,1,00*79"), Outcome::Unknown("GSV".into()));
    // 2024-02-29 exists (a leap year), 1900-02-29 does not; the epoch's day count.
    assert!(Date::new(2024, 2, 29).is_some() && Date::new(1900, 2, 29).is_none() && Date::new(2000, 2, 29).is_some());
    assert_eq!(Date::new(2021, 3, 1).unwrap().days_since_epoch(), 18_687);
    for days in [-800_000, -1, 0, 1, 18_687, 2_932_896] {
        let d = Date::from_days_since_epoch(days);
        assert_eq!(Date::new(d.year, d.month, d.day).unwrap().days_since_epoch(), days);
    }
}

/// Every prefix of a well-formed sentence (a line cut short) is either
/// refused or read with the values the whole sentence gives (none
/// invented, none changed).
#[test]
fn a_truncated_sentence_never_gives_a_wrong_value() {
    let mut read_prefixes = 0;
    for whole in lines(MIXED).into_iter().chain(lines(GOFREE)) {
        let Line::Sentence { outcome: Outcome::Read { sentence: full, .. }, .. } = parse_line(whole) else { continue };
        let values = |s: &Sentence| -> Vec<Option<f64>> {
            match s {
                Sentence::Hdg { heading_deg, deviation_deg, variation_deg } => vec![*heading_deg, *deviation_deg, *variation_deg],
                Sentence::Hdm { heading_deg } | Sentence::Hdt { heading_deg } => vec![*heading_deg],
                Sentence::Rmc { time_s, lat_deg, lon_deg, speed_mps, course_deg, variation_deg, .. } => vec![*time_s, *lat_deg, *lon_deg, *speed_mps, *course_deg, *variation_deg],
                Sentence::Vtg { course_deg, speed_mps, .. } => vec![*course_deg, *speed_mps],
                Sentence::Vhw { speed_mps } => vec![*speed_mps],
                Sentence::Gga { time_s, lat_deg, lon_deg, .. } => vec![*time_s, *lat_deg, *lon_deg],
                Sentence::Gll { time_s, lat_deg, lon_deg, .. } => vec![*time_s, *lat_deg, *lon_deg],
                Sentence::Zda { time_s, .. } => vec![*time_s],
            }
        };
        let want = values(&full);
        let start = whole.iter().position(|&b| b == b'$').unwrap();
        for cut in start + 1..whole.len() {
            if let Line::Sentence { outcome: Outcome::Read { sentence, .. }, no_checksum, .. } = parse_line(&whole[..cut]) {
                assert!(no_checksum, "{:?}", String::from_utf8_lossy(&whole[..cut]));
                assert_eq!(sentence.kind(), full.kind());
                for (got, want) in values(&sentence).iter().zip(&want) {
                    assert!(got.is_none() || got == want, "{:?}: {got:?} (the whole sentence: {want:?})", String::from_utf8_lossy(&whole[..cut]));
                }
                read_prefixes += 1;
            }
        }
    }
    // Cut just before `*`, or after a complete last field: measured.
    // Measured: the cuts that leave every field the type needs (e.g.
    // just before `*hh`, or inside GGA's unused altitude).
    assert_eq!(read_prefixes, 1037);
}

proptest::proptest! {
    /// No byte string makes the reader or the import panic.
    #[test]
    fn any_bytes_are_safe(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400)) {
        let _ = parse_line(&bytes);
        let _ = import(&bytes, &ImportOptions::default());
    }

    /// Sentences damaged anywhere (a byte changed, or the log cut at any
    /// point) never panic and are refused or counted.
    #[test]
    fn damaged_logs_are_safe(at in 0usize..2000, byte in proptest::prelude::any::<u8>(), cut in 0usize..2000) {
        let mut log = MIXED.to_vec();
        let i = at % log.len();
        log[i] = byte;
        log.truncate(cut.max(i + 1));
        if let Ok(im) = import(&log, &ImportOptions::default()) {
            proptest::prop_assert!(im.report.rows > 0);
        }
    }
}

fn t_of(im: &Imported) -> Vec<f64> {
    im.column(col::T).unwrap().to_vec()
}

/// The time rule, on numbers worked out by hand.
#[test]
fn untimed_sentences_are_spread_between_timed_ones() {
    let log = "$GPRMC,100000,A,,,,,,,010121,,\n\
               $HCHDM,001.0,M\n$HCHDM,002.0,M\n$HCHDM,003.0,M\n\
               $GPGGA,100002,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
               $HCHDM,004.0,M\n\
               $GPGLL,4807.038,N,01131.000,E,100002,A\n\
               $HCHDM,005.0,M\n\
               $GPZDA,100003,01,01,2021,00,00\n";
    let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
    // 3 HDM between 10:00:00 and 10:00:02: 0.5, 1.0, 1.5 s; the HDM
    // between two sentences of 10:00:02 gets 2 s; the last, between
    // 10:00:02 and 10:00:03, 2.5 s. The RMC gives no row (no value).
    assert_eq!(t_of(&im), [0.5, 1.0, 1.5, 2.0, 2.0, 2.0, 2.5]);
    assert_eq!(im.column(col::COMPASS_HEADING_DEG).unwrap()[..3], [1.0, 2.0, 3.0]);
    assert_eq!(im.report.start_utc.as_deref(), Some("2021-01-01T10:00:00Z"));
    assert_eq!(im.report.used.get("RMC"), Some(&1));
    // Before the first and after the last timed sentence, and over a gap
    // longer than MAX_SPREAD_GAP_S: counted, not used.
    let log = "$HCHDM,001.0,M\n$GPZDA,100000,01,01,2021,00,00\n$HCHDM,002.0,M\n$GPZDA,100001,01,01,2021,00,00\n\
               $HCHDM,003.0,M\n$GPZDA,100020,01,01,2021,00,00\n$HCHDM,004.0,M\n";
    let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
    assert_eq!(t_of(&im), [0.5]);
    let r = &im.report;
    assert_eq!((r.untimed_before_first_time, r.untimed_in_gaps, r.untimed_after_last_time), (1, 1, 1));
    assert_eq!(r.duration_s, 0.5);
}

/// GGA and GLL carry the time of day: dated by RMC/ZDA, the day advancing
/// at midnight; a time going back is dropped.
#[test]
fn midnight_and_time_going_back() {
    let log = "$GPGGA,235959.5,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
               $GPRMC,000000.5,A,4807.038,N,01131.000,E,5.0,090.0,010321,,\n\
               $HCHDM,010.0,M\n\
               $GPGGA,000001.5,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
               $GPGGA,000000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
               $GPGLL,4807.038,N,01131.000,E,000002.5,A\n";
    let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
    // The first GGA, before the first date (1 March) and 12 h after its
    // time of day, is 28 February 23:59:59.5: t = 0, 1, 1.5, 2, (back: dropped), 3.
    assert_eq!(t_of(&im), [0.0, 1.0, 1.5, 2.0, 3.0]);
    assert_eq!(im.report.start_utc.as_deref(), Some("2021-02-28T23:59:59.500Z"));
    assert_eq!(im.report.time_backwards, 1);
    // 5 kn ≥ 0.5 m/s: the course is the reference (no HDT).
    assert_eq!(im.report.reference, Reference::Course);
    assert_eq!(im.column(col::REF_HEADING_DEG).unwrap()[1], 90.0);
    // Without any date: t from the first time of day, no start_utc, said.
    let im = import(b"$GPGGA,120000,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n$HCHDM,010.0,M\n$GPGGA,120001,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n", &ImportOptions::default()).unwrap();
    assert_eq!(t_of(&im), [0.0, 0.5, 1.0]);
    assert_eq!((im.report.start_utc.as_deref(), im.report.start_time_of_day_utc.as_str()), (None, "12:00:00"));
    assert!(im.report.notes.iter().any(|n| n.contains("no date")), "{:?}", im.report.notes);
}

/// The hand-made log (tests/data/nmea/make_mixed.py): every count
/// follows from its 38 lines (see the comments there).
#[test]
fn the_mixed_log_is_counted_by_kind() {
    let im = import(MIXED, &ImportOptions::default()).unwrap();
    let r = &im.report;
    assert_eq!((r.lines, r.sentences, r.non_nmea_lines, r.prefixed_lines), (38, 37, 1, 1));
    // Line 14; lines 15, 16, 17, 26, 28, 33, 35; lines 20, 21, 22.
    assert_eq!((r.bad_checksum, r.partial, r.unknown), (1, 7, 3));
    // Lines 10 and 15 have no checksum; 18, 19, 32 are void; 23 is empty.
    assert_eq!((r.missing_checksum, r.void_fixes, r.empty_values), (2, 3, 1));
    // HCHDG (4) is the compass; HCHDM (3) and 24HDG (1) are not used.
    assert_eq!((r.compass_source.as_deref(), r.other_source), (Some("HCHDG"), 4));
    assert_eq!(r.reference, Reference::Hdt);
    assert_eq!(r.start_utc.as_deref(), Some("2021-02-28T23:59:58.500Z"));
    assert_eq!(r.rows, 16);
    // HDG lines 2, 3 and HDT 4 between 23:59:58.5 (line 1) and 23:59:59
    // (line 5): t = 0.125, 0.25, 0.375; line 8 between 00:00:00 and
    // 00:00:01: 2.0; lines 10-12 between 00:00:01 and 00:00:02: 2.75, 3.0, 3.25.
    let t = t_of(&im);
    assert_eq!(t, [0.0, 0.125, 0.25, 0.375, 0.5, 1.5, 2.0, 2.5, 2.75, 3.0, 3.25, 8.5, 9.5, 10.5, 14.0, 14.5]);
    let heading = im.column(col::COMPASS_HEADING_DEG).unwrap();
    assert_eq!([heading[1], heading[2], heading[6], heading[8]], [98.3, 101.5, 99.0, 99.5]);
    assert!(r.notes.iter().any(|n| n.contains("NOT applied") && n.contains("2.5")), "{:?}", r.notes);
    assert!(r.notes.iter().any(|n| n.contains("two-digit year")), "{:?}", r.notes);
    assert_eq!(im.column(col::REF_HEADING_DEG).unwrap()[3], 100.1);
    assert_eq!(r.columns, [col::T, col::COMPASS_HEADING_DEG, col::VARIATION_DEG, col::REF_HEADING_DEG, col::COURSE_DEG, col::GPS_SPEED_MPS, col::LAT_DEG, col::LON_DEG]);
}

/// Each HDT by its talker: the compass's own (its HDG's talker, or HC)
/// left out and counted; a GNSS compass's the reference; another
/// talker's only when named; the compass's talker never.
#[test]
fn an_hdt_is_the_reference_only_from_an_independent_talker() {
    let log = |hdt: &str| format!("$GPRMC,100000,A,4807.038,N,01131.000,E,5.0,090.0,010121,,\n$24HDG,010.0,,,,\n${hdt}HDT,012.0,T\n$GPRMC,100001,A,4807.038,N,01131.000,E,5.0,091.0,010121,,\n");
    let run = |hdt: &str, named: Option<&str>| import(log(hdt).as_bytes(), &ImportOptions { reference_talker: named.map(str::to_string), ..ImportOptions::default() });
    let im = run("24", None).unwrap();
    assert_eq!((im.report.reference, im.report.compass_true_headings), (Reference::Course, 1));
    assert_eq!(im.report.column_sources.get(col::REF_HEADING_DEG).map(String::as_str), Some("GPRMC (course over ground at 0.5 m/s or more)"));
    assert_eq!(run("HC", None).unwrap().report.compass_true_headings, 1);
    let im = run("GN", None).unwrap();
    assert_eq!((im.report.reference, im.report.column_sources.get(col::REF_HEADING_DEG).map(String::as_str)), (Reference::Hdt, Some("GNHDT")));
    let im = run("II", None).unwrap();
    assert_eq!((im.report.reference, im.report.unplaced_true_headings, im.report.unplaced_true_heading_sources.clone()), (Reference::Course, 1, vec!["IIHDT".to_string()]));
    assert_eq!(run("II", Some("II")).unwrap().report.reference, Reference::Hdt);
    let e = run("24", Some("24")).unwrap_err().to_string();
    assert!(e.starts_with("24 is the compass's own talker (24HDG)"), "{e}");
    assert!(run("II", Some("ii")).unwrap_err().to_string().contains("not \"ii\""));
}

/// A dated sentence far from both neighbours is refused alone, at the
/// log's start, middle and end; a pause (neighbours apart too) is kept.
#[test]
fn a_date_jump_is_refused_alone() {
    let rmc = |s: u32, date: &str| format!("$GPRMC,1000{s:02},A,4807.038,N,01131.000,E,5.0,090.0,{date},,\n");
    for bad in [0, 5, 9] {
        let log: String = (0..10).map(|s| rmc(s, if s == bad { "010122" } else { "010121" })).collect();
        let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
        assert_eq!((im.report.date_jumps, im.report.rows, im.report.time_backwards), (1, 9, 0), "{bad}");
        assert_eq!(im.report.start_utc.as_deref(), Some(if bad == 0 { "2021-01-01T10:00:01Z" } else { "2021-01-01T10:00:00Z" }));
    }
    // Two days apart, five fixes each: a pause, nothing refused.
    let log: String = (0..10).map(|s| rmc(s, if s < 5 { "010121" } else { "030121" })).collect();
    let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
    assert_eq!((im.report.date_jumps, im.report.rows), (0, 10));
}

/// The refusals, each with what the input looked like.
#[test]
fn refusals_say_what_the_input_was() {
    let err = |b: &[u8]| import(b, &ImportOptions::default()).unwrap_err().to_string();
    assert_eq!(err(b""), "no NMEA 0183 sentence: the file is empty (0 bytes)");
    assert!(err(&[0xA3, 0x95, 0x80, 0, 1, 2, b'$', 200]).contains("not text: a binary file"));
    assert!(err(b"!AIVDM,1,1,,A,14eG;o@034o8sd<L9i:a;WF>062D,0*7D\r\n").contains("1 `!` sentences (AIS"));
    assert!(err(b"t,mx,my,mz\n0,1,2,3\n").contains("no line holds a `$` sentence (first line: \"t,mx,my,mz\")"));
    assert!(err(&[b'$'; 3000]).contains("longer than 1024 bytes"));
    let e = err(b"$IIMWV,271.0,R,000.2,N,A*3B\n$GPGGA,120000,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n");
    assert!(e.starts_with("nothing to calibrate with: no heading sentence"), "{e}");
    let e = err(N2KD);
    assert!(e.starts_with("no sentence gives a time"), "{e}");
    // Headings only outside the timed part.
    let e = err(b"$HCHDM,001.0,M\n$GPZDA,100000,01,01,2021,00,00\n");
    assert!(e.contains("no heading or course could be timed (1 before the first timed sentence"), "{e}");
}
