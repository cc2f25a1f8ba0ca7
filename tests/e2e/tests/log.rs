//! `magcal log` against the firmware in QEMU: the board's own stream, its
//! own clock and its own `Health` counters, through the real binary.

use std::process::{Command, Stdio};
use std::time::Duration;

use e2e_tests::{boot, magcal_bin};
use host_tools::board::{LogEnd, LogSummary};
use host_tools::data::BoardLog;

/// The two tests time the board's stream: one QEMU at a time, so that they
/// do not share the two cores with each other.
static ONE_BOARD: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn steps_ms(log: &BoardLog) -> Vec<i64> {
    log.t_s.windows(2).map(|w| ((w[1] - w[0]) * 1000.0).round() as i64).collect()
}

#[test]
fn the_board_stream_is_logged_on_its_clock_and_ctrl_c_ends_it_cleanly() {
    let _one = ONE_BOARD.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let board = boot("log");
    let dir = std::env::temp_dir().join(format!("magcal-e2e-log-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let out_csv = dir.join("board.csv");
    let _ = std::fs::remove_file(&out_csv);

    // A timed log at 50 Hz.
    let out = Command::new(magcal_bin())
        .args(["log", "--port", board.link_port(), "--out", out_csv.to_str().unwrap(), "--duration-s", "4", "--rate-hz", "50", "--json"])
        .output()
        .expect("run magcal");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s: LogSummary = serde_json::from_slice(&out.stdout).expect("stdout is the summary");
    let log = BoardLog::read(&out_csv).expect("merge reads the board log");
    eprintln!("timed log: {s:?}");
    assert_eq!(s.ended, LogEnd::Duration);
    assert_eq!(log.t_s.len() as u64, s.samples);
    assert!(s.samples > 20, "{s:?}");
    // The board's 50 Hz: every step 20 ms on its clock (the firmware's
    // output timer; a stamp may land a few ms late when QEMU, whose clock
    // follows the host's, is descheduled), none missing on a healthy link.
    let steps = steps_ms(&log);
    let mean_ms = steps.iter().sum::<i64>() as f64 / steps.len() as f64;
    assert!(steps.iter().all(|&d| (d - 20).abs() <= 5) && (mean_ms - 20.0).abs() < 0.2, "{steps:?}");
    assert_eq!((s.link_drops, s.gaps.len()), (0, 0), "{s:?}");
    // The board's own count over the same span: all it produced arrived,
    // give or take the samples on the wire at the two Status requests.
    let produced = s.board_samples_produced.expect("Health before and after");
    assert!((i64::from(produced) - s.samples as i64).abs() <= 3, "board produced {produced}, logged {}", s.samples);
    assert_eq!(s.board_tx_dropped, Some(0));
    assert!(log.mag.iter().all(|m| m.iter().all(|v| v.is_finite())));
    // Every row's integrity state counted; the board's Health read at the
    // end gives the on-line hard iron (none applied on a fresh board), and
    // nothing says "recalibrate".
    assert_eq!(s.integrity.states.total(), s.samples, "{s:?}");
    assert_eq!((s.integrity.hard_iron_applied, s.recalibrate), (Some(false), None), "{s:?}");

    // Ctrl-C: an open-ended log interrupted; the file is complete.
    std::fs::remove_file(&out_csv).unwrap();
    let child = Command::new(magcal_bin())
        .args(["log", "--port", board.link_port(), "--out", out_csv.to_str().unwrap(), "--json"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn magcal");
    std::thread::sleep(Duration::from_secs(3));
    let killed = Command::new("kill").args(["-INT", &child.id().to_string()]).status().expect("kill -INT");
    assert!(killed.success());
    let out = child.wait_with_output().expect("magcal exits");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s: LogSummary = serde_json::from_slice(&out.stdout).expect("stdout is the summary");
    assert_eq!(s.ended, LogEnd::Interrupted);
    let text = std::fs::read_to_string(&out_csv).unwrap();
    assert!(text.ends_with('\n'), "the last row is whole");
    let log = BoardLog::read(&out_csv).unwrap();
    assert_eq!(log.t_s.len() as u64, s.samples);
    assert!(s.samples > 20, "{s:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A relay between QEMU's pty and a pty of our own that `magcal log` opens
/// through a symlink: closing our pty is a cable pulled out; a new pty
/// behind the same path is the cable plugged back in. The board keeps
/// streaming meanwhile and those samples are lost, as on a real link.
struct Relay {
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

/// A fresh pty; `link` (a symlink) is made to point at its slave side, which
/// only `magcal` opens (serialport locks what it opens).
fn plug(link: &std::path::Path) -> serialport::TTYPort {
    use serialport::SerialPort;
    let (mut master, slave) = serialport::TTYPort::pair().expect("a pty pair");
    master.set_timeout(Duration::from_millis(2)).unwrap();
    let name = slave.name().expect("the slave's path");
    drop(slave);
    let tmp = link.with_extension("new");
    let _ = std::fs::remove_file(&tmp);
    std::os::unix::fs::symlink(&name, &tmp).unwrap();
    std::fs::rename(&tmp, link).unwrap();
    master
}

impl Relay {
    /// Relays `board` ↔ `link`, pulling the cable for `down` after `up`.
    fn start(board: &str, link: &std::path::Path, up: Duration, down: Duration) -> Self {
        use std::io::{Read, Write};
        use std::sync::atomic::Ordering;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let mut qemu = serialport::new(board, 115_200).timeout(Duration::from_millis(2)).open_native().expect("open QEMU's pty");
        let mut pair = Some(plug(link));
        let link = link.to_path_buf();
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let t0 = std::time::Instant::now();
            let mut buf = [0u8; 512];
            let mut replugged = false;
            while !flag.load(Ordering::Relaxed) {
                let t = t0.elapsed();
                if pair.is_some() && !replugged && t >= up {
                    pair = None; // pulled out: both ends closed
                } else if pair.is_none() && t >= up + down {
                    pair = Some(plug(&link));
                    replugged = true;
                }
                if let Ok(n) = qemu.read(&mut buf) {
                    if let Some(m) = pair.as_mut() {
                        let _ = m.write_all(&buf[..n]);
                    }
                }
                if let Some(m) = pair.as_mut() {
                    if let Ok(n) = m.read(&mut buf) {
                        let _ = qemu.write_all(&buf[..n]);
                    }
                }
            }
        });
        Self { stop, thread: Some(thread) }
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[test]
fn a_pulled_cable_is_a_reported_gap_and_logging_goes_on_with_the_real_board() {
    let _one = ONE_BOARD.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let board = boot("log-drop");
    let dir = std::env::temp_dir().join(format!("magcal-e2e-log-drop-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let out_csv = dir.join("board.csv");
    let link = dir.join("link");
    let (up, down) = (Duration::from_secs(3), Duration::from_secs(2));
    let relay = Relay::start(board.link_port(), &link, up, down);
    let out = Command::new(magcal_bin())
        .args(["log", "--port", link.to_str().unwrap(), "--out", out_csv.to_str().unwrap(), "--duration-s", "10", "--rate-hz", "50", "--json"])
        .output()
        .expect("run magcal");
    drop(relay);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let s: LogSummary = serde_json::from_slice(&out.stdout).expect("stdout is the summary");
    eprintln!("log across a pulled cable: {s:?}");
    let log = BoardLog::read(&out_csv).expect("merge reads the board log");
    assert_eq!(log.t_s.len() as u64, s.samples);
    // One drop, one gap on the board's clock at least as long as the cable
    // was out (plus detection and the reconnect's backoff), the rest of the
    // stream whole at 20 ms.
    assert_eq!(s.link_drops, 1, "{s:?}");
    assert_eq!(s.gaps.len(), 1, "{s:?}");
    let gap = &s.gaps[0];
    assert!(gap.length_s >= down.as_secs_f64() && gap.length_s < down.as_secs_f64() + 8.0, "{gap:?}");
    assert_eq!(gap.missing_samples, (gap.length_s * 50.0).round() as u64 - 1, "{gap:?}");
    let steps = steps_ms(&log);
    // (Stamps jitter by a few ms here: QEMU's clock follows the host's, and
    // the relay, QEMU and magcal share two cores.)
    assert_eq!(steps.iter().filter(|&&d| d > 30).count(), 1, "{steps:?}");
    let rest: Vec<i64> = steps.iter().copied().filter(|&d| d <= 30).collect();
    let mean_ms = rest.iter().sum::<i64>() as f64 / rest.len() as f64;
    assert!((mean_ms - 20.0).abs() < 0.2, "mean step {mean_ms} ms: {steps:?}");
    // Samples on both sides of the gap.
    let first = s.first_t_s.unwrap();
    let last = s.last_t_s.unwrap();
    assert!(gap.after_t_s - first > 1.0 && last - (gap.after_t_s + gap.length_s) > 1.0, "{s:?}");
    let text = std::fs::read_to_string(&out_csv).unwrap();
    assert!(text.ends_with('\n'));
    let _ = std::fs::remove_dir_all(&dir);
}
