//! The command-level fuzz driver (hostile input to every command), shared by the `commands` fuzz
//! target and the test that replays its seeds and crashes
//! (`magcal/tests/commands/hostile/references.rs`), so both run the same
//! calls.
//!
//! One input is up to four parts separated by [`SEPARATOR`] (ASCII record
//! separator, 0x1E): a recording CSV, a calibration document (JSON), an
//! NMEA 0183 log, and option bytes. They go through the library's command
//! entry points as `apply`, `swing`, `card` and `import --nmea` call them:
//! the CSV as a recording ([`Recording::from_reader_mapped`]) and as a
//! compass log; the document as a field calibration and as a compass's
//! (parsed and validated); the NMEA log through the importer's reader, its
//! rows as a compass log; then `apply`, the swing fits and the card on
//! whatever was read. The option bytes pick the delay (given or searched),
//! the water current, the card's step and points, the importer's course
//! speed and reference talker — each from the values those options accept,
//! so that what is fuzzed is the data, not the options' parsers.
//!
//! Whatever the bytes, nothing may panic: every refusal is an error.

use std::path::Path;

use host_tools::compute::{apply_recording, ApplyOptions};
use host_tools::compute::{compass_card, deviation_card};
use host_tools::compute::{apply_compass, swing_compass};
use host_tools::compute::{swing_recording_with, Delay, WaterCurrentMode};
use host_tools::data::CompassLog;
use host_tools::doc::CompassDoc;
use host_tools::data::{import_nmea_reader, NmeaImported, NmeaOptions};
use host_tools::data::{col, ColumnMap};
use host_tools::data::Recording;
use host_tools::doc::CalDoc;

/// The byte between an input's parts.
pub const SEPARATOR: u8 = 0x1E;

/// Card steps `card --step-deg` accepts (divisors of 360).
const STEPS_DEG: [f64; 8] = [0.5, 1.0, 5.0, 10.0, 15.0, 22.5, 45.0, 90.0];

/// The options an input's last part picks.
struct Options {
    delay: Delay,
    water_current: WaterCurrentMode,
    step_deg: f64,
    points: usize,
    declination_deg: Option<f64>,
    import: NmeaOptions,
}

fn options(bytes: &[u8]) -> Options {
    let b = |i: usize| bytes.get(i).copied().unwrap_or(0);
    let delay = match b(0) % 3 {
        0 => Delay::Given(f64::from(b(1) as i8) / 10.0),
        1 => Delay::Estimate { min_s: -f64::from(b(1) % 8), max_s: f64::from(b(2) % 8) },
        _ => Delay::Estimate { min_s: 0.0, max_s: 5.0 },
    };
    Options {
        delay,
        water_current: if b(3) & 1 == 0 { WaterCurrentMode::Off } else { WaterCurrentMode::Auto },
        step_deg: STEPS_DEG[usize::from(b(4)) % STEPS_DEG.len()],
        points: if b(5) & 1 == 0 { 16 } else { 8 },
        declination_deg: (b(6) & 1 == 1).then(|| f64::from(b(7) as i8) / 2.0),
        import: NmeaOptions {
            min_course_speed_mps: f64::from(b(8)) / 20.0,
            reference_talker: match b(9) % 4 {
                0 => None,
                1 => Some("II".into()),
                2 => Some("HC".into()),
                _ => Some(String::from_utf8_lossy(&[b(10), b(11)]).into_owned()),
            },
        },
    }
}

/// The importer's rows as a compass log (what `swing` reads back from the
/// CSV `import` writes), when they hold a compass heading.
fn compass_log(im: &NmeaImported) -> Option<CompassLog> {
    let column = |name: &str| im.column(name).map(<[f64]>::to_vec);
    Some(CompassLog {
        t_s: column(col::T)?,
        compass_heading_deg: column(col::COMPASS_HEADING_DEG)?,
        ref_heading_deg: column(col::REF_HEADING_DEG),
        lat_deg: column(col::LAT_DEG),
        lon_deg: column(col::LON_DEG),
        speed_mps: column(col::SPEED_MPS),
        variation_deg: column(col::VARIATION_DEG),
    })
}

/// Drives one input through the command entry points.
pub fn drive(data: &[u8]) {
    let mut parts = data.splitn(4, |&b| b == SEPARATOR);
    let (csv, json, log, opts) = (parts.next().unwrap_or_default(), parts.next().unwrap_or_default(), parts.next().unwrap_or_default(), parts.next().unwrap_or_default());
    let o = options(opts);
    let (csv_path, doc_path) = (Path::new("fuzz.csv"), Path::new("fuzz.json"));
    let map = ColumnMap::default();

    // A magnetometer's recording with a field calibration: apply, swing, card.
    let doc = serde_json::from_slice::<CalDoc>(json).ok().filter(|d| d.validate(doc_path).is_ok());
    if let (Ok(rec), Some(doc)) = (Recording::from_reader_mapped(csv, csv_path, &map), &doc) {
        let _ = apply_recording(&rec, doc, &ApplyOptions::default());
        let _ = swing_recording_with(&rec, doc, o.delay, o.water_current);
        let _ = deviation_card(&rec, doc, o.step_deg, o.points);
    }

    // A heading-only compass: the CSV and the NMEA import as its log.
    let compass_doc = serde_json::from_slice::<CompassDoc>(json).ok().filter(|d| d.validate(doc_path).is_ok());
    let mut logs: Vec<CompassLog> = CompassLog::from_reader_mapped(csv, csv_path, &map).into_iter().collect();
    if let Ok(im) = import_nmea_reader(log, Path::new("fuzz.nmea"), &o.import) {
        logs.extend(compass_log(&im));
    }
    for log in &logs {
        let _ = swing_compass(log, o.declination_deg, o.delay, o.water_current);
        if let Some(doc) = &compass_doc {
            let _ = apply_compass(log, doc);
            let _ = compass_card(log, doc, o.step_deg, o.points);
        }
    }
}
