//! `magcal log` against the firmware in QEMU: the board's own stream, its
//! own clock and its own `Health` counters, through the real binary.

use std::process::{Command, Stdio};
use std::time::Duration;

use e2e_tests::{boot, magcal_bin};
use host_tools::board::log::{LogEnd, LogSummary};
use host_tools::data::merge::BoardLog;

fn steps_ms(log: &BoardLog) -> Vec<i64> {
    log.t_s.windows(2).map(|w| ((w[1] - w[0]) * 1000.0).round() as i64).collect()
}

#[test]
fn the_board_stream_is_logged_on_its_clock_and_ctrl_c_ends_it_cleanly() {
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
    // output timer), none missing on a healthy link.
    let steps = steps_ms(&log);
    assert!(steps.iter().all(|&d| d == 20), "{steps:?}");
    assert_eq!((s.link_drops, s.gaps.len()), (0, 0), "{s:?}");
    // The board's own count over the same span: all it produced arrived,
    // give or take the samples on the wire at the two Status requests.
    let produced = s.board_samples_produced.expect("Health before and after");
    assert!((i64::from(produced) - s.samples as i64).abs() <= 3, "board produced {produced}, logged {}", s.samples);
    assert_eq!(s.board_tx_dropped, Some(0));
    assert!(log.mag.iter().all(|m| m.iter().all(|v| v.is_finite())));

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
