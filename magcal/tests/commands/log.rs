//! `magcal log`'s refusals from the command line, each one line on stderr,
//! nothing on stdout, and no file left behind (or the existing one kept).
//! Logging itself is tested against the in-memory board
//! (host-tools `session::tests::log`) and the QEMU board (tests/e2e).

use std::process::Output;
use super::{magcal};

fn one_line_failure(out: &Output) -> String {
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success() && out.stdout.is_empty(), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    err
}

#[test]
fn a_port_that_cannot_be_opened_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out_csv = dir.path().join("board.csv");
    let out = magcal(&["log", "--port", "/dev/does-not-exist", "--out", out_csv.to_str().unwrap()]);
    let err = one_line_failure(&out);
    assert!(err.contains("cannot open serial port /dev/does-not-exist"), "{err}");
    assert!(!out_csv.exists(), "no empty log left behind");
}

#[test]
fn a_port_where_no_board_answers_is_refused() {
    use serialport::SerialPort;
    // A pty nobody answers on (its master end held open, silent).
    let (master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let name = slave.name().expect("pty name");
    let dir = tempfile::tempdir().unwrap();
    let out_csv = dir.path().join("board.csv");
    let out = magcal(&["log", "--port", &name, "--out", out_csv.to_str().unwrap(), "--duration-s", "1"]);
    let err = one_line_failure(&out);
    assert!(err.contains("no board answers on the port"), "{err}");
    assert!(!out_csv.exists());
    drop((master, slave));
}

#[test]
fn an_existing_output_is_refused_before_the_port_is_touched() {
    let dir = tempfile::tempdir().unwrap();
    let out_csv = dir.path().join("board.csv");
    std::fs::write(&out_csv, "t,mx,my,mz\n1,2,3,4\n").unwrap();
    // The port does not exist either: the file is checked first.
    let out = magcal(&["log", "--port", "/dev/does-not-exist", "--out", out_csv.to_str().unwrap()]);
    let err = one_line_failure(&out);
    assert!(err.contains("exists") && err.contains("--force"), "{err}");
    assert_eq!(std::fs::read_to_string(&out_csv).unwrap(), "t,mx,my,mz\n1,2,3,4\n");
    // With --force the file is taken (and the port's refusal comes next).
    let out = magcal(&["log", "--port", "/dev/does-not-exist", "--out", out_csv.to_str().unwrap(), "--force"]);
    assert!(one_line_failure(&out).contains("cannot open serial port"));
}

#[test]
fn out_of_range_options_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out_csv = dir.path().join("board.csv");
    for (flag, value) in [("--rate-hz", "0"), ("--rate-hz", "101"), ("--duration-s", "0")] {
        let out = magcal(&["log", "--port", "/dev/null", "--out", out_csv.to_str().unwrap(), flag, value]);
        assert!(!out.status.success(), "{flag} {value}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(flag), "{flag} {value}: {err}");
        assert!(!out_csv.exists());
    }
}
