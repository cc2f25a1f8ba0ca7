//! NMEA 2000 in canboat's text formats (FAST, PLAIN) and Actisense's N2K
//! ASCII: a boat's compass, its satellite compass or gyro, attitude, rate of
//! turn, GNSS course and position, as one recording.
//!
//! **Hand-written.** canboat's own Rust crate (`canboat`, every version
//! published: 8.2.1 to 9.1.0) reads these formats, but needs Rust 1.96:
//! this project's toolchain is 1.95 and its declared minimum 1.85; `canboat-rs` (0.1.2-alpha) decodes a CAN
//! identifier and frame, not the text logs. Neither would read PGN 65350 as
//! a field (canboat's database leaves it incomplete, see below). The text
//! is a comma-separated line and the six PGNs read are single 8-byte frames
//! with fixed fields, so the reader is small; the tests check it against an
//! independent decode in Python written from canboat's published
//! definitions (`tests/data/nmea2000-canboat/reference.py`). When the
//! project moves to Rust 1.96, the `canboat` crate (feature `decode`) is the
//! candidate to replace [`text`] and [`pgn`].
//!
//! **Lines** ([`text`]). canboat's FAST and PLAIN share a layout,
//! `timestamp,priority,PGN,source,destination,length,hex bytes…`: FAST has
//! one line per whole PGN, PLAIN one per CAN frame (at most 8 bytes), so a
//! PLAIN log's fast-packet PGNs (those canboat marks `Fast`, and the
//! proprietary range 130816–131071) are reassembled from their frames: byte
//! 0 holds the sequence counter (bits 5–7) and the frame index (bits 0–4);
//! the first frame's byte 1 the payload's length and then 6 bytes, every
//! later frame 7. A frame out of sequence drops its packet (counted
//! `fast_packet_incomplete`, the frame `fast_packet_frame_without_start`). A
//! log is FAST when its header says `# format=FAST` or a line holds more than
//! 8 bytes, else PLAIN (`# format=PLAIN` says so too). Actisense's N2K ASCII
//! (`A000200.004 96FF2 1F802 FFFCCA30…`: time of day, source, destination and
//! priority in hex, the PGN in hex, the payload) carries whole PGNs. Each
//! line is checked whole — the header's numbers (priority 0–7, addresses
//! 0–255), every byte one or two hex digits, as many bytes as its length
//! says — and refused and counted by kind otherwise, never ending the import.
//!
//! **Time.** canboat's timestamps: an ISO date and time with milliseconds
//! (`2026-07-02T06:01:32.996Z`; canboat's older `2011-11-24-22:42:04.388`,
//! a space, a comma before the fraction, no `Z`: zone unknown, said), or a
//! number of seconds; Actisense's a time of day (the day advances when it
//! goes back by more than 12 h). A log keeps its first line's form; lines of
//! another are counted and not used. `t` = s since the first row.
//!
//! **PGNs** ([`pgn`]): 127250 Vessel Heading (heading, deviation, variation,
//! reference true/magnetic), 127251 Rate of Turn, 127257 Attitude, 129026 COG
//! & SOG Rapid Update, 129025 Position Rapid Update, decoded as canboat's
//! `canboat.json` defines them; a value outside its field's range (the "not
//! available" `0x7FFF`, `0xFFFF`, … codes) is NaN. **65350 "Simnet: Magnetic
//! Field"** is proprietary and canboat's definition of it is incomplete (its
//! fields are marked missing; its guessed layout A/B/C/D puts a field across
//! bytes 3–4, which jumps by ±32 000 between consecutive samples of a real
//! Precision-9): read here as three little-endian signed 16-bit axes at
//! bytes 0, 2 and 4, which vary smoothly — **counts, in units and axes the
//! maker has not published**, kept as they are (`field_unit` says so). Any
//! maker may use a proprietary PGN: a 65350 not from a Simrad/Navico compass
//! would be misread (the report names its source).
//!
//! **Roles.** A MAGNETIC 127250 heading is the compass's
//! (`compass_heading_deg`, [`Role::Compass`]); the compass is the source of
//! 65350 (the field) when the log has one, else the source with the most
//! magnetic headings (`--instance N`: source address N). A TRUE 127250
//! heading of ANOTHER source (a satellite compass, a gyrocompass) is the
//! reference (`ref_heading_deg`, [`Role::Reference`]); the compass's own true
//! heading (its magnetic heading plus the variation) is never the reference:
//! counted `compass_own_true_heading`, not used; nor is another source's
//! true heading that follows the compass's magnetic heading to within
//! [`RELAY_SPREAD_DEG`] (a display or gateway relaying the compass with a
//! variation: counted `true_heading_relaying_the_compass`). Several sources of one PGN:
//! one is chosen by role (the compass's own attitude and rate of turn; the
//! reference's course and position; else the source with most messages),
//! said in a note, the others counted (`another_source_<PGN>`).
//!
//! **Rows.** One per 65350 sample (`mx, my, mz`) when the compass sends the
//! field, else one per compass heading sample (a heading-only log, for
//! `magcal swing`/`card` as an NMEA 0183 heading log). The other PGNs are
//! carried to the rows' times ([`rules::Series`], within
//! [`ImportOptions::max_age_s`]): `compass_heading_deg`, `variation_deg`
//! (the compass's 127250 variation, else the reference's), `ref_heading_deg`
//! (the reference's true heading; only where the log has none, the course at
//! speed by [`rules::course_at_speed_deg`]), `roll_deg`, `pitch_deg`
//! (127257, NMEA 2000's signs: bow up and starboard down positive, the
//! body-frame FRD convention), `gz` (127251's rate of turn, rad/s: the yaw
//! rate in the body frame only when level — an approximation, said),
//! `course_deg`, `gps_speed_mps` (129026, true course only), `lat_deg`,
//! `lon_deg` (129025). A 127250 deviation is reported, never applied.

pub(crate) mod pgn;
pub(crate) mod text;

use std::collections::BTreeMap;

use super::rules::{self, Kind, Series};
use super::{Builder, Format, ImportError, ImportOptions, Imported, Role};
use crate::data::nmea::Date;
use crate::data::table::col;
use pgn::{Decoded, Reference};
use text::{TextFormat, TimeForm};

/// Why an NMEA 2000 log could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum Nmea2000Error {
    /// No line is NMEA 2000 in a format read.
    #[error("no line is NMEA 2000 in canboat's text (timestamp,priority,PGN,source,destination,length,bytes…) or Actisense's N2K ASCII: {found}")]
    NotNmea2000 {
        /// What the lines were, by kind.
        found: String,
    },
    /// No compass: neither a magnetic heading nor the field.
    #[error("nothing to calibrate: no magnetic heading (PGN 127250, reference magnetic) and no magnetic field (PGN 65350) in the log; found {found}")]
    NoCompass {
        /// The PGNs found (with sources) and what was refused.
        found: String,
    },
}

/// Whether a log's first bytes look like NMEA 2000 in a text format read.
pub fn looks_like(head: &[u8]) -> bool {
    text::looks_like(head)
}

/// The messages of one PGN read, by source address.
type BySource<T> = BTreeMap<u8, Vec<(f64, T)>>;

/// The decoded messages, by PGN and source.
#[derive(Default)]
struct Decoded6 {
    magnetic: BySource<[f64; 3]>,
    true_heading: BySource<[f64; 2]>,
    rate: BySource<[f64; 2]>,
    attitude: BySource<[f64; 2]>,
    cog: BySource<[f64; 2]>,
    position: BySource<[f64; 2]>,
    field: BySource<[f64; 3]>,
}

/// Imports an NMEA 2000 text log held in memory.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    let log = text::read(bytes).map_err(|skipped| Nmea2000Error::NotNmea2000 { found: kinds(skipped.iter().map(|(k, n)| (k.to_string(), *n))) })?;
    let mut d = Decoded6::default();
    let mut read: BTreeMap<String, usize> = BTreeMap::new();
    let mut skipped: BTreeMap<String, usize> = log.skipped.iter().map(|(k, n)| (k.to_string(), *n)).collect();
    let mut other = 0usize;
    for m in &log.messages {
        let Some(name) = pgn::READ.iter().find(|(p, _)| *p == m.pgn).map(|(_, n)| *n) else {
            other += 1;
            continue;
        };
        let Some(v) = pgn::decode(m.pgn, &m.data) else {
            add(&mut skipped, format!("short_payload_{}", m.pgn), 1);
            continue;
        };
        *read.entry(format!("{} {name}, source {}", m.pgn, m.src)).or_default() += 1;
        let (src, t) = (m.src, m.t_s);
        match v {
            Decoded::Heading { heading_deg, deviation_deg, variation_deg, reference } if heading_deg.is_finite() => match reference {
                Reference::Magnetic => push(&mut d.magnetic, src, t, [heading_deg, deviation_deg, variation_deg]),
                Reference::True => push(&mut d.true_heading, src, t, [heading_deg, variation_deg]),
                Reference::Unknown => add(&mut skipped, "heading_of_unknown_reference".into(), 1),
            },
            Decoded::Heading { .. } => add(&mut skipped, "heading_not_available".into(), 1),
            Decoded::RateOfTurn { rate_rad_s } if rate_rad_s.is_finite() => push(&mut d.rate, src, t, [rate_rad_s, 0.0]),
            Decoded::Attitude { pitch_deg, roll_deg, .. } if pitch_deg.is_finite() && roll_deg.is_finite() => push(&mut d.attitude, src, t, [roll_deg, pitch_deg]),
            Decoded::CogSog { reference: Reference::Magnetic, .. } => add(&mut skipped, "course_magnetic".into(), 1),
            Decoded::CogSog { cog_deg, sog_mps, .. } if cog_deg.is_finite() || sog_mps.is_finite() => push(&mut d.cog, src, t, [cog_deg, sog_mps]),
            Decoded::Position { lat_deg, lon_deg } if lat_deg.is_finite() && lon_deg.is_finite() => push(&mut d.position, src, t, [lat_deg, lon_deg]),
            Decoded::Field { xyz } if xyz.iter().all(|v| v.is_finite()) => push(&mut d.field, src, t, xyz),
            _ => add(&mut skipped, format!("not_available_{}", m.pgn), 1),
        }
    }
    // The compass: the field's source, else the most magnetic headings.
    let mut candidates: Vec<u8> = d.field.keys().chain(d.magnetic.keys()).copied().collect();
    candidates.sort_unstable();
    candidates.dedup();
    let compass = match opts.instance {
        Some(w) => u8::try_from(w).ok().filter(|s| candidates.contains(s)).ok_or_else(|| ImportError::NoInstance { sensor: "compass (PGN 127250 magnetic or 65350, by source address)".into(), wanted: Some(w), found: candidates.iter().map(|&c| u32::from(c)).collect() })?,
        None => match most(&d.field).or_else(|| most(&d.magnetic)) {
            Some(c) => c,
            None => {
                let mut found: Vec<(String, usize)> = read.iter().map(|(k, n)| (k.clone(), *n)).collect();
                found.push(("other PGNs".into(), other));
                found.extend(skipped.iter().map(|(k, n)| (format!("refused {k}"), *n)));
                return Err(Nmea2000Error::NoCompass { found: kinds(found.into_iter()) }.into());
            }
        },
    };
    let mut notes = Vec::new();
    if candidates.len() > 1 {
        notes.push(format!("compass: source {compass} of the sources of magnetic headings or the field {candidates:?} (--instance N for source N)"));
    }
    let field = d.field.remove(&compass).unwrap_or_default();
    let magnetic = d.magnetic.remove(&compass).unwrap_or_default();
    add(&mut skipped, "another_source_65350".into(), d.field.values().map(Vec::len).sum());
    add(&mut skipped, "another_compass_127250_magnetic".into(), d.magnetic.values().map(Vec::len).sum());
    let own_true = d.true_heading.remove(&compass).map_or(0, |v| v.len());
    add(&mut skipped, "compass_own_true_heading".into(), own_true);
    if own_true > 0 {
        notes.push(format!("{own_true} true headings (127250) of the compass (source {compass}) are its magnetic heading plus the variation: not a reference, not used"));
    }
    // A true heading that follows the compass's magnetic heading to within
    // RELAY_SPREAD_DEG is the compass relayed (a display or gateway adding
    // the variation): never a reference.
    let mut compass_series = Series::new([Kind::Heading360]);
    for (t, v) in &magnetic {
        compass_series.push(*t, [v[0]]);
    }
    let relays: Vec<u8> = d.true_heading.iter().filter(|(_, v)| relays_compass(v, &compass_series, opts.max_age_s)).map(|(s, _)| *s).collect();
    for r in relays {
        let n = d.true_heading.remove(&r).map_or(0, |v| v.len());
        add(&mut skipped, "true_heading_relaying_the_compass".into(), n);
        notes.push(format!("the {n} true headings (127250) of source {r} follow the compass's magnetic heading to within {RELAY_SPREAD_DEG}° (RMS about their mean): the compass relayed with a variation, not a reference, not used"));
    }
    let reference = most(&d.true_heading);
    let true_heading = reference.and_then(|r| d.true_heading.remove(&r)).unwrap_or_default();
    let others: usize = d.true_heading.values().map(Vec::len).sum();
    if others > 0 {
        add(&mut skipped, "another_source_127250_true".into(), others);
        notes.push(format!("ref_heading_deg from source {} (the most true headings); the {others} of sources {:?} not used", reference.unwrap_or_default(), d.true_heading.keys().collect::<Vec<_>>()));
    }
    let mut choose = |map: &mut BySource<[f64; 2]>, pgn: u32, what: &str, prefer: [Option<u8>; 2]| {
        let src = prefer.into_iter().flatten().find(|s| map.contains_key(s)).or_else(|| most(map))?;
        let samples = map.remove(&src)?;
        let others: usize = map.values().map(Vec::len).sum();
        if others > 0 {
            add(&mut skipped, format!("another_source_{pgn}"), others);
            notes.push(format!("{what} ({pgn}) from source {src}; the {others} of sources {:?} not used", map.keys().collect::<Vec<_>>()));
        }
        Some((src, samples))
    };
    let attitude = choose(&mut d.attitude, pgn::ATTITUDE, "roll and pitch", [Some(compass), reference]);
    let rate = choose(&mut d.rate, pgn::RATE_OF_TURN, "rate of turn", [Some(compass), reference]);
    let cog = choose(&mut d.cog, pgn::COG_SOG_RAPID, "course and speed", [reference, None]);
    let position = choose(&mut d.position, pgn::POSITION_RAPID, "position", [reference, None]);
    // The rows.
    let by_field = !field.is_empty();
    let row_t: Vec<f64> = if by_field { field.iter().map(|s| s.0).collect() } else { magnetic.iter().map(|s| s.0).collect() };
    let Some(t0) = row_t.iter().copied().reduce(f64::min) else {
        return Err(Nmea2000Error::NoCompass { found: format!("only headings of the compass (source {compass}) that are not available") }.into());
    };
    let mut dropped = BTreeMap::new();
    let mut series = |samples: &[(f64, [f64; 2])], kinds: [Kind; 2], what: &'static str| {
        let mut s = Series::new(kinds);
        for (t, v) in samples {
            s.push(*t, *v);
        }
        dropped.insert(what, s.out_of_order);
        s
    };
    let heading3 = |i: usize| magnetic.iter().map(move |(t, v)| (*t, [v[0], v.get(i).copied().unwrap_or(f64::NAN)])).collect::<Vec<_>>();
    let compass_heading = series(&heading3(2), [Kind::Heading360, Kind::Linear], "127250_magnetic");
    let ref_heading = series(&true_heading, [Kind::Heading360, Kind::Linear], "127250_true");
    let att = series(attitude.as_ref().map_or(&[][..], |a| &a.1), [Kind::Angle180, Kind::Angle180], "127257");
    let rot = series(rate.as_ref().map_or(&[][..], |r| &r.1), [Kind::Linear, Kind::Linear], "127251");
    let course = series(cog.as_ref().map_or(&[][..], |c| &c.1), [Kind::Heading360, Kind::Linear], "129026");
    let pos = series(position.as_ref().map_or(&[][..], |p| &p.1), [Kind::Linear, Kind::Linear], "129025");
    for (what, n) in dropped {
        add(&mut skipped, format!("time_backwards_{what}"), n);
    }
    let age = opts.max_age_s;
    let at = |s: &Series<2>, t: f64, k: usize| s.at(t, age).map_or(f64::NAN, |v| v[k]);
    let n = row_t.len();
    let mut cols: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut put = |name: &'static str, v: f64| cols.entry(name).or_insert_with(|| Vec::with_capacity(n)).push(v);
    let variation_of_compass = magnetic.iter().any(|s| s.1[2].is_finite());
    for (i, &t) in row_t.iter().enumerate() {
        if by_field {
            let xyz = field.get(i).map_or([f64::NAN; 3], |s| s.1);
            for (k, name) in col::MAG.into_iter().enumerate() {
                put(name, xyz[k]);
            }
            put(col::COMPASS_HEADING_DEG, at(&compass_heading, t, 0));
        } else {
            put(col::COMPASS_HEADING_DEG, magnetic.get(i).map_or(f64::NAN, |s| s.1[0]));
        }
        put(col::VARIATION_DEG, if variation_of_compass { at(&compass_heading, t, 1) } else { at(&ref_heading, t, 1) });
        let (course_deg, speed) = (at(&course, t, 0), at(&course, t, 1));
        put(col::REF_HEADING_DEG, if true_heading.is_empty() { rules::course_at_speed_deg(course_deg, speed, opts.min_course_speed_mps) } else { at(&ref_heading, t, 0) });
        put(col::COURSE_DEG, course_deg);
        put(col::GPS_SPEED_MPS, speed);
        put(col::ROLL_DEG, at(&att, t, 0));
        put(col::PITCH_DEG, at(&att, t, 1));
        put(col::GYRO[2], at(&rot, t, 0));
        put(col::LAT_DEG, at(&pos, t, 0));
        put(col::LON_DEG, at(&pos, t, 1));
    }
    let (clock, zone_note) = clock(log.time, log.base_s + t0);
    // To the nanosecond: the timestamps' milliseconds without the f64
    // remainder of a time of day (0.098, not 0.09800000000177533).
    let mut b = Builder::new(Format::Nmea2000, row_t.iter().map(|t| ((t - t0) * 1e9).round() / 1e9).collect(), clock);
    let fmt = match log.format {
        TextFormat::Fast => "canboat FAST",
        TextFormat::Plain => "canboat PLAIN",
        TextFormat::Actisense => "Actisense N2K ASCII",
    };
    let src = |pgn: u32, s: u8, what: &str| format!("PGN {pgn} {what}, source {s} ({fmt})");
    if by_field {
        b.report.field_unit = Some("counts (Simnet 65350, units unpublished)".into());
        for (k, name) in col::MAG.into_iter().enumerate() {
            let axis = ["X", "Y", "Z"].get(k).copied().unwrap_or("");
            b.column(name, cols.remove(name).unwrap_or_default(), src(pgn::SIMNET_MAGNETIC_FIELD, compass, &format!("Simnet: Magnetic Field {axis}, int16 at byte {}, counts", 2 * k)), Role::Compass)?;
        }
        notes.push("mx, my, mz: PGN 65350 read as three little-endian int16 at bytes 0, 2, 4 (canboat's definition of this proprietary PGN is incomplete); counts in the maker's unpublished units and axes, kept as they are".into());
    }
    let heading_from = src(pgn::VESSEL_HEADING, compass, "Vessel Heading (reference magnetic), 0.0001 rad → °");
    b.column(col::COMPASS_HEADING_DEG, cols.remove(col::COMPASS_HEADING_DEG).unwrap_or_default(), heading_from, Role::Compass)?;
    let variation_from = match (variation_of_compass, reference) {
        (true, _) => src(pgn::VESSEL_HEADING, compass, "Vessel Heading variation"),
        (false, Some(r)) => src(pgn::VESSEL_HEADING, r, "Vessel Heading (true) variation"),
        (false, None) => String::new(),
    };
    b.column(col::VARIATION_DEG, cols.remove(col::VARIATION_DEG).unwrap_or_default(), variation_from, Role::Sensor)?;
    let ref_values = cols.remove(col::REF_HEADING_DEG).unwrap_or_default();
    let ref_rows = ref_values.iter().filter(|v| v.is_finite()).count();
    let (ref_from, ref_note) = match (reference, &cog) {
        (Some(r), _) => (src(pgn::VESSEL_HEADING, r, "Vessel Heading (reference true)"), format!("ref_heading_deg is source {r}'s true heading (127250): an instrument other than the compass (a satellite compass or a gyrocompass)")),
        (None, Some((c, _))) => (
            format!("{} at {} m/s or more", src(pgn::COG_SOG_RAPID, *c, "COG (true)"), opts.min_course_speed_mps),
            format!("ref_heading_deg is the course over ground where the speed over ground is {} m/s or more ({ref_rows} rows): course is not heading (in a current they differ by the crab angle)", opts.min_course_speed_mps),
        ),
        (None, None) => (String::new(), "no ref_heading_deg: no true heading of another source (127250) and no course over ground (129026)".into()),
    };
    b.column(col::REF_HEADING_DEG, ref_values, ref_from, Role::Reference)?;
    notes.push(ref_note);
    if let Some((c, _)) = &cog {
        b.column(col::COURSE_DEG, cols.remove(col::COURSE_DEG).unwrap_or_default(), src(pgn::COG_SOG_RAPID, *c, "COG (true), 0.0001 rad → °"), Role::Sensor)?;
        b.column(col::GPS_SPEED_MPS, cols.remove(col::GPS_SPEED_MPS).unwrap_or_default(), src(pgn::COG_SOG_RAPID, *c, "SOG, 0.01 m/s"), Role::Sensor)?;
    }
    if let Some((a, _)) = &attitude {
        b.column(col::ROLL_DEG, cols.remove(col::ROLL_DEG).unwrap_or_default(), src(pgn::ATTITUDE, *a, "Attitude roll, 0.0001 rad → °"), Role::Sensor)?;
        b.column(col::PITCH_DEG, cols.remove(col::PITCH_DEG).unwrap_or_default(), src(pgn::ATTITUDE, *a, "Attitude pitch, 0.0001 rad → °"), Role::Sensor)?;
    }
    if let Some((r, _)) = &rate {
        b.column(col::GYRO[2], cols.remove(col::GYRO[2]).unwrap_or_default(), src(pgn::RATE_OF_TURN, *r, "Rate of Turn, 3.125e-8 rad/s"), Role::Sensor)?;
        notes.push("gz is the rate of turn (127251): the rate of change of the heading, which is the body's yaw rate only when level (an approximation under roll and pitch)".into());
    }
    if let Some((p, _)) = &position {
        b.column(col::LAT_DEG, cols.remove(col::LAT_DEG).unwrap_or_default(), src(pgn::POSITION_RAPID, *p, "latitude, 1e-7°"), Role::Sensor)?;
        b.column(col::LON_DEG, cols.remove(col::LON_DEG).unwrap_or_default(), src(pgn::POSITION_RAPID, *p, "longitude, 1e-7°"), Role::Sensor)?;
    }
    let deviations = magnetic.iter().filter(|s| s.1[1].is_finite()).count();
    if deviations > 0 {
        notes.push(format!("{deviations} compass headings gave the compass's own deviation: present and NOT applied; compass_heading_deg is the sensor heading"));
    }
    if attitude.is_some() {
        notes.push("roll_deg, pitch_deg: NMEA 2000's Attitude signs (bow up, starboard down positive), taken as the body frame FRD's".into());
    }
    notes.extend(zone_note);
    b.note(format!("rows: one per {} of source {compass} ({fmt}{})", if by_field { "magnetic field sample (65350)" } else { "compass heading (127250, magnetic)" }, if log.format == TextFormat::Plain { format!(", {} CAN frames", log.frames) } else { String::new() }));
    for note in notes {
        b.note(note);
    }
    b.report.messages.extend(read);
    if other > 0 {
        b.report.messages.insert("other PGNs (not read)".into(), other);
    }
    for (kind, n) in skipped {
        b.skip(&kind, n);
    }
    b.finish()
}

/// The clock's words for rows counted from `t0` (in the log's time form),
/// and a note when the zone is not given.
fn clock(form: TimeForm, t0: f64) -> (String, Option<String>) {
    let tod = |s: f64| {
        let ms = (s.rem_euclid(86_400.0) * 1000.0).round() as i64;
        format!("{:02}:{:02}:{:02}.{:03}", ms / 3_600_000, ms / 60_000 % 60, ms / 1000 % 60, ms % 1000)
    };
    match form {
        TimeForm::DateTime { utc } => {
            let d = Date::from_days_since_epoch((t0 / 86_400.0).floor() as i64);
            let when = format!("{:04}-{:02}-{:02}T{}", d.year, d.month, d.day, tod(t0));
            if utc {
                (format!("s since {when}Z (UTC, the logger's timestamps)"), None)
            } else {
                (format!("s since {when} (the logger's timestamps, zone not given)"), Some("the timestamps give no zone (no Z): the start time is the logger's local time, or UTC".into()))
            }
        }
        TimeForm::Seconds => (format!("s since the logger's time {t0} s (timestamps in seconds, no date)"), None),
        TimeForm::TimeOfDay => (format!("s since {} (Actisense time of day, no date)", tod(t0)), None),
    }
}

/// The spread (RMS about the mean) of a true heading minus the compass's
/// magnetic heading under which the true heading is the compass relayed, °.
/// An independent sensor's differs by both sensors' noise (the triton log's
/// satellite compass: 0.22°).
pub const RELAY_SPREAD_DEG: f64 = 0.05;

/// Whether true headings follow the compass's heading (carried to their
/// times) to within [`RELAY_SPREAD_DEG`], over 10 pairs or more.
fn relays_compass(true_heading: &[(f64, [f64; 2])], compass: &Series<1>, max_age_s: f64) -> bool {
    let d: Vec<f64> = true_heading.iter().filter_map(|(t, v)| compass.at(*t, max_age_s).map(|c| rules::wrap180(v[0] - c[0]))).filter(|d| d.is_finite()).collect();
    if d.len() < 10 {
        return false;
    }
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let spread = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
    spread < RELAY_SPREAD_DEG
}

/// Counts `n` of `kind` (nothing when 0).
fn add(map: &mut BTreeMap<String, usize>, kind: String, n: usize) {
    if n > 0 {
        *map.entry(kind).or_default() += n;
    }
}

/// Adds a sample of source `src` at `t`.
fn push<T>(map: &mut BySource<T>, src: u8, t: f64, v: T) {
    map.entry(src).or_default().push((t, v));
}

/// The source with the most samples (the lowest address among equals).
fn most<T>(map: &BySource<T>) -> Option<u8> {
    map.iter().max_by_key(|(src, v)| (v.len(), std::cmp::Reverse(**src))).map(|(src, _)| *src)
}

/// `kind: n, …` for messages.
fn kinds(found: impl Iterator<Item = (String, usize)>) -> String {
    let text: Vec<String> = found.filter(|(_, n)| *n > 0).map(|(k, n)| format!("{k}: {n}")).collect();
    if text.is_empty() {
        "nothing (an empty file)".into()
    } else {
        text.join(", ")
    }
}

#[cfg(test)]
mod tests;
