//! Refusals, resynchronisation and the first IMU's gyro on logs written by
//! hand.

use super::reader::field_size;
use super::*;
use crate::data::table::col;

fn fmt(type_id: u8, name: &str, format: &str, labels: &str) -> Vec<u8> {
    let len: usize = 3 + format.chars().map(|c| field_size(c).unwrap()).sum::<usize>();
    let mut b = vec![0xA3, 0x95, FMT_TYPE, type_id, len as u8];
    let mut pad = |s: &str, n: usize| {
        let mut v = s.as_bytes().to_vec();
        v.resize(n, 0);
        b.extend(v);
    };
    pad(name, 4);
    pad(format, 16);
    pad(labels, 64);
    b
}

#[test]
fn refusals_and_resynchronisation() {
    assert!(matches!(import(b"hello", &ImportOptions::default()), Err(DataFlashError::NotDataFlash { .. })));
    // A FMT whose length disagrees with its format.
    let mut bad = fmt(200, "XYZ", "Qh", "TimeUS,A");
    bad[4] = 20;
    let e = import(&bad, &ImportOptions::default()).unwrap_err();
    assert!(e.to_string().contains("makes 13 bytes, the FMT says 20"), "{e}");
    // A log with a MAG format, junk bytes, then one MAG of instance 1 only.
    let mut log = fmt(201, "MAG", "QBhhhhhh", "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ");
    log.extend([1, 2, 3]);
    log.extend([0xA3, 0x95, 201]);
    log.extend(5_000_000u64.to_le_bytes());
    log.push(1);
    for v in [100i16, 200, 300, 10, 20, 30] {
        log.extend(v.to_le_bytes());
    }
    let e = import(&log, &ImportOptions::default()).unwrap_err();
    assert!(matches!(&e, DataFlashError::NoMag { instance: 0, found } if found == &vec![1]), "{e}");
    let ok = import(&log, &ImportOptions { mag_instance: 1, ..Default::default() }).unwrap();
    assert_eq!(ok.recording.mag[0], [90.0, 180.0, 270.0]);
    assert_eq!(ok.report.skipped.garbage_bytes, 3);
    assert_eq!(ok.report.notes.len(), 1, "defaults assumed and said");
    // Every column says where it came from; the reference is the course.
    assert!(ok.report.column_sources["mx, my, mz"].starts_with("MAG instance 1"));
    assert!(ok.report.column_sources[col::REF_HEADING_DEG].starts_with("GPS instance 0 GCrs"));
}

#[test]
fn the_first_imus_gyro_at_each_mag_time() {
    let msg = |t: u8, body: Vec<u8>| [vec![0xA3, 0x95, t], body].concat();
    let mag = |t_us: u64| {
        let mut b = t_us.to_le_bytes().to_vec();
        b.push(0);
        for v in [1i16, 2, 3, 0, 0, 0] {
            b.extend(v.to_le_bytes());
        }
        msg(201, b)
    };
    let gyro = |t: u8, t_us: u64, i: u8, sample_us: Option<u64>, g: [f32; 3]| {
        let mut b = t_us.to_le_bytes().to_vec();
        b.push(i);
        if let Some(s) = sample_us {
            b.extend(s.to_le_bytes());
        }
        for v in g {
            b.extend(v.to_le_bytes());
        }
        msg(t, b)
    };
    let mut log = fmt(201, "MAG", "QBhhhhhh", "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ");
    log.extend(fmt(202, "IMU", "QBfff", "TimeUS,I,GyrX,GyrY,GyrZ"));
    log.extend(fmt(203, "GYR", "QBQfff", "TimeUS,I,SampleUS,GyrX,GyrY,GyrZ"));
    let mut with_imu = log.clone();
    with_imu.extend(gyro(202, 900_000, 0, None, [0.1, 0.0, -1.0]));
    with_imu.extend(gyro(202, 1_000_000, 1, None, [9.0, 9.0, 9.0])); // the second IMU: not used
    with_imu.extend(gyro(203, 1_000_000, 0, Some(1_000_000), [5.0, 5.0, 5.0])); // GYR: only without IMU
    with_imu.extend(gyro(202, 1_100_000, 0, None, [0.3, 0.5, -1.0]));
    with_imu.extend(mag(1_000_000));
    let im = import(&with_imu, &ImportOptions::default()).unwrap();
    let g = [&im.recording.gx_rad_s, &im.recording.gy_rad_s, &im.recording.gz_rad_s].map(|c| c.as_ref().unwrap()[0]);
    for (got, want) in g.iter().zip([0.2, 0.25, -1.0]) {
        assert!((got - want).abs() < 1e-6, "{g:?}");
    }
    assert!(im.report.column_sources["gx, gy, gz"].starts_with("IMU instance 0"));
    assert_eq!(im.report.rows_with_gyro, 1);
    // GYR alone: its sample times.
    log.extend(gyro(203, 2_000_000, 0, Some(950_000), [0.4, 0.0, 0.0]));
    log.extend(gyro(203, 2_000_000, 0, Some(1_050_000), [0.6, 0.0, 0.0]));
    log.extend(mag(1_000_000));
    let im = import(&log, &ImportOptions::default()).unwrap();
    assert!((im.recording.gx_rad_s.as_ref().unwrap()[0] - 0.5).abs() < 1e-6);
    assert!(im.report.column_sources["gx, gy, gz"].starts_with("GYR instance 0"));
}
