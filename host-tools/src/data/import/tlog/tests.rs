//! The framing, the correction undone and the refusals, on logs written
//! by the `mavlink` crate.

use super::framing::{STX_V1, STX_V2, TIME_LEN};
use super::*;
use mavlink::dialects::ardupilotmega::{
    ATTITUDE_DATA, GpsFixType, HEARTBEAT_DATA, MavType, PARAM_VALUE_DATA, RAW_IMU_DATA, SCALED_IMU2_DATA,
};
use mavlink::{MAVLinkV1MessageRaw, MAVLinkV2MessageRaw, MavHeader};

const T0: u64 = 1_683_220_541_000_000;

fn record(t_us: u64, sysid: u8, compid: u8, msg: &MavMessage, v1: bool) -> Vec<u8> {
    let header = MavHeader { system_id: sysid, component_id: compid, sequence: 0 };
    let mut out = t_us.to_be_bytes().to_vec();
    if v1 {
        let mut raw = MAVLinkV1MessageRaw::new();
        raw.serialize_message(header, msg);
        out.extend_from_slice(raw.raw_bytes());
    } else {
        let mut raw = MAVLinkV2MessageRaw::new();
        raw.serialize_message(header, msg);
        out.extend_from_slice(raw.raw_bytes());
    }
    out
}

fn heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_SUBMARINE, autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, ..Default::default() })
}

fn param(name: &str, value: f32) -> MavMessage {
    let mut id = [0u8; 16];
    id[..name.len()].copy_from_slice(name.as_bytes());
    MavMessage::PARAM_VALUE(PARAM_VALUE_DATA { param_id: id.into(), param_value: value, ..Default::default() })
}

fn raw_imu(t_ms: u64, mag: [i16; 3], gyro: [i16; 3]) -> MavMessage {
    MavMessage::RAW_IMU(RAW_IMU_DATA {
        time_usec: t_ms * 1000,
        xgyro: gyro[0],
        ygyro: gyro[1],
        zgyro: gyro[2],
        xmag: mag[0],
        ymag: mag[1],
        zmag: mag[2],
        ..Default::default()
    })
}

/// A small log: heartbeat, offsets 10/20/30 (DIA 1, ODI 0 by default),
/// 5 RAW_IMU at 2 Hz and ATTITUDE at 10 Hz, alternating v1 and v2.
fn log() -> Vec<u8> {
    let mut b = Vec::new();
    let mut t = T0;
    let mut push = |m: MavMessage, b: &mut Vec<u8>| {
        t += 1000;
        let v1 = t.is_multiple_of(2000);
        b.extend(record(t, 1, 1, &m, v1));
    };
    push(heartbeat(), &mut b);
    push(MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID, ..Default::default() }), &mut b);
    for (name, v) in [("COMPASS_OFS_X", 10.0), ("COMPASS_OFS_Y", 20.0), ("COMPASS_OFS_Z", 30.0)] {
        push(param(name, v), &mut b);
    }
    for k in 0..25u64 {
        let yaw = (k as f32 * 0.1).sin();
        push(MavMessage::ATTITUDE(ATTITUDE_DATA { time_boot_ms: 1000 + 100 * k as u32, roll: 0.1, pitch: -0.05, yaw, ..Default::default() }), &mut b);
        if k % 5 == 0 {
            push(raw_imu(1000 + 100 * k, [110, 220, 330 + k as i16], [1, -2, 3]), &mut b);
        }
    }
    b
}

#[test]
fn a_log_is_read_and_the_correction_undone() {
    let bytes = log();
    assert!(looks_like(&bytes[..bytes.len().min(4096)]));
    // A first frame with a bad checksum does not hide the format.
    let mut first_bad = bytes.clone();
    first_bad[TIME_LEN + 12] ^= 0xFF;
    assert!(looks_like(&first_bad) && !matches!(super::record(&first_bad, 0), Record::Good(..)));
    assert!(!looks_like(b"t,mx,my,mz\n0,1,2,3\n") && !looks_like(&[]));
    let im = import(&bytes, &ImportOptions::default()).unwrap();
    assert_eq!(im.report.rows, 5);
    assert_eq!(im.report.messages["RAW_IMU"], 5);
    assert_eq!(im.report.messages["ATTITUDE"], 25);
    assert_eq!(im.report.messages["HEARTBEAT"], 2);
    assert_eq!(im.column("mx").unwrap(), [100.0; 5]);
    assert_eq!(im.column("mz").unwrap()[4], 300.0 + 20.0);
    assert_eq!(im.column("t").unwrap()[1], 1.5);
    assert!((im.column("gy").unwrap()[0] + 0.002).abs() < 1e-12);
    assert!((im.column("roll_deg").unwrap()[0] - 0.1f32.to_degrees() as f64).abs() < 1e-4);
    assert_eq!(im.report.column_sources["ahrs_yaw_deg"].role, Role::OwnEstimate);
    assert!(im.report.skipped.is_empty(), "{:?}", im.report.skipped);
    assert!(im.report.notes.iter().any(|n| n.contains("corrected one")), "{:?}", im.report.notes);
}

#[test]
fn corrupt_frames_are_skipped_and_counted() {
    let good = log();
    let clean = import(&good, &ImportOptions::default()).unwrap();
    // A flipped payload byte in the 6th record (a bad checksum), junk
    // between two records, and a record cut by the end of the file.
    let mut lens = Vec::new();
    let mut o = 0;
    while let Record::Good(_, len) = super::record(&good, o) {
        lens.push((o, len));
        o += len;
    }
    let (o5, l5) = lens[5];
    let mut bad = good[..o5].to_vec();
    let mut frame = good[o5..o5 + l5].to_vec();
    frame[TIME_LEN + 12] ^= 0x55;
    bad.extend(frame);
    bad.extend([0xFD, 0x00, 0x13, 0x37, 0xFE]);
    bad.extend(&good[o5 + l5..]);
    bad.extend(&good[lens[3].0..lens[3].0 + 12]);
    let im = import(&bad, &ImportOptions::default()).unwrap();
    assert_eq!(im.report.skipped["frames_with_bad_checksum"], 1);
    assert_eq!(im.report.skipped["bytes_skipped_to_resynchronise"], 5);
    assert_eq!(im.report.skipped["truncated_tail_bytes"], 12);
    let lost = clean.report.messages.values().sum::<usize>() - im.report.messages.values().sum::<usize>();
    assert_eq!(lost, 1);
}

#[test]
fn hostile_input_is_refused_by_name() {
    let e = import(b"t,mx,my,mz\n0,1,2,3\n", &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("not a MAVLink telemetry log"), "{e}");
    let bytes = log();
    let e = import(&bytes[..20], &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("truncated"), "{e}");
    // A start byte other than 0xFE/0xFD everywhere.
    let wrong: Vec<u8> = bytes.iter().map(|&b| if b == STX_V1 || b == STX_V2 { 0xFC } else { b }).collect();
    assert!(!looks_like(&wrong));
    assert!(import(&wrong, &ImportOptions::default()).unwrap_err().to_string().contains("not a MAVLink telemetry log"));
    // No magnetometer: only attitude.
    let mut no_mag = record(T0, 1, 1, &heartbeat(), false);
    no_mag.extend(record(T0 + 1, 1, 1, &MavMessage::ATTITUDE(ATTITUDE_DATA::default()), false));
    let e = import(&no_mag, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("no magnetometer") && e.contains("ATTITUDE 1"), "{e}");
    // An instance not in the log.
    let e = import(&bytes, &ImportOptions { instance: Some(2), ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("no instance 2") && e.contains("[0]"), "{e}");
    // No offsets anywhere: the raw field cannot be recovered.
    let mut no_ofs = record(T0, 1, 1, &heartbeat(), false);
    no_ofs.extend(record(T0 + 1, 1, 1, &raw_imu(1000, [1, 2, 3], [0; 3]), false));
    let e = import(&no_ofs, &ImportOptions::default()).unwrap_err().to_string();
    assert!(e.contains("COMPASS_OFS_X") && e.contains("SENSOR_OFFSETS"), "{e}");
    // Random bytes never panic.
    let mut x = 0x2545_F491_4F6C_DD1Du64;
    for n in [0usize, 1, 7, 9, 100, 5000] {
        let junk: Vec<u8> = (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                x as u8
            })
            .collect();
        let _ = import(&junk, &ImportOptions::default());
        let mut spliced = bytes.clone();
        spliced.splice(100..100, junk);
        let _ = import(&spliced, &ImportOptions::default());
    }
}

#[test]
fn other_systems_and_zero_fields_are_counted() {
    let mut b = log();
    // A second system's RAW_IMU, and a SCALED_IMU2 of no compass (zeros).
    b.extend(record(T0 + 900_000, 2, 1, &raw_imu(5000, [1, 1, 1], [0; 3]), false));
    b.extend(record(T0 + 900_001, 1, 1, &MavMessage::SCALED_IMU2(SCALED_IMU2_DATA { time_boot_ms: 5000, ..Default::default() }), false));
    let im = import(&b, &ImportOptions::default()).unwrap();
    assert_eq!(im.report.skipped["messages_from_other_systems"], 1);
    assert_eq!(im.report.rows, 5);
    let e = import(&b, &ImportOptions { instance: Some(1), ..Default::default() }).unwrap_err().to_string();
    assert!(e.contains("no instance 1"), "{e}");
}

#[test]
fn dates_are_civil() {
    assert_eq!(utc(0), "1970-01-01T00:00:00Z");
    assert_eq!(utc(1_683_220_541_055_000), "2023-05-04T17:15:41Z");
    assert_eq!(utc(951_782_400_000_000), "2000-02-29T00:00:00Z");
}

#[test]
fn a_gnss_compass_or_the_course_at_speed_is_the_reference() {
    use mavlink::dialects::ardupilotmega::{GPS_INPUT_DATA, GPS_RAW_INT_DATA};
    let gps = |t_ms: u64, vel_cm_s: u16, cog_cdeg: u16, yaw_cdeg: u16| {
        MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
            time_usec: t_ms * 1000,
            lat: 483_861_418,
            lon: -1_246_305_732,
            vel: vel_cm_s,
            cog: cog_cdeg,
            fix_type: GpsFixType::GPS_FIX_TYPE_3D_FIX,
            yaw: yaw_cdeg,
            ..Default::default()
        })
    };
    let mut b = log();
    let mut t = T0 + 10_000_000;
    for m in [
        gps(5_000, 30, 9_000, 0), // slow, no yaw: nothing
        raw_imu(5_100, [1, 1, 1], [0; 3]),
        gps(5_200, 150, 9_000, 0), // 1.5 m/s, no yaw: the course
        raw_imu(5_300, [1, 1, 2], [0; 3]),
        gps(5_400, 150, 9_000, 36_000), // a GNSS compass: north
        raw_imu(5_500, [1, 1, 3], [0; 3]),
    ] {
        t += 100_000;
        b.extend(record(t, 1, 1, &m, false));
    }
    let im = import(&b, &ImportOptions::default()).unwrap();
    let reference = im.column("ref_heading_deg").unwrap();
    let course = im.column("course_deg").unwrap();
    assert!(reference[5].is_nan() && course[5] == 90.0, "{reference:?}");
    assert_eq!(reference[6], 90.0);
    assert_eq!(reference[7], 0.0);
    assert_eq!(im.column("gps_speed_mps").unwrap()[6], 1.5);
    assert!((im.column("lat_deg").unwrap()[7] - 48.386_141_8).abs() < 1e-9);
    assert_eq!(im.report.column_sources["ref_heading_deg"].role, Role::Reference);
    assert!(im.report.column_sources["ref_heading_deg"].from.contains("GNSS compass"));
    // A GPS stamped with Unix time (not the autopilot's boot clock): counted, not used.
    let mut unix = b.clone();
    unix.extend(record(t + 1, 1, 1, &gps(1_700_000_000_000, 150, 9_000, 0), false));
    assert_eq!(import(&unix, &ImportOptions::default()).unwrap().report.skipped["gps_not_on_boot_clock"], 1);
    // A GPS fed over GPS_INPUT: its yaw is not a reference.
    b.extend(record(t + 1, 1, 220, &MavMessage::GPS_INPUT(GPS_INPUT_DATA::default()), false));
    let im = import(&b, &ImportOptions::default()).unwrap();
    assert_eq!(im.column("ref_heading_deg").unwrap()[7], 90.0, "the course at speed instead");
    assert!(im.report.notes.iter().any(|n| n.contains("GPS_INPUT by sysid/compid 1/220")), "{:?}", im.report.notes);
}
