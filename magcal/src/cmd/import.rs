//! `magcal import`: a recording from a vehicle's own log — ArduPilot /
//! ArduSub DataFlash `.bin` (host-tools' [`host_tools::data::dataflash`]).

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::data::dataflash::{import_file, ImportOptions};

/// Arguments of `magcal import`.
#[derive(clap::Args)]
pub struct Args {
    /// ArduPilot/ArduSub DataFlash binary log.
    #[arg(long)]
    dataflash: PathBuf,
    /// The recording to write (CSV; raw field in mGauss).
    #[arg(long)]
    out: PathBuf,
    /// Compass instance (0 = the first).
    #[arg(long, default_value_t = 0)]
    mag_instance: u8,
    /// GPS course is the reference heading only at this ground speed or more, m/s.
    #[arg(long, default_value_t = 0.5)]
    min_course_speed_mps: f64,
    /// Print the import report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal import`.
pub fn run(a: Args) -> Result<()> {
    super::check_out("--out", &a.out, &[&a.dataflash])?;
    if !(a.min_course_speed_mps.is_finite() && a.min_course_speed_mps >= 0.0) {
        bail!("--min-course-speed-mps must be a non-negative number, not {}", a.min_course_speed_mps);
    }
    let opts = ImportOptions { mag_instance: a.mag_instance, min_course_speed_mps: a.min_course_speed_mps, ..ImportOptions::default() };
    let im = import_file(&a.dataflash, &opts).with_context(|| format!("{}: DataFlash import", a.dataflash.display()))?;
    let r = &im.report;
    for n in &r.notes {
        eprintln!("note: {n}");
    }
    let s = r.skipped;
    if s.garbage_bytes + s.unknown_type_messages + s.truncated_tail_bytes > 0 {
        eprintln!(
            "warning: skipped {} corrupt bytes, {} messages of undescribed types, {} bytes of a truncated last message",
            s.garbage_bytes, s.unknown_type_messages, s.truncated_tail_bytes
        );
    }
    im.recording
        .write_with_extra(&a.out, &[("ahrs_yaw_deg", &im.ahrs_yaw_deg), (host_tools::data::table::col::GPS_SPEED_MPS, &im.gps_speed_mps)])?;
    eprintln!("wrote {} ({} rows)", a.out.display(), r.rows);
    if a.json {
        println!("{}", serde_json::to_string_pretty(r)?);
    } else {
        println!(
            "{} MAG rows; {} with attitude, {} with a GPS course, {} with a current",
            r.rows, r.rows_with_attitude, r.rows_with_course, r.rows_with_current
        );
    }
    Ok(())
}
