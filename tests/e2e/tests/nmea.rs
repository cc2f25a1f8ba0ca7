//! The NMEA 0183 stream mode end to end: the firmware in QEMU, the host
//! playing the bridges and the AHRS, the link switched to NMEA; every
//! sentence the board sends is parsed by an independent parser (`pynmea2`
//! from PyPI, installed here when missing) with its checksum checked, the
//! values compared with the truth, a passing magnet sent as an empty
//! heading, and the link taken back to framed samples.

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use calib_core::heading::{ned_field, ned_to_body};
use e2e_tests::{boot_with_feed, magcal_bin};
use host_tools::board::{BoardClient, FeedWriter};
use magcal_protocol::{self as proto, Integrity, Request, RequestBody, Response, ResponseBody, StreamMode, MAX_FRAME_LEN};

const DECLINATION_RAD: f64 = 0.05;
const YAW_RAD: f64 = 1.2;
const FIELD_NT: f64 = 48_730.0;

fn frame(seq: u16, body: RequestBody) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let n = proto::encode(&Request { seq, body }, &mut buf).expect("encode");
    buf[..n].to_vec()
}

/// The NMEA lines of a capture: the framed replies (`0x00 ‖ frame ‖ \r\n`,
/// the frame ending in its own zero) taken out, the first (possibly
/// partial) line and an unterminated last one dropped.
fn nmea_lines(capture: &[u8]) -> Vec<String> {
    let mut text = Vec::new();
    for (i, piece) in capture.split(|b| *b == 0).enumerate() {
        if i % 2 == 0 {
            text.extend_from_slice(piece);
        }
    }
    let text = String::from_utf8(text).expect("NMEA is ASCII");
    let mut lines: Vec<&str> = text.split("\r\n").collect();
    lines.pop(); // after the last "\r\n": unterminated
    lines.into_iter().skip(1).filter(|l| !l.is_empty()).map(String::from).collect()
}

/// `pynmea2` importable, installed with pip when it is not.
fn ensure_pynmea2() {
    let have = |_: ()| Command::new("python3").args(["-c", "import pynmea2"]).status().is_ok_and(|s| s.success());
    if have(()) {
        return;
    }
    let st = Command::new("python3").args(["-m", "pip", "install", "--quiet", "pynmea2"]).status().expect("run pip");
    assert!(st.success() && have(()), "pynmea2 could not be installed (pip install pynmea2)");
}

/// Each line parsed by pynmea2 with its checksum checked (`check=True`
/// raises on a bad or missing one), as one JSON array per line:
/// `[type, fields…]`, empty fields as null.
fn parse_with_pynmea2(path: &Path) -> Vec<serde_json::Value> {
    const SCRIPT: &str = r#"
import json, sys, pynmea2
for line in open(sys.argv[1], encoding="ascii"):
    m = pynmea2.parse(line.rstrip("\r\n"), check=True)
    if isinstance(m, pynmea2.ProprietarySentence):
        print(json.dumps(["P" + m.manufacturer] + [d if d != "" else None for d in m.data]))
    else:
        vals = [getattr(m, f[1]) for f in m.fields]
        print(json.dumps([m.sentence_type] + [str(v) if v is not None else None for v in vals]))
"#;
    let out = Command::new("python3").args(["-c", SCRIPT]).arg(path).output().expect("run python3");
    assert!(out.status.success(), "pynmea2 refused a sentence: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8_lossy(&out.stdout).lines().map(|l| serde_json::from_str(l).expect("json")).collect()
}

fn num(v: &serde_json::Value) -> Option<f64> {
    v.as_str().map(|s| s.parse().expect("a number"))
}

#[test]
fn the_board_streams_nmea_sentences_a_parser_accepts_and_goes_back_to_frames() {
    ensure_pynmea2();
    let board = boot_with_feed("nmea");
    let mut link = BoardClient::open(board.link_port()).expect("open link");
    let mut feed = FeedWriter::open(board.sensor_port().expect("feed pty")).expect("open feed");
    link.identify().expect("identify");
    // With the field's inclination as the set's reference (protocol 5):
    // without one no heading is ok (unjudged) and none is sent.
    let c = proto::Coefficients { declination_rad: DECLINATION_RAD as f32, field_nt: FIELD_NT as f32, inclination_rad: 1.12, ..firmware::device::default_coefficients() };
    link.upload_coefficients(&c).expect("upload");
    link.set_output_rate(10).expect("rate");
    let (roll, pitch) = (0.1f32, -0.05f32);
    let h = ned_to_body(ned_field(FIELD_NT, 1.12, DECLINATION_RAD), f64::from(roll), f64::from(pitch), YAW_RAD);
    let clean = h.map(|v| v as f32);
    // A magnet under the sensor: +8 000 nT on z, |h| up by ~7 800 nT, 13 σ
    // of the board's reference scatter (1.2 % of F).
    let magnet = [clean[0], clean[1], clean[2] + 8_000.0];
    let offsets = [50_000.0, -40_000.0, 20_000.0];
    feed.send(clean, offsets).expect("feed");
    link.attitude(roll, pitch).expect("attitude");
    // The switch as a user makes it: `magcal stream --mode nmea` on the
    // board's port (the test's own link closed meanwhile, then reopened).
    drop(link);
    let out = Command::new(magcal_bin()).args(["stream", "--port", board.link_port(), "--mode", "nmea"]).output().expect("run magcal stream");
    assert!(out.status.success(), "magcal stream --mode nmea failed: {}", String::from_utf8_lossy(&out.stderr));
    let link = BoardClient::open(board.link_port()).expect("reopen link");

    // 4 s clean, 1.5 s with the magnet, 1 s clean again; the AHRS keeps
    // the attitude fresh with framed requests meanwhile.
    let mut port = link.into_port();
    let mut capture = Vec::new();
    let start = Instant::now();
    // Due at once: the attitude sent before the switch is stale by now.
    let mut last_attitude = Instant::now() - Duration::from_secs(1);
    let mut seq = 100;
    while start.elapsed() < Duration::from_millis(6_500) {
        let t = start.elapsed().as_secs_f64();
        feed.send(if (4.0..5.5).contains(&t) { magnet } else { clean }, offsets).expect("feed");
        if last_attitude.elapsed() > Duration::from_millis(150) {
            seq += 1;
            port.write_all(&frame(seq, RequestBody::Attitude { roll_rad: roll, pitch_rad: pitch })).expect("write");
            last_attitude = Instant::now();
        }
        let mut buf = [0u8; 512];
        match port.read(&mut buf) {
            Ok(n) => capture.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock) => {}
            Err(e) => panic!("read: {e}"),
        }
    }

    let lines = nmea_lines(&capture);
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/e2e-logs");
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join("nmea-capture.txt");
    std::fs::write(&path, lines.iter().map(|l| format!("{l}\r\n")).collect::<String>()).expect("write capture");
    assert!(lines.iter().all(|l| l.starts_with('$')), "not a sentence: {lines:?}");
    let parsed = parse_with_pynmea2(&path);
    assert_eq!(parsed.len(), lines.len());

    // Group HDG, HDT, PMAGI per sample (a burst may be cut at the start).
    let true_deg = YAW_RAD.to_degrees();
    let (mut ok, mut flagged) = (0, 0);
    // The longest run of consecutive flagged samples the capture saw.
    let (mut run, mut longest_run) = (0u32, 0u32);
    // Per sample: 'o' ok, 'x' ok but off by 0.1° or more, 'f' flagged,
    // 'n' without attitude.
    let mut kinds: Vec<char> = Vec::new();
    let mut i = parsed.iter().position(|p| p[0] == "HDG").expect("an HDG");
    while i + 2 < parsed.len() {
        let (hdg, hdt, magi) = (&parsed[i], &parsed[i + 1], &parsed[i + 2]);
        assert_eq!((hdg[0].as_str(), hdt[0].as_str(), magi[0].as_str()), (Some("HDG"), Some("HDT"), Some("PMAG")), "{hdg} {hdt} {magi}");
        // ["PMAG", "I", sigma, state]
        assert_eq!(magi[1], "I");
        let state = magi[3].as_str().expect("a state");
        // Deviation 0.0 E (applied); variation = the declination, east.
        assert_eq!((num(&hdg[2]), hdg[3].as_str()), (Some(0.0), Some("E")));
        assert_eq!((num(&hdg[4]), hdg[5].as_str()), (Some((DECLINATION_RAD.to_degrees() * 10.0).round() / 10.0), Some("E")));
        assert_eq!(hdt[2], "T");
        match (state, num(&hdt[1]), num(&hdg[1])) {
            ("ok", Some(t), Some(m)) => {
                let sigma = num(&magi[2]).expect("a σ with an ok heading");
                // The board's σ without attitude noise: the field scatter's
                // 1.2 % of F over H = F cos 64.2° (0.0276 rad = 1.6°).
                assert!((0.5..3.0).contains(&sigma), "σ {sigma}");
                // Every ok heading within its σ; HDG and HDT agree up to
                // their rounding (0.05° each).
                assert!((t - true_deg).abs() < sigma, "HDT {t} vs {true_deg} (σ {sigma})");
                assert!((t - m - DECLINATION_RAD.to_degrees()).abs() < 0.1 + 1e-9, "HDT {t} HDG {m}");
                // Away from the magnet's edges, 0.05° of rounding plus the
                // chain's resolution (measured on the sensor test:
                // < 0.01°). A sample at an edge may hold a part of the
                // magnet the decimation filter averaged in and still pass
                // the gates (measured under load: 0.09° before one, 0.35°
                // after one): counted, at most two an edge.
                let off = (t - true_deg).abs() >= 0.1 || (m - (true_deg - DECLINATION_RAD.to_degrees())).abs() >= 0.1;
                kinds.push(if off { 'x' } else { 'o' });
                ok += 1;
                run = 0;
            }
            ("disturbed" | "cal_invalid", None, None) => {
                flagged += 1;
                kinds.push('f');
                run += 1;
                longest_run = longest_run.max(run);
            }
            // The attitude went stale (> 500 ms): the first samples after
            // the switch, until the loop's first attitude arrives, and any
            // while this test's attitude loop is starved on a loaded
            // machine, have no heading — and say so.
            ("no_attitude", None, None) => {
                run = 0;
                kinds.push('n');
            }
            other => panic!("heading and state disagree: {other:?} ({hdg} {hdt} {magi})"),
        }
        i += 3;
    }
    // 6.5 s at 10 Hz would be 50 clean samples and 15 with the magnet;
    // QEMU's board runs slower on a loaded host (measured: 18 ok and 6
    // flagged in a capture on two shared cores).
    eprintln!("NMEA capture: {} sentences, {ok} ok, {flagged} flagged", lines.len());
    assert!(ok >= 10, "{ok} ok, {flagged} flagged");
    // The ok samples off by 0.1° or more lie at the magnet's edges: within
    // two samples of a flagged one, two an edge at most.
    let kinds: String = kinds.into_iter().collect();
    // Without attitude after the first heading only while this test's
    // attitude loop starves (measured: one sample, once, under load); a
    // board that lost attitude mid-stream would show many.
    let first_heading = kinds.find(['o', 'x']).unwrap_or(kinds.len());
    let lost = kinds[first_heading..].matches('n').count();
    assert!(lost <= 3.max(kinds.len() / 5), "{lost} samples without attitude after the first heading: {kinds}");
    let off: Vec<usize> = kinds.match_indices('x').map(|(i, _)| i).collect();
    assert!(off.len() <= 4, "{kinds}");
    for i in off {
        assert!(kinds.get(i.saturating_sub(2)..(i + 3).min(kinds.len())).is_some_and(|w| w.contains('f')), "an ok sample off by 0.1° away from the magnet's edges: {kinds}");
    }
    // The magnet seen (measured: 12–25 flagged on two shared cores, 2 with
    // three more busy processes beside the test).
    assert!(flagged >= 2, "{ok} ok, {flagged} flagged");

    // Back to frames with a framed request sent in NMEA mode.
    seq += 1;
    port.write_all(&frame(seq, RequestBody::SetStream(StreamMode::Raw))).expect("write");
    let mut link = BoardClient::new(port);
    let deadline = Instant::now() + Duration::from_secs(3);
    let mut acked = false;
    while !acked && Instant::now() < deadline {
        if let Ok(Some(r)) = link.next_response(Duration::from_millis(200)) {
            acked = r == Response { seq: Some(seq), body: ResponseBody::Ack };
        }
    }
    assert!(acked, "no Ack to SetStream(Raw) sent in NMEA mode");
    let s = link.next_sample(Duration::from_secs(2)).expect("read").expect("a framed sample");
    assert!(s.raw.is_some() && s.field_nt.is_none());
    let health = link.status().expect("status");
    assert_eq!(health.stream, StreamMode::Raw);
    // The board counted at least what the capture saw.
    assert!(health.integrity_samples[Integrity::Ok as usize] >= ok, "{health:?}");
    assert!(health.integrity_samples[Integrity::Disturbed as usize] + health.integrity_samples[Integrity::CalInvalid as usize] >= flagged, "{health:?}");
    // The longest disturbance spans at least the capture's longest run of
    // flagged samples, 100 ms apart (a sample without attitude between
    // two runs ends one: measured once under load, 20 flagged in two runs,
    // the board's longest 1.7 s).
    assert!(health.longest_disturbance_ms >= 100 * longest_run.saturating_sub(1), "longest run {longest_run}: {health:?}");
}
