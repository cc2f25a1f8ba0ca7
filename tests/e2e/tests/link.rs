//! The host link end to end: firmware in QEMU, USART1 on a pty, magcal's
//! serial code on the host.

use std::process::Command;
use std::time::Duration;

use e2e_tests::{boot, magcal_bin};
use host_tools::board::{BoardClient, ClientError};
use magcal_protocol::{self as proto, FrameError, DeviceError as Remote, Platform, Response, ResponseBody};

#[test]
fn identify_over_the_pty() {
    let board = boot("identify");
    let mut link = BoardClient::open(board.link_port()).expect("open pty");
    let id = link.identify().expect("identify");
    assert_eq!(id.name.as_str(), "magcal-fw");
    assert_eq!(id.firmware_version.as_str(), env!("CARGO_PKG_VERSION"));
    assert_eq!(id.protocol_version, proto::PROTOCOL_VERSION);
    assert_eq!(id.platform, Platform::Qemu);
    // Ping echoes arbitrary nonces, so replies really come from the board.
    for nonce in [0, 1, 0xFFFF_FFFF, 0x1234_5678] {
        assert_eq!(link.ping(nonce).expect("ping"), nonce);
    }
}

#[test]
fn a_malformed_frame_is_answered_with_a_typed_error_and_the_link_recovers() {
    let board = boot("malformed");
    let mut link = BoardClient::open(board.link_port()).expect("open pty");
    // Make sure the board is listening before sending garbage.
    link.identify().expect("identify");

    // A COBS-valid 7-byte frame whose CRC is wrong.
    link.send_raw(&[0x00, 0x08, 1, 2, 3, 4, 5, 6, 7, 0x00]).expect("send");
    let reply = link.next_response(Duration::from_secs(3)).expect("read").expect("a reply");
    assert_eq!(
        reply,
        Response { seq: None, body: ResponseBody::Error(Remote::Frame(FrameError::Crc)) }
    );

    // Too long without a delimiter.
    let mut junk = vec![0x41u8; 600];
    junk.push(0);
    link.send_raw(&junk).expect("send");
    let reply = link.next_response(Duration::from_secs(3)).expect("read").expect("a reply");
    assert_eq!(reply.body, ResponseBody::Error(Remote::Frame(FrameError::TooLong)));

    // The board is still fine.
    assert_eq!(link.ping(99).expect("ping after garbage"), 99);
}

#[test]
fn the_magcal_cli_identifies_the_board() {
    let board = boot("cli");
    let out = Command::new(magcal_bin())
        .args(["identify", "--json", "--port", board.link_port()])
        .output()
        .expect("run magcal");
    assert!(out.status.success(), "magcal failed: {}", String::from_utf8_lossy(&out.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stdout is one JSON document");
    assert_eq!(doc["name"], "magcal-fw");
    assert_eq!(doc["platform"], "qemu");
    assert_eq!(doc["protocol_version"], proto::PROTOCOL_VERSION);
}

#[test]
fn the_cli_reports_a_missing_port_in_one_line() {
    let out = Command::new(magcal_bin())
        .args(["identify", "--port", "/dev/does-not-exist"])
        .output()
        .expect("run magcal");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("cannot open serial port /dev/does-not-exist"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(out.stdout.is_empty());
}

#[test]
fn silence_is_a_timeout_not_a_hang() {
    // A pty nobody answers on: the link gives up with a typed error.
    use serialport::SerialPort;
    let (master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let name = slave.name().expect("pty name");
    drop(slave);
    let mut link = BoardClient::open(&name).expect("open");
    link.timeout = Duration::from_millis(200);
    link.attempts = 2;
    assert!(matches!(link.identify(), Err(ClientError::Timeout { attempts: 2, .. })));
    drop(master);
}
