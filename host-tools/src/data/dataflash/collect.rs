//! The messages of a log collected by kind (the chosen compass's raw field,
//! the attitude, GPS, battery and the first IMU's gyro, the parameters in
//! force), then carried to each compass sample's row.

use std::collections::HashMap;

use super::correction::{compass_matrix_noted, solve3};
use super::{read_messages, DataFlashError, ImportOptions, ImportReport, Imported, Message};
use crate::data::import::rules::{self, Kind, Series};
use crate::data::recording::Recording;
use crate::data::table::col;

/// What the messages of a log hold, in time order per kind.
pub(super) struct Collected {
    params: HashMap<String, f64>,
    /// ATT Roll, Pitch, Yaw.
    att: Series<3>,
    /// GPS instance 0: Status, Lat, Lng, Spd, GCrs.
    gps: Series<5>,
    /// BAT/CURR instance 0: Curr.
    bat: Series<1>,
    /// The first IMU's gyro (IMU with I = 0, or IMU of older logs), rad/s.
    imu: Series<3>,
    /// GYR of the first IMU (high-rate samples), rad/s: used without IMU.
    gyr: Series<3>,
    /// The chosen compass's raw field: (time, raw).
    pub(super) mag: Vec<(f64, [f64; 3])>,
    /// Every compass instance seen.
    pub(super) instances: Vec<u8>,
}

impl Default for Collected {
    fn default() -> Self {
        Self {
            params: HashMap::new(),
            att: Series::new([Kind::Linear, Kind::Linear, Kind::Heading360]),
            gps: Series::new([Kind::Latest; 5]),
            bat: Series::new([Kind::Latest]),
            imu: Series::new([Kind::Linear; 3]),
            gyr: Series::new([Kind::Linear; 3]),
            mag: Vec::new(),
            instances: Vec::new(),
        }
    }
}

impl Collected {
    /// A compass message (`MAG`, `MAG2`, `MAG3`): the raw field of the
    /// chosen instance, the autopilot's corrections undone.
    fn mag(&mut self, m: &Message, name: &str, opts: &ImportOptions, report: &mut ImportReport) -> Result<(), DataFlashError> {
        let inst = match (name, m.num("I")) {
            ("MAG", Some(i)) => i as u8,
            ("MAG", None) => 0,
            ("MAG2", _) => 1,
            _ => 2,
        };
        if !self.instances.contains(&inst) {
            self.instances.push(inst);
        }
        if inst != opts.mag_instance {
            return Ok(());
        }
        let t = m.need("TimeUS")? * 1e-6;
        let field = [m.need("MagX")?, m.need("MagY")?, m.need("MagZ")?];
        let ofs = [m.need("OfsX")?, m.need("OfsY")?, m.need("OfsZ")?];
        let mo = [m.num("MOX").unwrap_or(0.0), m.num("MOY").unwrap_or(0.0), m.num("MOZ").unwrap_or(0.0)];
        let mat = compass_matrix_noted(&self.params, inst, &mut report.notes);
        let corrected = solve3(&mat, [0, 1, 2].map(|k| field[k] - mo[k])).ok_or(DataFlashError::Singular { instance: inst, t_s: t })?;
        let raw = [0, 1, 2].map(|k| corrected[k] - ofs[k]);
        if let Some((prev, _)) = self.mag.last() {
            if t < *prev {
                return Err(DataFlashError::TimeBackwards { t_s: t, previous_s: *prev });
            }
        }
        self.mag.push((t, raw));
        Ok(())
    }

    /// One message of any kind.
    fn message(&mut self, m: &Message, opts: &ImportOptions, report: &mut ImportReport) -> Result<(), DataFlashError> {
        match m.format.name.as_str() {
            "PARM" => {
                if let (Some(n), Some(v)) = (m.text("Name"), m.num("Value")) {
                    self.params.insert(n.to_string(), v);
                }
            }
            name @ ("MAG" | "MAG2" | "MAG3") => self.mag(m, name, opts, report)?,
            "ATT" => self.att.push(m.need("TimeUS")? * 1e-6, [m.need("Roll")?, m.need("Pitch")?, m.need("Yaw")?]),
            "GPS" if m.num("I").unwrap_or(0.0) == 0.0 => {
                self.gps.push(m.need("TimeUS")? * 1e-6, [m.need("Status")?, m.need("Lat")?, m.need("Lng")?, m.need("Spd")?, m.need("GCrs")?])
            }
            "BAT" | "CURR" if m.num("Inst").or(m.num("I")).unwrap_or(0.0) == 0.0 => self.bat.push(m.need("TimeUS")? * 1e-6, [m.need("Curr")?]),
            // The first IMU: `IMU` with I = 0 (older logs: `IMU`, with `IMU2`, `IMU3` for the others).
            "IMU" if m.num("I").unwrap_or(0.0) == 0.0 => self.imu.push(m.need("TimeUS")? * 1e-6, [m.need("GyrX")?, m.need("GyrY")?, m.need("GyrZ")?]),
            "GYR" if m.num("I").unwrap_or(0.0) == 0.0 => self.gyr.push(m.num("SampleUS").map_or_else(|| m.need("TimeUS"), Ok)? * 1e-6, [m.need("GyrX")?, m.need("GyrY")?, m.need("GyrZ")?]),
            _ => {}
        }
        Ok(())
    }
}

/// Reads every message of the log (the first bad one stops it).
pub(super) fn collect(bytes: &[u8], opts: &ImportOptions, report: &mut ImportReport) -> Result<Collected, DataFlashError> {
    let mut c = Collected::default();
    let mut first_error: Option<DataFlashError> = None;
    let skipped = read_messages(bytes, |m| {
        if first_error.is_some() {
            return;
        }
        *report.messages.entry(m.format.name.clone()).or_default() += 1;
        if let Err(e) = c.message(m, opts, report) {
            first_error = Some(e);
        }
    })?;
    if let Some(e) = first_error {
        return Err(e);
    }
    report.skipped = skipped;
    Ok(c)
}

/// The recording: one row per compass sample, the attitude and the first
/// IMU's gyro interpolated to it, the latest GPS fix and battery current
/// ([`rules::Series`]).
pub(super) fn rows(c: &Collected, opts: &ImportOptions, report: &mut ImportReport) -> Imported {
    let (att, gps, bat, mag) = (&c.att, &c.gps, &c.bat, &c.mag);
    // The gyro: IMU (the rates the autopilot uses); GYR (high-rate samples) only without IMU.
    let (gyro, gyro_from) = if !c.imu.is_empty() { (&c.imu, "IMU instance 0 (IMU with I = 0, or IMU of older logs) GyrX/Y/Z, rad/s") } else { (&c.gyr, "GYR instance 0 GyrX/Y/Z (high-rate samples; the log has no IMU), rad/s") };
    let n = mag.len();
    let (mut roll, mut pitch, mut course, mut lat, mut lon) = (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]);
    let (mut yaw, mut speed, mut current) = (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]);
    let mut g = [vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]];
    for (i, &(t, _)) in mag.iter().enumerate() {
        // Attitude: linear between the ATT samples around t (yaw across ±180°).
        if let Some(v) = att.at(t, opts.max_age_s) {
            (roll[i], pitch[i], yaw[i]) = (v[0], v[1], v[2]);
            report.rows_with_attitude += 1;
        }
        // GPS: the latest fix (Status ≥ 3: 3D); the course only at speed.
        if let Some(v) = gps.at(t, opts.max_age_s) {
            if v[0] >= 3.0 {
                (lat[i], lon[i], speed[i]) = (v[1], v[2], v[3]);
                course[i] = rules::course_at_speed_deg(v[4], v[3], opts.min_course_speed_mps);
                if course[i].is_finite() {
                    report.rows_with_course += 1;
                }
            }
        }
        if let Some(v) = bat.at(t, opts.max_age_s) {
            current[i] = v[0];
            report.rows_with_current += 1;
        }
        if let Some(v) = gyro.at(t, opts.max_age_s) {
            for k in 0..3 {
                g[k][i] = v[k];
            }
            report.rows_with_gyro += 1;
        }
    }
    report.skipped.out_of_order_samples = att.out_of_order + gps.out_of_order + bat.out_of_order + gyro.out_of_order;
    report.rows = n;
    let k = opts.mag_instance;
    for (column, source) in [
        ("mx, my, mz", format!("MAG instance {k} (MAG with I = {k}, or MAG{} of older logs), MagX/Y/Z with ArduPilot's correction undone: the raw field", if k == 0 { String::new() } else { (k + 1).to_string() })),
        (col::ROLL_DEG, "ATT Roll".to_string()),
        (col::PITCH_DEG, "ATT Pitch".to_string()),
        (col::REF_HEADING_DEG, format!("GPS instance 0 GCrs (course over ground) with a 3D fix at a ground speed of {} m/s or more", opts.min_course_speed_mps)),
        ("ahrs_yaw_deg", "ATT Yaw: the autopilot's own heading, from its compasses (not a reference)".to_string()),
        (col::GPS_SPEED_MPS, "GPS instance 0 Spd".to_string()),
        (col::LAT_DEG, "GPS instance 0 Lat".to_string()),
        (col::LON_DEG, "GPS instance 0 Lng".to_string()),
        (col::MOTOR_CURRENT_A, "BAT/CURR instance 0 Curr".to_string()),
        ("gx, gy, gz", format!("{gyro_from}, linear between the samples around each MAG time")),
    ] {
        report.column_sources.insert(column.to_string(), source);
    }
    let [gx, gy, gz] = g;
    let recording = Recording {
        t_s: Some(mag.iter().map(|m| m.0).collect()),
        mag: mag.iter().map(|m| m.1).collect(),
        roll_deg: Some(roll),
        pitch_deg: Some(pitch),
        ref_heading_deg: Some(course),
        lat_deg: Some(lat),
        lon_deg: Some(lon),
        motor_current_a: Some(current),
        gx_rad_s: Some(gx),
        gy_rad_s: Some(gy),
        gz_rad_s: Some(gz),
        ..Recording::default()
    };
    Imported { recording, ahrs_yaw_deg: yaw, gps_speed_mps: speed, report: std::mem::take(report) }
}
