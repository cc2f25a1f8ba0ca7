//! `magcal log` ([`crate::board::log`]) against the in-memory board of the
//! session's tests: the firmware's own request handling behind a link that
//! can be cut. The board streams a sample every 10 ms of its clock, which
//! advances 10 ms per read of the link (100 Hz in virtual time), with
//! `raw = [1000·roll, 2, 3]` (roll 0 here).

use std::sync::atomic::{AtomicBool, Ordering};

use super::*;
use crate::board::log::{log_board, LogEnd, LogError, LogOptions, LogSummary};
use crate::data::board_log::{self, BoardLog, HEALTH_AFTER_GAP};

fn opts() -> LogOptions {
    LogOptions { rate_hz: 100, silence: Duration::from_millis(200), backoff_initial: Duration::from_millis(10), ..LogOptions::default() }
}

/// Logs until `rows` rows are written (the stop flag, as Ctrl-C sets it),
/// then reads the file back with `merge`'s own reader.
fn log_until(rows: u64, connect: &mut dyn FnMut() -> Result<BoardClient<Conn>, ClientError>, mut each: impl FnMut(u64)) -> (LogSummary, BoardLog, String) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("board.csv");
    let file = crate::board::log::create_log_file(&path, false).unwrap();
    let stop = AtomicBool::new(false);
    let summary = log_board(connect, file, path.clone(), &opts(), &stop, |p| {
        each(p.samples);
        if p.samples >= rows {
            stop.store(true, Ordering::Relaxed);
        }
    })
    .unwrap();
    (summary, BoardLog::read(&path).unwrap(), std::fs::read_to_string(&path).unwrap())
}

/// Board-time steps between rows, ms (the board stamps whole milliseconds).
fn steps_ms(log: &BoardLog) -> Vec<i64> {
    log.t_s.windows(2).map(|w| ((w[1] - w[0]) * 1000.0).round() as i64).collect()
}

#[test]
fn a_link_cut_mid_log_is_reopened_and_the_gap_kept_and_counted() {
    let b = board();
    // The first connection dies after 2000 bytes have come back (about 60
    // samples after the set-up replies); the next ones work.
    let mut connect = connector(&b, vec![(None, Some(2000)), (None, None), (None, None)]);
    let (s, log, text) = log_until(300, &mut connect, |_| {});
    assert_eq!(s.ended, LogEnd::Interrupted);
    assert_eq!(s.link_drops, 1, "{s:?}");
    assert_eq!(s.samples as usize, log.t_s.len());
    assert!(s.samples >= 300);
    // Every step is the board's 10 ms except at the gap, which is longer
    // (at least the sample that was on the wire when the link broke) and
    // flagged on the row after it.
    let steps = steps_ms(&log);
    let health = log.health.as_ref().expect("health column");
    let gaps: Vec<usize> = (0..steps.len()).filter(|&i| steps[i] != 10).collect();
    assert_eq!(gaps.len(), 1, "steps {steps:?}");
    let g = gaps[0];
    assert!(steps[g] >= 20 && steps[g] % 10 == 0, "gap {} ms", steps[g]);
    assert_eq!(s.gaps.len(), 1);
    assert!((s.gaps[0].length_s - steps[g] as f64 / 1000.0).abs() < 1e-9, "{s:?}");
    assert!((s.gaps[0].after_t_s - log.t_s[g]).abs() < 1e-9);
    assert_eq!(s.gaps[0].missing_samples as i64, steps[g] / 10 - 1);
    for (i, h) in health.iter().enumerate() {
        assert_eq!(*h as u32, if i == g + 1 { HEALTH_AFTER_GAP } else { 0 }, "row {i}");
    }
    // The cut came after the set-up and well before the end.
    assert!(g > 20 && g < 150, "gap at row {g}");
    // The raw field and the temperature as the board sent them (the mock
    // board's thermistor reads 21.5 °C).
    assert!(log.mag.iter().all(|m| *m == [0.0, 2.0, 3.0]));
    assert!(log.temp_c.as_ref().unwrap().iter().all(|t| *t == 21.5));
    assert!(text.starts_with(&format!("{}\n", board_log::HEADER)));
    assert!(board_log::HEADER.ends_with(",heading_sigma_deg,integrity"));
    // The board's heading σ and integrity, as it sent them (the mock
    // board: 1.25°, disturbed).
    assert!(text.lines().skip(1).all(|l| l.ends_with(",1.25,disturbed")), "{text}");
    // The board's clock started at 5 s and advanced 10 ms per read.
    assert!(log.t_s[0] > 5.0 && log.t_s[0] < 5.5, "{}", log.t_s[0]);
}

#[test]
fn failed_reopens_are_retried_with_backoff_until_the_board_is_back() {
    let b = board();
    let mut inner = connector(&b, vec![(None, Some(1500)), (None, None), (None, None), (None, None)]);
    let mut calls = 0;
    // Calls 2 and 3 (the first reopenings) find no port.
    let mut connect = move || {
        calls += 1;
        if calls == 2 || calls == 3 {
            Err(ClientError::Io(io::Error::new(io::ErrorKind::NotFound, "unplugged")))
        } else {
            inner()
        }
    };
    let (s, log, _) = log_until(200, &mut connect, |_| {});
    assert_eq!((s.link_drops, s.gaps.len()), (1, 1), "{s:?}");
    assert!(log.t_s.windows(2).all(|w| w[1] > w[0]));
}

#[test]
fn a_silent_board_is_reopened_and_its_stream_restarted() {
    let b = board();
    let mut connect = connector(&b, vec![]);
    let quiet = b.clone();
    let mut silenced = false;
    // After 50 rows the board stops streaming (as if it lost the stream
    // request); reopening sets the stream again.
    let (s, log, _) = log_until(150, &mut connect, |n| {
        if n >= 50 && !silenced {
            quiet.borrow_mut().streaming = false;
            silenced = true;
        }
    });
    assert_eq!(s.link_drops, 1, "{s:?}");
    assert!(log.t_s.len() >= 150);
    // No board time passes while it is silent (its clock runs on reads of
    // a streaming link): no gap, only the drop.
    assert!(steps_ms(&log).iter().all(|&d| d == 10), "{:?}", steps_ms(&log));
}

/// A port that accepts bytes and never answers.
struct Dead;
impl Read for Dead {
    fn read(&mut self, _: &mut [u8]) -> io::Result<usize> {
        std::thread::sleep(Duration::from_millis(1));
        Ok(0)
    }
}
impl Write for Dead {
    fn write(&mut self, b: &[u8]) -> io::Result<usize> {
        Ok(b.len())
    }
    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_port_without_a_board_and_a_port_that_cannot_open_are_refused() {
    let stop = AtomicBool::new(false);
    let mut silent = || {
        let mut l = BoardClient::new(Dead);
        l.timeout = Duration::from_millis(30);
        Ok(l)
    };
    let mut out = Vec::new();
    let e = log_board(&mut silent, &mut out, "board.csv".into(), &opts(), &stop, |_| {}).unwrap_err();
    assert!(matches!(e, LogError::Identify(ClientError::Timeout { .. })), "{e:?}");
    assert!(e.to_string().starts_with("no board answers"), "{e}");
    assert!(out.is_empty(), "nothing written before the board answered");
    let mut missing = || -> Result<BoardClient<Dead>, ClientError> { Err(ClientError::Io(io::Error::new(io::ErrorKind::NotFound, "no such port"))) };
    let e = log_board(&mut missing, &mut out, "board.csv".into(), &opts(), &stop, |_| {}).unwrap_err();
    assert!(matches!(e, LogError::Open(_)), "{e:?}");
    let e = log_board(&mut missing, &mut out, "board.csv".into(), &LogOptions { rate_hz: 0, ..opts() }, &stop, |_| {}).unwrap_err();
    assert!(matches!(e, LogError::RateOutOfRange(0)), "{e:?}");
}

/// The board's integrity states counted as they are logged, and the
/// session's "recalibrate" rule on them: a second of `cal_invalid` in a
/// log of about four seconds says "recalibrate" with the evidence; the
/// same log all `ok` says nothing.
#[test]
fn the_logged_integrity_states_are_counted_and_judged_by_the_sessions_rule() {
    let b = board();
    // Board time 5.5 s to 6.5 s cal_invalid: 100 samples at its 10 ms.
    b.borrow_mut().integrity_at = |t_ms| if (5500..6500).contains(&t_ms) { magcal_protocol::Integrity::CalInvalid } else { magcal_protocol::Integrity::Ok };
    let mut connect = connector(&b, vec![]);
    let (s, log, text) = log_until(400, &mut connect, |_| {});
    assert!(log.t_s[0] < 5.5 && *log.t_s.last().unwrap() > 6.5, "the log spans the stretch: {s:?}");
    // The counts against the file's own integrity column.
    let column = |word: &str| text.lines().skip(1).filter(|l| l.ends_with(&format!(",{word}"))).count() as u64;
    let c = &s.integrity;
    assert_eq!([IntegrityState::Ok, IntegrityState::CalInvalid, IntegrityState::Disturbed, IntegrityState::NoAttitude].map(|st| c.states.of(st)), [column("ok"), column("cal_invalid"), 0, 0]);
    assert_eq!((c.states.of(IntegrityState::CalInvalid), c.states.total()), (100, s.samples));
    // 100 steps of 10 ms on the board's clock, both stretches.
    assert!((c.longest_cal_invalid_s.unwrap() - 1.0).abs() < 1e-6 && (c.longest_disturbance_s - 1.0).abs() < 1e-6, "{c:?}");
    // The mock board has no calibration: no on-line hard iron, read from
    // its Health at the end.
    assert_eq!((c.hard_iron_applied, c.hard_iron_nt), (Some(false), None));
    let e = s.recalibrate.expect("100 of about 400 samples cal_invalid");
    assert_eq!((e.rows as u64, e.cal_invalid_rows, e.hard_iron_applied), (s.samples, 100, false));
    assert!(e.cal_invalid_fraction > 0.10 && e.cal_invalid_fraction < 0.30, "{e:?}");
    let line = crate::doc::integrity::recalibrate_text(&e, crate::board::log::LOGGED_SAMPLES);
    let counts = crate::doc::integrity::integrity_text(c);
    assert_eq!(counts, format!("{} ok, 0 disturbed, 100 cal_invalid, 0 no_attitude, 0 unjudged; longest disturbance 1.0 s, longest cal_invalid 1.0 s; no on-line hard-iron estimate", s.samples - 100));
    assert!(line.starts_with("RECALIBRATE") && line.contains(&format!("100 of {} logged samples", s.samples)) && line.contains("longest cal_invalid stretch 1.0 s"), "{line}");
    // In the JSON summary, typed.
    let json = serde_json::to_value(&s).unwrap();
    assert_eq!((json["integrity"]["states"]["cal_invalid"].as_u64(), json["recalibrate"]["cal_invalid_rows"].as_u64()), (Some(100), Some(100)));

    // The same log all ok: nothing said.
    let clean = board();
    clean.borrow_mut().integrity_at = |_| magcal_protocol::Integrity::Ok;
    let (s, _, _) = log_until(400, &mut connector(&clean, vec![]), |_| {});
    assert_eq!((s.integrity.states.of(IntegrityState::Ok), s.recalibrate), (s.samples, None));
    assert!(serde_json::to_value(&s).unwrap().get("recalibrate").is_none());
    // All disturbed (a passing object, the mock board's default): not evidence.
    let (s, _, _) = log_until(200, &mut connector(&board(), vec![]), |_| {});
    assert_eq!((s.integrity.states.of(IntegrityState::Disturbed), s.recalibrate), (s.samples, None));
}

/// The on-line hard iron over a log, from the board's `Health` at its two
/// ends: applied now, or applied (again) since the start, counts.
#[test]
fn the_hard_iron_over_a_log_is_read_from_the_boards_health() {
    use crate::board::log::logger::hard_iron_over_log;
    let base = Device::new(Boot { stored: None, challenge: 42 }).health(1000, &BoardCounters::default());
    assert_eq!(hard_iron_over_log(Some(&base), &base), (Some(false), None));
    let end = magcal_protocol::Health { uptime_ms: 9000, hard_iron_nt: Some([800.0, -50.0, 0.5]), hard_iron_applications: 1, ..base };
    assert_eq!(hard_iron_over_log(Some(&base), &end), (Some(true), Some([800.0, -50.0, 0.5])));
    // Applied before the log and not since: not this log's evidence.
    let start = magcal_protocol::Health { hard_iron_applications: 1, ..base };
    assert_eq!(hard_iron_over_log(Some(&start), &end).0, Some(false));
    // Applied now.
    assert_eq!(hard_iron_over_log(Some(&start), &magcal_protocol::Health { hard_iron_applied: true, ..end }).0, Some(true));
    // The board restarted (its uptime went back): applications since then count.
    assert_eq!(hard_iron_over_log(Some(&magcal_protocol::Health { uptime_ms: 20_000, ..start }), &end).0, Some(true));
    // A restart the uptime hides (the end's uptime past the start's): its
    // sample counter went back, and the applications since count too.
    let long_run = magcal_protocol::Health { device: magcal_protocol::DeviceCounters { samples: 5_000, ..start.device }, ..start };
    assert_eq!(hard_iron_over_log(Some(&long_run), &magcal_protocol::Health { device: magcal_protocol::DeviceCounters { samples: 40, ..end.device }, ..end }).0, Some(true));
}
