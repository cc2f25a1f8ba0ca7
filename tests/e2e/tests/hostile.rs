//! A hostile link, end to end with the firmware in QEMU: garbage, truncated
//! and bit-flipped frames, floods, a disconnect mid-upload, replayed frames.
//! The board must stay responsive, count what it refused, and never run an
//! unverified or partial coefficient set.

use std::time::Duration;

use calib_core::conformance::SplitMix64;
use e2e_tests::boot;
use firmware::acquisition::COUNTS_PER_NT;
use host_tools::board::{BoardClient, ClientError};
use magcal_protocol::{self as proto, CoefficientSource, Coefficients, DeviceError as Remote, Request, RequestBody, Response, ResponseBody, MAX_FRAME_LEN, UNLOCK_XOR};

fn coefficients(bias_x: f32) -> Coefficients {
    let g = 1.0 / COUNTS_PER_NT;
    Coefficients {
        bias: [bias_x, -2000.0, 500.0],
        matrix: [[g, 0.0, 0.0], [0.0, g, 0.0], [0.0, 0.0, g]],
        swing: [0.0; 5],
        declination_rad: 0.05,
        field_nt: 48_730.0,
        current_bias_per_a: [0.0; 3],
        temp_ref_c: 20.0,
        temp_gain_per_c: [0.0; 3],
        inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION,
    }
}

fn frame(seq: u16, body: RequestBody) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME_LEN + 1];
    let n = proto::encode(&Request { seq, body }, &mut buf[1..]).unwrap();
    buf[..n + 1].to_vec()
}

/// Reads replies until one answers `seq` (or times out).
fn reply_to(link: &mut BoardClient<Box<dyn serialport::SerialPort>>, seq: u16) -> Option<ResponseBody> {
    for _ in 0..50 {
        match link.next_response(Duration::from_millis(200)).unwrap() {
            Some(Response { seq: Some(s), body }) if s == seq => return Some(body),
            Some(_) => {}
            None => {}
        }
    }
    None
}

/// Damaged frames in `bytes`, counted the way the protocol defines them
/// (each non-empty `0x00`-delimited chunk that fails COBS, the length bound,
/// the version or the CRC), for the assertion on the board's counter.
fn damaged_frames(bytes: &[u8]) -> u32 {
    let mut decoder = proto::FrameDecoder::new();
    let mut bad = 0;
    for &b in bytes {
        match decoder.push(b) {
            Some(Ok(body)) if proto::decode_body::<Request>(body).is_err() => bad += 1,
            Some(Ok(_)) => {}
            Some(Err(_)) => bad += 1,
            None => {}
        }
    }
    bad
}

#[test]
fn garbage_truncation_bit_flips_and_floods_leave_the_board_responsive() {
    let board = boot("hostile-noise");
    let mut link = BoardClient::open(board.link_port()).expect("open");
    link.identify().expect("identify");
    let mut rng = SplitMix64::new(5);

    // Unlock and stage a valid set first, so that a commit is possible and
    // only the damage can stop the bit-flipped one below.
    let staged = coefficients(1200.0);
    let challenge = link.status().unwrap().unlock_challenge;
    assert_eq!(link.request(RequestBody::Unlock { key: challenge ^ UNLOCK_XOR }).unwrap(), ResponseBody::Ack);
    assert_eq!(link.request(RequestBody::WriteCoefficients(staged)).unwrap(), ResponseBody::Ack);
    let before = link.status().unwrap();

    // 20 kB of random bytes, closed by a delimiter so that the last chunk is
    // judged before the next frame.
    let mut abuse: Vec<u8> = (0..20_000).map(|_| (rng.next_u64() & 0xFF) as u8).collect();
    abuse.push(0);
    // Truncated frames (each ended by a delimiter, as a line break would).
    let good = frame(900, RequestBody::Ping { nonce: 1 });
    for cut in [3, 6, good.len() - 2] {
        abuse.extend_from_slice(&good[..cut]);
        abuse.push(0);
    }
    // A bit-flipped commit of exactly the staged set's CRC: only the frame
    // check stands between it and the flash.
    let mut flipped = frame(901, RequestBody::Commit { crc: staged.crc() });
    flipped[4] ^= 0x20;
    abuse.extend_from_slice(&flipped);
    let expected_bad = damaged_frames(&abuse);
    link.send_raw(&abuse).unwrap();
    // A flood: 1000 pings without reading a reply.
    let flood: Vec<u8> = (0..1000u16).flat_map(|k| frame(1000 + k, RequestBody::Ping { nonce: u32::from(k) })).collect();
    link.send_raw(&flood).unwrap();

    // Still answers, and counted exactly the damaged frames it was sent
    // (measured: 84, as computed, on 2026-11-22).
    link.timeout = Duration::from_secs(3);
    assert_eq!(link.ping(0xABCD).expect("ping after the abuse"), 0xABCD);
    let h = link.status().unwrap();
    eprintln!("after the abuse: {} bad frames (expected {expected_bad}), {} requests, {} rx bytes dropped, {} tx frames dropped", h.board.bad_frames, h.board.requests, h.board.rx_dropped, h.board.tx_dropped);
    assert_eq!(h.board.rx_dropped, 0, "the board kept up with 115 200 baud: {h:?}");
    assert_eq!(h.board.bad_frames - before.board.bad_frames, expected_bad, "{h:?}");
    assert!(expected_bad > 70, "the abuse has damaged frames to count ({expected_bad})");
    assert_eq!(h.coefficient_source, CoefficientSource::Default, "the bit-flipped commit was not taken");

    // Positive control: the same commit, undamaged, does commit the staged set.
    let commit = link.request(RequestBody::Commit { crc: staged.crc() }).unwrap();
    assert!(matches!(commit, ResponseBody::Committed { .. }), "{commit:?}");
    let (back, source, _) = link.read_coefficients().unwrap();
    assert_eq!((back, source), (staged, CoefficientSource::Stored));
}

#[test]
fn a_disconnect_mid_upload_and_replayed_frames_never_change_the_coefficients() {
    let board = boot("hostile-upload");
    let port = board.link_port().to_string();
    let mut link = BoardClient::open(&port).expect("open");
    link.identify().expect("identify");

    // Stage a set, then drop the link before committing.
    let first = coefficients(1000.0);
    let challenge = link.status().unwrap().unlock_challenge;
    assert!(matches!(link.request(RequestBody::Unlock { key: challenge ^ UNLOCK_XOR }).unwrap(), ResponseBody::Ack));
    assert!(matches!(link.request(RequestBody::WriteCoefficients(first)).unwrap(), ResponseBody::Ack));
    drop(link);
    let mut link = BoardClient::open(&port).expect("reopen");
    let (_, source, _) = link.read_coefficients().unwrap();
    assert_eq!(source, CoefficientSource::Default, "a staged set is not in use");

    // A proper upload, recording the frames it sends.
    let c = coefficients(1500.0);
    let challenge = link.status().unwrap().unlock_challenge;
    let replay = [
        frame(7000, RequestBody::Unlock { key: challenge ^ UNLOCK_XOR }),
        frame(7001, RequestBody::WriteCoefficients(coefficients(9999.0))),
        frame(7002, RequestBody::Commit { crc: coefficients(9999.0).crc() }),
    ];
    let seq = link.upload_coefficients(&c).expect("upload");
    // Replay: the spent unlock key is refused, so nothing else gets through.
    let answers: Vec<Option<ResponseBody>> = replay
        .iter()
        .zip([7000u16, 7001, 7002])
        .map(|(f, s)| {
            link.send_raw(f).unwrap();
            reply_to(&mut link, s)
        })
        .collect();
    assert_eq!(answers[0], Some(ResponseBody::Error(Remote::BadKey)));
    assert_eq!(answers[1], Some(ResponseBody::Error(Remote::Locked)));
    assert_eq!(answers[2], Some(ResponseBody::Error(Remote::Locked)));
    let (back, source, back_seq) = link.read_coefficients().unwrap();
    assert_eq!((back, source, back_seq), (c, CoefficientSource::Stored, seq));

    // Coefficients outside physical bounds are refused even when unlocked.
    let mut bad = c;
    bad.matrix[1][1] *= 20.0;
    match link.upload_coefficients(&bad) {
        Err(ClientError::Remote(Remote::InvalidCoefficients)) => {}
        other => panic!("{other:?}"),
    }
    assert_eq!(link.read_coefficients().unwrap().0, c);
}
