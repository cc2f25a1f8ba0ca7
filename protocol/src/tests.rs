#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use super::*;
use crate::crc::CRC32;
use serde::Serialize;
use proptest::prelude::*;

fn frame_of<T: Serialize>(m: &T) -> ([u8; MAX_FRAME_LEN], usize) {
    let mut out = [0u8; MAX_FRAME_LEN];
    let n = encode(m, &mut out).unwrap();
    (out, n)
}

fn identity() -> Response {
    Response {
        seq: Some(7),
        body: ResponseBody::Identity(Identity {
            name: Name::try_from("magcal-fw").unwrap(),
            firmware_version: Name::try_from("0.1.0").unwrap(),
            protocol_version: PROTOCOL_VERSION,
            platform: Platform::Qemu,
            uptime_ms: 123_456,
        }),
    }
}

#[test]
fn crc_is_the_iso_hdlc_crc32() {
    // The standard check value of CRC-32/ISO-HDLC (the zip/Ethernet CRC).
    assert_eq!(CRC32.checksum(b"123456789"), 0xCBF4_3926);
}

#[test]
fn ping_frame_bytes_match_a_hand_encoding() {
    // Request { seq: 1, body: Ping { nonce: 2 } } in postcard is
    // varint(1) = 01, variant index 0 = 00, varint(2) = 02.
    let req = Request { seq: 1, body: RequestBody::Ping { nonce: 2 } };
    let (frame, n) = frame_of(&req);
    let mut decoded = [PROTOCOL_VERSION, 0x01, 0x00, 0x02, 0, 0, 0, 0];
    let crc = CRC32.checksum(&decoded[..4]).to_le_bytes();
    decoded[4..].copy_from_slice(&crc);
    // COBS by hand: the zero at index 2 splits the block; no other zeros
    // unless the CRC has some, so build it generically.
    let mut expect = [0u8; 16];
    let mut out = 0;
    let mut code_at = 0;
    out += 1;
    let mut code = 1u8;
    for &b in &decoded {
        if b == 0 {
            expect[code_at] = code;
            code_at = out;
            out += 1;
            code = 1;
        } else {
            expect[out] = b;
            out += 1;
            code += 1;
        }
    }
    expect[code_at] = code;
    expect[out] = 0;
    out += 1;
    assert_eq!(&frame[..n], &expect[..out]);
    assert!(!frame[..n - 1].contains(&0), "COBS must remove every zero");
}

#[test]
fn messages_round_trip() {
    let r = identity();
    let (f, n) = frame_of(&r);
    assert_eq!(decode::<Response>(&f[..n]).unwrap(), r);
    let q = Request { seq: 65535, body: RequestBody::Identify };
    let (f, n) = frame_of(&q);
    assert_eq!(decode::<Request>(&f[..n]).unwrap(), q);
    let e = Response { seq: None, body: ResponseBody::Error(DeviceError::Frame(FrameError::Crc)) };
    let (f, n) = frame_of(&e);
    assert_eq!(decode::<Response>(&f[..n]).unwrap(), e);
}

#[test]
fn every_single_bit_flip_is_detected() {
    let (frame, n) = frame_of(&identity());
    for byte in 0..n {
        for bit in 0..8 {
            let mut damaged = frame;
            damaged[byte] ^= 1 << bit;
            let mut dec = FrameDecoder::new();
            let mut got_ok = false;
            for &b in &damaged[..n] {
                if let Some(Ok(body)) = dec.push(b) {
                    if decode_body::<Response>(body).is_ok() {
                        got_ok = true;
                    }
                }
            }
            assert!(!got_ok, "flip of bit {bit} in byte {byte} was not detected");
        }
    }
}

#[test]
fn truncated_frames_are_errors_not_messages() {
    let (frame, n) = frame_of(&identity());
    for cut in 0..n - 1 {
        assert!(decode::<Response>(&frame[..cut]).is_err(), "cut at {cut}");
    }
}

#[test]
fn wrong_version_is_reported_as_such() {
    let mut raw = [0u8; 16];
    raw[0] = PROTOCOL_VERSION + 1;
    raw[1] = 0x01;
    raw[2] = 0x01; // Identify
    let crc = CRC32.checksum(&raw[..3]).to_le_bytes();
    raw[3..7].copy_from_slice(&crc);
    let mut enc = [0u8; 32];
    let n = cobs::try_encode(&raw[..7], &mut enc).unwrap();
    assert_eq!(
        decode::<Request>(&enc[..n]),
        Err(FrameError::UnsupportedVersion { got: PROTOCOL_VERSION + 1 })
    );
}

#[test]
fn overlong_input_is_dropped_and_the_receiver_resynchronises() {
    let mut dec = FrameDecoder::new();
    for _ in 0..MAX_FRAME_LEN + 10 {
        assert!(dec.push(0x55).is_none());
    }
    assert_eq!(dec.push(0).unwrap(), Err(FrameError::TooLong));
    let (frame, n) = frame_of(&identity());
    let mut got = None;
    for &b in &frame[..n] {
        if let Some(r) = dec.push(b) {
            got = Some(decode_body::<Response>(r.unwrap()).unwrap());
        }
    }
    assert_eq!(got.unwrap(), identity());
}

#[test]
fn empty_frames_are_ignored() {
    let mut dec = FrameDecoder::new();
    assert!(dec.push(0).is_none());
    assert!(dec.push(0).is_none());
    assert_eq!(dec.pending(), 0);
}

#[test]
fn encoder_reports_a_too_small_buffer() {
    let mut out = [0u8; 8];
    assert_eq!(encode(&identity(), &mut out), Err(FrameError::Overflow));
}

proptest! {
    #[test]
    fn arbitrary_bytes_never_panic_and_never_yield_oversized_frames(bytes in proptest::collection::vec(any::<u8>(), 0..2000)) {
        let mut dec = FrameDecoder::new();
        for b in bytes {
            if let Some(Ok(body)) = dec.push(b) {
                prop_assert!(body.len() <= MAX_FRAME_LEN);
                let _ = decode_body::<Request>(body);
                let _ = decode_body::<Response>(body);
            }
        }
    }

    #[test]
    fn any_ping_round_trips(seq in any::<u16>(), nonce in any::<u32>()) {
        let q = Request { seq, body: RequestBody::Ping { nonce } };
        let (f, n) = frame_of(&q);
        prop_assert!(n <= MAX_FRAME_LEN);
        prop_assert_eq!(decode::<Request>(&f[..n]).unwrap(), q);
    }
}

#[test]
fn the_largest_messages_fit_in_a_frame() {
    let c = Coefficients {
        bias: [f32::MAX; 3],
        matrix: [[f32::MIN; 3]; 3],
        swing: [1.0; 5],
        declination_rad: 0.1,
        field_nt: 48_000.0,
        current_bias_per_a: [f32::MAX; 3],
        temp_ref_c: f32::MIN,
        temp_gain_per_c: [f32::MAX; 3],
        inclination_rad: Coefficients::NO_INCLINATION,
    };
    let big = [
        Response { seq: Some(u16::MAX), body: ResponseBody::Coefficients { coefficients: c, source: CoefficientSource::Stored, seq: u32::MAX } },
        Response {
            seq: Some(u16::MAX),
            body: ResponseBody::Fit(FitReport { running: true, model: Some(OnboardModel::Full), samples: u32::MAX, coverage_pct: 100, residual_rms_nt: 1.0, estimate: Some(c) }),
        },
        Response {
            seq: Some(u16::MAX),
            body: ResponseBody::Status(Health {
                uptime_ms: u32::MAX,
                board: BoardCounters {
                    pairs: u32::MAX, saturated: u32::MAX, acq_errors: u32::MAX, overruns: u32::MAX, rx_dropped: u32::MAX, tx_dropped: u32::MAX, bad_frames: u32::MAX,
                    requests: u32::MAX, feed_updates: u32::MAX, max_acq_gap_ms: u32::MAX, store_saves: u32::MAX, max_store_ms: u32::MAX,
                },
                device: DeviceCounters { samples: u32::MAX, current_stale: u32::MAX, temp_missing: u32::MAX },
                mission_mode: true, unlocked: true,
                unlock_challenge: u32::MAX, coefficient_source: CoefficientSource::Default, coefficient_seq: u32::MAX,
                last_error: Some(DeviceError::Frame(FrameError::UnsupportedVersion { got: 255 })), output_rate_hz: 100, stream: StreamMode::Both,
                temp_c: Some(f32::MIN), env_degraded: true,
                integrity_samples: [u32::MAX; Integrity::COUNT], longest_disturbance_ms: u32::MAX, hard_iron_nt: Some([f32::MIN; 3]), hard_iron_applied: true, hard_iron_applications: u32::MAX,
            }),
        },
        Response { seq: None, body: ResponseBody::Sample(Sample { t_ms: u32::MAX, raw: Some([1.0; 3]), field_nt: Some([2.0; 3]), heading_rad: Some(3.0), saturated: true, feed_seq: Some(u32::MAX), temp_c: Some(f32::MIN), heading_sigma_deg: Some(f32::MAX), integrity: Integrity::NoAttitude }) },
    ];
    for r in big {
        let (f, n) = frame_of(&r);
        assert!(n <= MAX_FRAME_LEN);
        assert_eq!(decode::<Response>(&f[..n]).unwrap(), r);
    }
    for body in [RequestBody::WriteCoefficients(c), RequestBody::AttitudeEnv { roll_rad: f32::MIN, pitch_rad: f32::MAX, motor_current_a: f32::MIN }] {
        let q = Request { seq: u16::MAX, body };
        let (f, n) = frame_of(&q);
        assert!(n <= MAX_FRAME_LEN);
        assert_eq!(decode::<Request>(&f[..n]).unwrap(), q);
    }
    let feed = SensorFeed { seq: u32::MAX, field_nt: [f32::MAX; 3], offset_counts: Some([f32::MIN; 3]), temp_c: Some(f32::MIN) };
    let (f, n) = frame_of(&feed);
    assert_eq!(decode::<SensorFeed>(&f[..n]).unwrap(), feed);
    // The commit CRC is the CRC-32 of the postcard bytes, so both sides agree.
    let mut buf = [0u8; 128];
    assert_eq!(c.crc(), CRC32.checksum(postcard::to_slice(&c, &mut buf).unwrap()));
}

/// The wire format is pinned: these frames were encoded by protocol
/// version 2 (the ICD/framing split and the move to calib-core's
/// `ModelKind`, commit f08d520). Version 3 only appended fields and
/// variants, so a version-2 message's postcard payload is unchanged
/// (`FitStart`) or a prefix of its version-3 payload (`WriteCoefficients`:
/// the current and temperature terms follow), and the version byte moved
/// from 2 to 3 so that peers of different versions refuse each other's
/// frames instead of misreading them.
#[test]
fn version_3_appends_to_the_version_2_layout() {
    let mut buf = [0u8; MAX_FRAME_LEN];
    let c = Coefficients {
        bias: [1.0, -2.0, 3.5],
        matrix: [[0.03, 0.0, 0.001], [0.0, 0.028, 0.0], [0.001, 0.0, 0.029]],
        swing: [0.01, 0.0, -0.002, 0.0, 0.0],
        declination_rad: 0.05,
        field_nt: 48730.0,
        current_bias_per_a: [0.5, -0.25, 2.0],
        temp_ref_c: 20.0,
        temp_gain_per_c: [-0.003, -0.003, -0.0031],
        inclination_rad: Coefficients::NO_INCLINATION,
    };
    let golden_v2: [&[u8]; 2] = [
        &[5, 2, 7, 6, 2, 8, 90, 62, 71, 207, 50, 111, 134, 0],
        &[
            4, 2, 7, 11, 1, 3, 128, 63, 1, 1, 2, 192, 1, 7, 96, 64, 143, 194, 245, 60, 1, 1, 1, 5, 111, 18, 131, 58, 1, 1, 1, 5, 66, 96, 229, 60, 1, 1, 1, 5, 111, 18,
            131, 58, 1, 1, 1, 9, 104, 145, 237, 60, 10, 215, 35, 60, 1, 1, 1, 5, 111, 18, 3, 187, 1, 1, 1, 1, 1, 1, 1, 5, 205, 204, 76, 61, 8, 90, 62, 71, 115, 127,
            216, 72, 0,
        ],
    ];
    let bodies = [RequestBody::FitStart { model: OnboardModel::Full, field_nt: 48730.0 }, RequestBody::WriteCoefficients(c)];
    for (body, old) in bodies.into_iter().zip(golden_v2) {
        let mut old_decoded = [0u8; MAX_FRAME_LEN];
        let m = cobs::decode(&old[..old.len() - 1], &mut old_decoded).unwrap().frame_size();
        let (old_version, old_payload) = (old_decoded[0], &old_decoded[1..m - 4]);
        assert_eq!(old_version, 2);
        // A version-2 frame is refused, not misread.
        assert!(matches!(decode::<Request>(old), Err(FrameError::UnsupportedVersion { got: 2 })));
        let n = encode(&Request { seq: 7, body }, &mut buf).unwrap();
        let mut new_decoded = [0u8; MAX_FRAME_LEN];
        let k = cobs::decode(&buf[..n - 1], &mut new_decoded).unwrap().frame_size();
        assert_eq!(new_decoded[0], PROTOCOL_VERSION);
        assert!(new_decoded[1..k - 4].starts_with(old_payload), "the v2 payload is not a prefix of the v3 one");
    }
    // The appended terms are the last 28 bytes of the coefficients (7 f32 LE).
    let mut cb = [0u8; 128];
    let bytes = postcard::to_slice(&c, &mut cb).unwrap();
    assert_eq!(bytes.len(), 27 * 4);
    assert_eq!(&bytes[76..80], &0.5f32.to_le_bytes());
    assert_eq!(&bytes[88..92], &20.0f32.to_le_bytes());
}

/// Every coefficient set encodes within [`Coefficients::MAX_ENCODED_LEN`]:
/// postcard writes each `f32` as 4 fixed bytes whatever its value (no
/// varint for floats), so the extremes — largest, smallest, NaN, infinities,
/// subnormals — all take the same 27 × 4 bytes (27 `f32` fields counted in
/// the ICD: 3 + 9 + 5 + 1 + 1 + 3 + 1 + 3 + 1).
#[test]
fn the_largest_coefficient_set_encodes_within_max_encoded_len() {
    assert_eq!(Coefficients::MAX_ENCODED_LEN, 27 * 4);
    let set = |x: f32| Coefficients {
        bias: [x; 3],
        matrix: [[x; 3]; 3],
        swing: [x; 5],
        declination_rad: x,
        field_nt: x,
        current_bias_per_a: [x; 3],
        temp_ref_c: x,
        temp_gain_per_c: [x; 3],
        inclination_rad: Coefficients::NO_INCLINATION,
    };
    for x in [f32::MAX, f32::MIN, f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MIN_POSITIVE / 2.0, -0.0, 0.0] {
        let mut buf = [0u8; Coefficients::MAX_ENCODED_LEN];
        let n = postcard::to_slice(&set(x), &mut buf).map(|b| b.len());
        assert_eq!(n, Ok(Coefficients::MAX_ENCODED_LEN), "{x}");
    }
}

proptest! {
    #[test]
    fn any_coefficient_set_encodes_in_max_encoded_len(bits in any::<[u32; 27]>()) {
        let f = bits.map(f32::from_bits);
        let c = Coefficients {
            bias: [f[0], f[1], f[2]],
            matrix: [[f[3], f[4], f[5]], [f[6], f[7], f[8]], [f[9], f[10], f[11]]],
            swing: [f[12], f[13], f[14], f[15], f[16]],
            declination_rad: f[17],
            field_nt: f[18],
            current_bias_per_a: [f[19], f[20], f[21]],
            temp_ref_c: f[22],
            temp_gain_per_c: [f[23], f[24], f[25]],
            inclination_rad: f[26],
        };
        let mut buf = [0u8; Coefficients::MAX_ENCODED_LEN];
        let bytes = postcard::to_slice(&c, &mut buf).unwrap();
        prop_assert_eq!(bytes.len(), Coefficients::MAX_ENCODED_LEN);
    }
}

/// Version 4: the integrity state's wire tag is calib-core's code (postcard
/// writes a unit variant as its index, a varint), both ways, for every state
/// in `IntegrityState::ALL`; the codes published since version 4 and 5 stay
/// (a new state is appended); and `Nmea` was appended to `StreamMode` (tag
/// 4) so the earlier modes keep theirs.
#[test]
fn integrity_tags_are_calib_cores_and_nmea_is_appended() {
    for (i, s) in Integrity::ALL.into_iter().enumerate() {
        let mut buf = [0u8; 4];
        let bytes = postcard::to_slice(&s, &mut buf).unwrap();
        assert_eq!(bytes, &[s.code()]);
        assert_eq!(usize::from(s.code()), i);
        assert_eq!(postcard::from_bytes::<Integrity>(bytes).unwrap(), s);
        assert_eq!(Integrity::from_code(s.code()), Some(s));
    }
    // The tags as published (`docs/INTERFACES.md`, protocol versions 4–5).
    for (name, tag) in [("ok", 0u8), ("disturbed", 1), ("cal_invalid", 2), ("no_attitude", 3), ("unjudged", 4)] {
        assert_eq!(Integrity::from_name(name).map(Integrity::code), Some(tag), "{name}");
    }
    let past_the_end = u8::try_from(Integrity::COUNT).unwrap();
    assert!(postcard::from_bytes::<Integrity>(&[past_the_end]).is_err());
    assert_eq!(Integrity::from_code(past_the_end), None);
    let mut buf = [0u8; 4];
    assert_eq!(postcard::to_slice(&StreamMode::Both, &mut buf).unwrap(), &[3]);
    assert_eq!(postcard::to_slice(&StreamMode::Nmea, &mut buf).unwrap(), &[4]);
}

/// The on-board models' wire bytes are the variant indices calib-core's
/// `ModelKind` had on the wire before (Sphere 0, Axis 1, Full 2, Gyro 4:
/// postcard wrote an enum's index as a varint, one byte below 128), so the
/// encoding did not change; the bytes of models the board does not fit
/// (3, once triangular; 5, attitude) no longer decode at all.
#[test]
fn on_board_models_keep_their_wire_bytes() {
    let mut buf = [0u8; 4];
    for (m, byte) in [(OnboardModel::Sphere, 0u8), (OnboardModel::Axis, 1), (OnboardModel::Full, 2), (OnboardModel::Gyro, 4)] {
        assert_eq!(postcard::to_slice(&m, &mut buf).unwrap(), &[byte]);
        assert_eq!(postcard::from_bytes::<OnboardModel>(&[byte]).unwrap(), m);
        assert_eq!(OnboardModel::of_kind(m.kind()), Some(m));
    }
    for byte in [3u8, 5, 127, 200] {
        assert!(postcard::from_bytes::<OnboardModel>(&[byte]).is_err(), "{byte}");
    }
    assert_eq!(OnboardModel::of_kind(ModelKind::Triangular), None);
}

/// One request of every endpoint (a sample value of each).
fn one_of_each() -> [RequestBody; 16] {
    use crate::endpoint as ep;
    let c = Coefficients {
        bias: [1.0; 3],
        matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        swing: [0.0; 5],
        declination_rad: 0.0,
        field_nt: 48_000.0,
        current_bias_per_a: [0.0; 3],
        temp_ref_c: 25.0,
        temp_gain_per_c: [0.0; 3],
        inclination_rad: Coefficients::NO_INCLINATION,
    };
    [
        ep::Ping { nonce: 9 }.into_body(),
        ep::Identify.into_body(),
        ep::Status.into_body(),
        ep::SetStream(StreamMode::Both).into_body(),
        ep::SetOutputRate { hz: 10 }.into_body(),
        ep::Attitude { roll_rad: 0.1, pitch_rad: 0.2 }.into_body(),
        ep::FitStart { model: OnboardModel::Full, field_nt: 48_000.0 }.into_body(),
        ep::FitStop.into_body(),
        ep::FitQuery.into_body(),
        ep::ReadCoefficients.into_body(),
        ep::Unlock { key: 3 }.into_body(),
        ep::WriteCoefficients(c).into_body(),
        ep::Commit { crc: 5 }.into_body(),
        ep::SetMissionMode { enabled: true }.into_body(),
        ep::Motion { roll_rad: 0.1, pitch_rad: 0.2, rate_rad_s: [0.0, 0.0, 0.3] }.into_body(),
        ep::AttitudeEnv { roll_rad: 0.1, pitch_rad: 0.2, motor_current_a: 4.0 }.into_body(),
    ]
}

/// The endpoint table keeps every request's wire tag: the tags are the
/// variant order of the hand-written request enum it replaced (protocol 6),
/// and postcard writes each request's code as its first byte.
#[test]
fn endpoint_codes_are_the_wire_tags_of_protocol_6() {
    let before = [
        "Ping", "Identify", "Status", "SetStream", "SetOutputRate", "Attitude", "FitStart", "FitStop", "FitQuery",
        "ReadCoefficients", "Unlock", "WriteCoefficients", "Commit", "SetMissionMode", "Motion", "AttitudeEnv",
    ];
    assert_eq!(ENDPOINTS.len(), before.len());
    for (i, (row, name)) in ENDPOINTS.iter().zip(before).enumerate() {
        assert_eq!((row.name, usize::from(row.code)), (name, i));
    }
    let mut seen = [false; 16];
    for body in one_of_each() {
        let mut buf = [0u8; MAX_PAYLOAD_LEN];
        let bytes = postcard::to_slice(&body, &mut buf).unwrap();
        let call = Call::from(body.clone());
        assert_eq!(bytes[0], call.code(), "{body:?}");
        seen[usize::from(call.code())] = true;
        let back: RequestBody = postcard::from_bytes(bytes).unwrap();
        assert_eq!(back, body);
    }
    assert!(seen.iter().all(|s| *s), "one request of each endpoint");
}

/// The answer kind of a response (exhaustive: a new response variant must
/// be placed here, as an endpoint's answer or as one of the two that answer
/// no particular request).
fn kind(body: &ResponseBody) -> Option<&'static str> {
    match body {
        ResponseBody::Pong { .. } => Some("Pong"),
        ResponseBody::Identity(_) => Some("Identity"),
        ResponseBody::Ack => Some("Ack"),
        ResponseBody::Status(_) => Some("Status"),
        ResponseBody::Fit(_) => Some("Fit"),
        ResponseBody::Coefficients { .. } => Some("Coefficients"),
        ResponseBody::Committed { .. } => Some("Committed"),
        ResponseBody::Error(_) | ResponseBody::Sample(_) => None,
    }
}

/// Every answer kind answers some endpoint, each endpoint's kind is a
/// response variant, and each typed answer goes to its variant and back
/// (and refuses another kind).
#[test]
fn every_answer_kind_answers_an_endpoint_and_round_trips() {
    use crate::endpoint::{Ack, Committed, InUse, Pong, Reply};
    fn round_trip<R: Reply + PartialEq + core::fmt::Debug + Clone>(r: R) -> &'static str {
        let body = r.clone().into_body();
        assert_eq!(kind(&body), Some(R::KIND));
        assert_eq!(R::from_body(body), Ok(r));
        assert_eq!(R::from_body(ResponseBody::Error(DeviceError::Unsupported)), Err(ResponseBody::Error(DeviceError::Unsupported)));
        R::KIND
    }
    let identity = match identity().body {
        ResponseBody::Identity(i) => i,
        _ => unreachable!(),
    };
    let report = FitReport { running: true, model: Some(OnboardModel::Axis), samples: 3, coverage_pct: 4, residual_rms_nt: 5.0, estimate: None };
    let c = match one_of_each()[11] {
        RequestBody::WriteCoefficients(c) => c,
        _ => unreachable!(),
    };
    let health = Health {
        uptime_ms: 1,
        board: BoardCounters::default(),
        device: DeviceCounters::default(),
        mission_mode: false,
        unlocked: true,
        unlock_challenge: 3,
        coefficient_source: CoefficientSource::Default,
        coefficient_seq: 0,
        last_error: None,
        output_rate_hz: 10,
        stream: StreamMode::Off,
        temp_c: None,
        env_degraded: false,
        integrity_samples: [0; Integrity::COUNT],
        longest_disturbance_ms: 0,
        hard_iron_nt: None,
        hard_iron_applied: false,
        hard_iron_applications: 0,
    };
    let kinds = [
        round_trip(health),
        round_trip(Ack),
        round_trip(Pong { nonce: 1 }),
        round_trip(identity),
        round_trip(report),
        round_trip(InUse { coefficients: c, source: CoefficientSource::Stored, seq: 2 }),
        round_trip(Committed { seq: 7 }),
    ];
    for k in kinds {
        assert!(ENDPOINTS.iter().any(|e| e.response == k), "{k} answers no endpoint");
    }
    for e in ENDPOINTS {
        assert!(kinds.contains(&e.response), "{}: {}", e.name, e.response);
    }
}
