//! `magcal import`: a recording from a vehicle's own log — ArduPilot /
//! ArduSub DataFlash `.bin` (host-tools' [`host_tools::data::dataflash`]) or
//! an NMEA 0183 log of a heading compass and a GPS
//! ([`host_tools::data::nmea`]).

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use host_tools::data::{dataflash, nmea};

/// Arguments of `magcal import`.
#[derive(clap::Args)]
#[command(group(clap::ArgGroup::new("log").required(true).args(["dataflash", "nmea"])))]
pub struct Args {
    /// ArduPilot/ArduSub DataFlash binary log.
    #[arg(long)]
    dataflash: Option<PathBuf>,
    /// NMEA 0183 log (text; HDG, HDM, HDT, RMC, VTG, GGA, GLL, ZDA of any
    /// talker; other sentences counted and skipped).
    #[arg(long)]
    nmea: Option<PathBuf>,
    /// The recording to write (CSV; DataFlash: raw field in mGauss; NMEA:
    /// headings and GPS, no field).
    #[arg(long)]
    out: PathBuf,
    /// Compass instance (0 = the first; DataFlash only).
    #[arg(long, conflicts_with = "nmea")]
    mag_instance: Option<u8>,
    /// GPS course is the reference heading only at this ground speed or
    /// more, m/s (NMEA: only where no HDT gives a true heading).
    #[arg(long, default_value_t = 0.5)]
    min_course_speed_mps: f64,
    /// NMEA: a talker (e.g. II) whose HDT is an independent true heading,
    /// besides a GNSS compass's (GP, GN, GA, GB, BD, GL, GQ, GI) and a
    /// gyrocompass's (HE). The compass's own talker's HDT is never the
    /// reference (it is the compass's heading plus the variation).
    #[arg(long, conflicts_with = "dataflash", value_name = "XX")]
    reference_talker: Option<String>,
    /// Print the import report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal import`.
pub fn run(a: Args) -> Result<()> {
    let log = a.dataflash.as_deref().or(a.nmea.as_deref()).context("give --dataflash LOG or --nmea LOG")?;
    super::check_out("--out", &a.out, &[log])?;
    if !(a.min_course_speed_mps.is_finite() && a.min_course_speed_mps >= 0.0) {
        bail!("--min-course-speed-mps must be a non-negative number, not {}", a.min_course_speed_mps);
    }
    match (&a.dataflash, &a.nmea) {
        (Some(log), _) => run_dataflash(&a, log),
        (None, Some(log)) => run_nmea(&a, log),
        (None, None) => bail!("give --dataflash LOG or --nmea LOG"),
    }
}

fn run_dataflash(a: &Args, log: &Path) -> Result<()> {
    let opts = dataflash::ImportOptions {
        mag_instance: a.mag_instance.unwrap_or(0),
        min_course_speed_mps: a.min_course_speed_mps,
        ..dataflash::ImportOptions::default()
    };
    let im = dataflash::import_file(log, &opts).with_context(|| format!("{}: DataFlash import", log.display()))?;
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

/// `name n, name n` of a count map.
fn counts(map: &std::collections::BTreeMap<String, usize>) -> String {
    map.iter().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ")
}

fn run_nmea(a: &Args, log: &Path) -> Result<()> {
    let opts = nmea::ImportOptions { min_course_speed_mps: a.min_course_speed_mps, reference_talker: a.reference_talker.clone() };
    let im = nmea::import_file(log, &opts).with_context(|| format!("{}: NMEA 0183 import", log.display()))?;
    let r = &im.report;
    for n in &r.notes {
        eprintln!("note: {n}");
    }
    if r.skipped() > 0 {
        let untimed = r.untimed_before_first_time + r.untimed_after_last_time + r.untimed_in_gaps;
        let parts: Vec<String> = [
            (r.bad_checksum, "with a bad checksum".to_string()),
            (r.partial, format!("partial ({})", counts(&r.partial_reasons))),
            (r.unknown, format!("of types not read ({})", counts(&r.unknown_types))),
            (r.void_fixes, "void fixes".to_string()),
            (r.empty_values, "with an empty heading or VTG".to_string()),
            (r.other_source, format!("headings of another compass than {}", r.compass_source.as_deref().unwrap_or("the one used"))),
            (r.time_backwards, "with a time going back".to_string()),
            (r.date_jumps, format!("dated more than {} s from the dated sentences around them", nmea::MAX_DATE_JUMP_S)),
            (r.compass_true_headings, "HDT of the compass itself (not a reference)".to_string()),
            (r.unplaced_true_headings, format!("HDT of talkers not known independent ({})", r.unplaced_true_heading_sources.join(", "))),
            (
                untimed,
                format!(
                    "that cannot be timed ({} before the first time, {} after the last, {} in gaps over {} s)",
                    r.untimed_before_first_time,
                    r.untimed_after_last_time,
                    r.untimed_in_gaps,
                    nmea::MAX_SPREAD_GAP_S
                ),
            ),
        ]
        .into_iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, what)| format!("{n} {what}"))
        .collect();
        eprintln!("warning: skipped {} of {} sentences: {}", r.skipped(), r.sentences, parts.join("; "));
    }
    for source in &r.unplaced_true_heading_sources {
        eprintln!("hint: if {source} is an independent heading sensor (not the compass relayed), give --reference-talker {}", &source[..2.min(source.len())]);
    }
    im.write(&a.out)?;
    eprintln!("wrote {} ({} rows)", a.out.display(), r.rows);
    if a.json {
        println!("{}", serde_json::to_string_pretty(r)?);
    } else {
        let start = r.start_utc.clone().unwrap_or_else(|| format!("{} UTC (no date in the log)", r.start_time_of_day_utc));
        let source = r.column_sources.get(host_tools::data::table::col::REF_HEADING_DEG).map(|s| format!(" from {s}")).unwrap_or_default();
        let reference = match r.reference {
            nmea::Reference::Hdt => format!("HDT{source}"),
            nmea::Reference::Course => format!("GPS course at speed{source}"),
            nmea::Reference::None => "none".to_string(),
        };
        println!(
            "{} rows over {:.1} s from {start}, from {} of {} sentences ({}); columns {}; reference heading: {reference}",
            r.rows,
            r.duration_s,
            r.used.values().sum::<usize>(),
            r.sentences,
            counts(&r.used),
            r.columns.join(", ")
        );
    }
    Ok(())
}
