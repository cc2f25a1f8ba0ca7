//! The decoding, the definitions' check, the frames and a bag by hand.

use super::cdr::CdrError;
use super::frames::qmul;
use super::*;
use crate::data::import::rules;
use crate::data::import::{Format, ImportError, ImportOptions, Role};

/// The ROS quaternion `[x, y, z, w]` of a rotation by `deg` about `axis`.
fn q(axis: [f64; 3], deg: f64) -> [f64; 4] {
    let h = (deg / 2.0).to_radians();
    [axis[0] * h.sin(), axis[1] * h.sin(), axis[2] * h.sin(), h.cos()]
}

fn close(a: [f64; 3], b: [f64; 3]) -> bool {
    a.iter().zip(b).all(|(x, y)| rules::wrap180(x - y).abs() < 1e-9)
}

#[test]
fn orientations_by_hand() {
    // Level, facing east: ROS's identity (x forward = east).
    assert!(close(enu_flu_to_ned_frd_euler_deg([0.0, 0.0, 0.0, 1.0]).unwrap(), [0.0, 0.0, 90.0]));
    // Level, facing north: 90° about up in ENU.
    assert!(close(enu_flu_to_ned_frd_euler_deg(q([0.0, 0.0, 1.0], 90.0)).unwrap(), [0.0, 0.0, 0.0]));
    // Facing west: 180° about up.
    assert!(close(enu_flu_to_ned_frd_euler_deg(q([0.0, 0.0, 1.0], 180.0)).unwrap(), [0.0, 0.0, 270.0]));
    // Facing east, nose up 10°: about FLU's left axis by −10° (positive
    // about left turns the nose down).
    assert!(close(enu_flu_to_ned_frd_euler_deg(q([0.0, 1.0, 0.0], -10.0)).unwrap(), [0.0, 10.0, 90.0]));
    // Facing east, right side down 20°: about forward by +20° (the left
    // side rises).
    assert!(close(enu_flu_to_ned_frd_euler_deg(q([1.0, 0.0, 0.0], 20.0)).unwrap(), [20.0, 0.0, 90.0]));
    // Facing north, right side down 20°: yaw, then roll in the body.
    let [x, y, z, w] = q([0.0, 0.0, 1.0], 90.0);
    let [rx, ry, rz, rw] = q([1.0, 0.0, 0.0], 20.0);
    let [w2, x2, y2, z2] = qmul([w, x, y, z], [rw, rx, ry, rz]);
    assert!(close(enu_flu_to_ned_frd_euler_deg([x2, y2, z2, w2]).unwrap(), [20.0, 0.0, 0.0]));
    assert!(enu_flu_to_ned_frd_euler_deg([0.0; 4]).is_none());
}

#[test]
fn the_field_by_hand() {
    // The field north 20 000 nT, down 40 000 nT (ENU: (0, 2e-5, −4e-5) T).
    // Facing north, FLU reads forward = north, left = west, up: (2e-5, 0, −4e-5).
    assert_eq!(flu_to_frd([2e-5, 0.0, -4e-5]), [2e-5, 0.0, 4e-5]);
    // Facing east, left = north: (0, 2e-5, −4e-5) → right (south) negative, down positive.
    assert_eq!(flu_to_frd([0.0, 2e-5, -4e-5]), [0.0, -2e-5, 4e-5]);
}

/// A MagneticField in CDR: `little` or big endian, frame_id `frame`.
fn magnetic_field(little: bool, frame: &str, f: [f64; 3]) -> Vec<u8> {
    let mut b = vec![0, u8::from(little), 0, 0];
    let put = |b: &mut Vec<u8>, bytes: &[u8], align: usize| {
        while !(b.len() - 4).is_multiple_of(align) {
            b.push(0);
        }
        if little {
            b.extend(bytes.iter().rev());
        } else {
            b.extend(bytes);
        }
    };
    put(&mut b, &7i32.to_be_bytes(), 4);
    put(&mut b, &5u32.to_be_bytes(), 4);
    put(&mut b, &(frame.len() as u32 + 1).to_be_bytes(), 4);
    b.extend(frame.as_bytes());
    b.push(0);
    for v in f.into_iter().chain([0.0; 9]) {
        put(&mut b, &v.to_be_bytes(), 8);
    }
    b
}

#[test]
fn cdr_of_both_byte_orders_and_alignments() {
    for little in [true, false] {
        // frame_id lengths that leave every padding before the float64s.
        for frame in ["", "a", "ab", "abc", "abcd", "imu_link"] {
            let msg = magnetic_field(little, frame, [1e-5, -2e-5, 3.5e-5]);
            let s = MsgType::MagneticField.decode(&msg, 9).unwrap().unwrap();
            assert_eq!(s.stamp_ns, 7_000_000_005, "{little} {frame:?}");
            assert_eq!(s.v[..3], [1e-5, -2e-5, 3.5e-5], "{little} {frame:?}");
            assert_eq!(s.receive_ns, 9);
        }
    }
}

#[test]
fn short_and_strange_cdr_is_an_error_naming_the_field() {
    let msg = magnetic_field(true, "imu", [1.0, 2.0, 3.0]);
    for n in 0..msg.len() {
        let e = MsgType::MagneticField.decode(&msg[..n], 0).unwrap_err();
        assert!(matches!(e, CdrError::NoHeader | CdrError::Short { .. } | CdrError::BadString(_)), "{n}: {e}");
    }
    let e = MsgType::MagneticField.decode(&msg[..30], 0).unwrap_err();
    assert_eq!(e.to_string(), "ends inside magnetic_field (needs 8 bytes at 24 of 26)");
    let mut xcdr2 = msg.clone();
    xcdr2[1] = 7;
    assert_eq!(MsgType::MagneticField.decode(&xcdr2, 0).unwrap_err(), CdrError::Encapsulation(7));
    // A frame_id length of 4 GB: bounded, not allocated.
    let mut huge = msg.clone();
    huge[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    assert!(matches!(MsgType::MagneticField.decode(&huge, 0).unwrap_err(), CdrError::Short { field: "header.frame_id", .. }));
    // A string without its NUL.
    let mut no_nul = msg;
    no_nul[19] = b'x';
    assert_eq!(MsgType::MagneticField.decode(&no_nul, 0).unwrap_err(), CdrError::BadString("header.frame_id"));
}

#[test]
fn definitions_are_checked_field_by_field() {
    let rosbags_style = "std_msgs/Header header\ngeometry_msgs/Vector3 magnetic_field\nfloat64[9] magnetic_field_covariance\n\
        ================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
        ================================================================================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
        ================================================================================\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
    assert_eq!(check_definition(MAGNETIC_FIELD, rosbags_style), Ok(()));
    // rosbag2's own: the .msg files with comments and constants.
    let with_comments = "# Measurement of the Magnetic Field vector\n\nstd_msgs/Header header # timestamp\n\ngeometry_msgs/Vector3 magnetic_field # tesla\nfloat64[9] magnetic_field_covariance\n";
    assert_eq!(check_definition(MAGNETIC_FIELD, with_comments), Ok(()));
    let fix = "int8 STATUS_NO_FIX =  -1\nstd_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\nfloat64[9] position_covariance\nuint8 COVARIANCE_TYPE_UNKNOWN = 0\nuint8 position_covariance_type\n\
        ================================================================================\nMSG: sensor_msgs/NavSatStatus\nint8 STATUS_FIX = 0\nint8 status\nuint16 service\n";
    assert_eq!(check_definition(NAV_SAT_FIX, fix), Ok(()));
    // A float32 field where float64 is read.
    let e = check_definition(MAGNETIC_FIELD, &rosbags_style.replace("float64 y", "float32 y")).unwrap_err();
    assert!(e.contains("Vector3") && e.contains("float32 y"), "{e}");
    let e = check_definition(IMU, "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n").unwrap_err();
    assert!(e.starts_with("Imu:"), "{e}");
}

/// A message of a header (stamp `ns`) and `f64s` in little-endian CDR.
fn stamped(ns: i64, f64s: &[f64]) -> Vec<u8> {
    stamped_in(ns, "m", f64s)
}

/// The same with `frame` for `header.frame_id`.
fn stamped_in(ns: i64, frame: &str, f64s: &[f64]) -> Vec<u8> {
    let mut b = vec![0, 1, 0, 0];
    b.extend(((ns / 1_000_000_000) as i32).to_le_bytes());
    b.extend(((ns % 1_000_000_000) as u32).to_le_bytes());
    b.extend((frame.len() as u32 + 1).to_le_bytes());
    b.extend(frame.as_bytes());
    b.push(0);
    while (b.len() - 4) % 8 != 0 {
        b.push(0);
    }
    for v in f64s {
        b.extend(v.to_le_bytes());
    }
    b
}

/// An Imu: orientation `q` (x, y, z, w), rate `w`, covariances zero.
fn imu(ns: i64, q: [f64; 4], w: [f64; 3]) -> Vec<u8> {
    let mut v = q.to_vec();
    v.extend([0.0; 9]);
    v.extend(w);
    v.extend([0.0; 9 + 3 + 9]);
    stamped(ns, &v)
}

#[test]
fn a_bag_by_hand_topics_roles_and_frames() {
    let mut bag = Bag::new(Format::Mcap);
    let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
    let att = bag.topic("/imu", IMU, "cdr", None);
    let hdg = bag.topic("/ins/heading", IMU, "cdr", None);
    let other = bag.topic("/camera", "sensor_msgs/msg/Image", "cdr", None);
    // Facing north, level, turning right at 0.1 rad/s; the field 20 000 nT
    // north, 40 000 nT down; a GNSS compass's heading 2° (yaw 88° in ENU).
    let north = q([0.0, 0.0, 1.0], 90.0);
    for k in 0..3 {
        let ns = 1_000_000_000 * (10 + k);
        bag.message(mag, ns + 7, &stamped(ns, &[2e-5, 0.0, -4e-5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
        bag.message(att, ns + 7, &imu(ns, north, [0.0, 0.0, -0.1]));
        bag.message(hdg, ns + 7, &imu(ns, q([0.0, 0.0, 1.0], 88.0), [0.0; 3]));
        bag.message(other, ns, &[1, 2, 3]);
    }
    bag.message(mag, 0, &[0, 1, 0, 0, 1]);
    let im = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap();
    assert_eq!(im.column("t").unwrap(), [0.0, 1.0, 2.0]);
    assert_eq!(im.column("mx").unwrap()[0], 20_000.0);
    assert_eq!(im.column("mz").unwrap()[0], 40_000.0);
    assert!(im.column("ahrs_yaw_deg").unwrap()[0].abs() < 1e-9);
    assert!((im.column("ref_heading_deg").unwrap()[0] - 2.0).abs() < 1e-9);
    assert!((im.column("gz").unwrap()[0] - 0.1).abs() < 1e-15);
    assert_eq!(im.report.column_sources["ref_heading_deg"].role, Role::Reference);
    assert!(im.report.column_sources["ref_heading_deg"].from.contains("/ins/heading"));
    assert!(im.report.column_sources["roll_deg"].from.contains("/imu:"));
    assert_eq!(im.report.messages["/camera"], 3);
    assert_eq!(im.report.messages["/mag"], 4);
    assert_eq!(im.report.skipped["short_cdr_message: /mag"], 1);
    assert!(im.report.notes.iter().any(|n| n.contains("/mag: no definition stored")), "{:?}", im.report.notes);
    assert!(!im.report.notes.iter().any(|n| n.contains("_ned")), "{:?}", im.report.notes);
    let mut bag = Bag::new(Format::Mcap);
    let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
    bag.message(mag, 0, &stamped_in(1, "imu_NED", &[1e-5; 12]));
    let im = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap();
    assert!(im.report.notes.iter().any(|n| n.starts_with("/mag: a header.frame_id ends in _ned or _frd")), "{:?}", im.report.notes);
}

#[test]
fn a_bag_by_hand_refusals() {
    let mut bag = Bag::new(Format::Sqlite3);
    bag.topic("/imu", IMU, "cdr", None);
    let e = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap_err().to_string();
    assert_eq!(e, "no sensor_msgs/msg/MagneticField topic in the bag (topics: /imu (sensor_msgs/msg/Imu))");
    let mut bag = Bag::new(Format::Sqlite3);
    let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
    bag.message(mag, 0, &[0, 1, 0, 0]);
    let e = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap_err().to_string();
    assert!(e.starts_with("/mag: none of its 1 messages could be decoded"), "{e}");
    let mut bag = Bag::new(Format::Sqlite3);
    let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
    bag.message(mag, 0, &stamped(1, &[0.0; 12]));
    let opts = ImportOptions { topic: Some("/other".into()), ..ImportOptions::default() };
    let e = bag.finish(&opts, |e| ImportError::Mcap(e.into())).unwrap_err().to_string();
    assert_eq!(e, "--topic /other: not a sensor_msgs/msg/MagneticField topic of the bag (magnetometer topics: /mag)");
    let mut bag = Bag::new(Format::Sqlite3);
    let mag = bag.topic("/mag", MAGNETIC_FIELD, "json", None);
    bag.message(mag, 0, b"{}");
    assert!(bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap_err().to_string().contains("not CDR"));
}

#[test]
fn types_by_either_name() {
    assert_eq!(MsgType::from_name("sensor_msgs/MagneticField"), Some(MsgType::MagneticField));
    assert_eq!(MsgType::from_name(IMU), Some(MsgType::Imu));
    assert_eq!(MsgType::from_name("sensor_msgs/msg/Image"), None);
}
