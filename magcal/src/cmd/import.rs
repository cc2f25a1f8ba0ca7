//! `magcal import`: a recording from a vehicle's own log, through the one
//! importer ([`host_tools::data::import`]): ArduPilot DataFlash, NMEA 0183,
//! MAVLink telemetry logs, PX4 ULog, ROS 2 bags (MCAP, sqlite3) and NMEA 2000
//! in canboat's text formats; the format found from the content or named.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use host_tools::data::{import_file, Format, ImportOptions, Role};

/// Arguments of `magcal import`.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("log").required(true).args(["input", "dataflash", "nmea"])))]
pub struct Args {
    /// The vehicle's log: its format is found from its content (magic
    /// bytes, the first line), or named with --format.
    #[arg(value_name = "LOG")]
    input: Option<PathBuf>,
    /// The log's format: dataflash, nmea0183, tlog, ulog, mcap, sqlite3,
    /// nmea2000.
    #[arg(long, value_parser = parse_format)]
    format: Option<Format>,
    /// An ArduPilot/ArduSub DataFlash binary log (the same as LOG with
    /// --format dataflash).
    #[arg(long, conflicts_with_all = ["input", "nmea"])]
    dataflash: Option<PathBuf>,
    /// An NMEA 0183 log (the same as LOG with --format nmea0183).
    #[arg(long, conflicts_with = "input")]
    nmea: Option<PathBuf>,
    /// The recording to write (CSV; the field in the unit the report names).
    #[arg(long)]
    out: PathBuf,
    /// The magnetometer instance to import (0 = the first; the report says
    /// which instances the log holds). NMEA 2000: the compass's source
    /// address.
    #[arg(long, alias = "mag-instance", value_parser = clap::value_parser!(u32).range(0..=255))]
    instance: Option<u32>,
    /// The magnetometer topic, when a ROS 2 bag or a PX4 ULog holds several
    /// (ULog: sensor_mag, vehicle_magnetometer, sensor_combined).
    #[arg(long)]
    topic: Option<String>,
    /// The GNSS course is the reference heading only at this ground speed
    /// or more, m/s (only where no independent heading is logged).
    #[arg(long, default_value_t = 0.5, value_parser = super::number_in(0.0..=100.0, "m/s"))]
    min_course_speed_mps: f64,
    /// NMEA 0183: a talker (e.g. II) whose HDT is an independent true
    /// heading, besides a GNSS compass's (GP, GN, GA, GB, BD, GL, GQ, GI)
    /// and a gyrocompass's (HE). The compass's own talker's HDT is never the
    /// reference (it is the compass's heading plus the variation).
    #[arg(long, value_name = "XX")]
    reference_talker: Option<String>,
    /// Print the import report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

fn parse_format(s: &str) -> Result<Format, String> {
    Format::from_name(s).ok_or_else(|| format!("one of {}", Format::names()))
}

/// Runs `magcal import`.
pub fn run(a: Args) -> Result<()> {
    let (log, named) = match (&a.input, &a.dataflash, &a.nmea) {
        (Some(log), None, None) => (log, a.format),
        (None, Some(log), None) => (log, Some(Format::Dataflash)),
        (None, None, Some(log)) => (log, Some(Format::Nmea0183)),
        _ => bail!("give one log: LOG, --dataflash LOG or --nmea LOG"),
    };
    if let (Some(f), Some(n)) = (a.format, named) {
        if f != n {
            bail!("--format {f} names another format than the log's option ({n})");
        }
    }
    super::check_out("--out", &a.out, &[log])?;
    let opts = ImportOptions {
        min_course_speed_mps: a.min_course_speed_mps,
        instance: a.instance,
        topic: a.topic.clone(),
        reference_talker: a.reference_talker.clone(),
        ..ImportOptions::default()
    };
    let im = import_file(log, named, &opts).with_context(|| format!("{}: import", log.display()))?;
    let r = &im.report;
    for n in &r.notes {
        eprintln!("note: {n}");
    }
    if r.skipped_total() > 0 {
        let parts: Vec<String> = r.skipped.iter().map(|(k, n)| format!("{n} {}", k.replace('_', " "))).collect();
        eprintln!("warning: skipped {} (by kind: {})", r.skipped_total(), parts.join("; "));
    }
    im.write(&a.out)?;
    eprintln!("wrote {} ({} rows, {})", a.out.display(), r.rows, r.format.title());
    if a.json {
        println!("{}", serde_json::to_string_pretty(r)?);
        return Ok(());
    }
    let reference = r
        .column_sources
        .iter()
        .find(|(_, s)| s.role == Role::Reference)
        .map_or_else(|| "none".to_string(), |(name, s)| format!("{name} from {}", s.from));
    let read: Vec<String> = r.messages.iter().map(|(k, n)| format!("{k} {n}")).collect();
    println!(
        "{} rows over {:.1} s ({}) from {}; columns {}; field in {}; reference heading: {reference}",
        r.rows,
        r.duration_s,
        r.clock,
        read.join(", "),
        r.columns.join(", "),
        r.field_unit.as_deref().unwrap_or("(no field)")
    );
    Ok(())
}
