//! The import: the line pass, the elections, the time rule, and the rows
//! and report.

use std::io::Read;
use std::path::Path;

use super::election::{independent_hdt_only, one_source};
use super::sentence::{for_each_line, parse_line, Line, Outcome, Partial, Sentence};
use crate::data::table::col;
use super::timing::{clock_text, times};
use super::{bump, Date, ImportOptions, Imported, NmeaError, NmeaReport, Reference, MAGNETIC_COMPASS_TALKER, MAX_DATE_JUMP_S, MAX_KEYS, MAX_LINE_BYTES, MAX_SPREAD_GAP_S, TIME_RULE};

/// A sentence kept for the time pass.
pub(super) struct Kept {
    pub(super) talker: String,
    pub(super) sentence: Sentence,
}

/// What the line pass gathered besides the report.
#[derive(Default)]
struct Gathered {
    kept: Vec<Kept>,
    /// Well-framed `$` sentences (read, bad checksum, unknown, partial in
    /// their fields).
    dollar_framed: usize,
    bang: usize,
    too_long_lines: usize,
    first_line: Option<String>,
    hdg_deviation: (usize, f64),
    zda_two_digit_year: usize,
}

fn gather<R: Read>(reader: R, path: &Path, report: &mut NmeaReport) -> Result<(Gathered, u64, u64), NmeaError> {
    let mut g = Gathered::default();
    let (total, binary) = for_each_line(reader, |line| {
        let Some(line) = line else {
            report.lines += 1;
            report.partial += 1;
            bump(&mut report.partial_reasons, Partial::TooLong.name());
            g.too_long_lines += 1;
            return;
        };
        let parsed = parse_line(line);
        if parsed == Line::Blank {
            return;
        }
        report.lines += 1;
        if g.first_line.is_none() {
            g.first_line = Some(String::from_utf8_lossy(&line[..line.len().min(60)]).into_owned());
        }
        let Line::Sentence { start, prefixed, no_checksum, outcome } = parsed else {
            report.non_nmea_lines += 1;
            return;
        };
        report.sentences += 1;
        report.prefixed_lines += usize::from(prefixed);
        report.missing_checksum += usize::from(no_checksum);
        if start == '!' {
            g.bang += 1;
        }
        let framed = match &outcome {
            Outcome::Partial(p) => p.framed(),
            _ => true,
        };
        if start == '$' && framed {
            g.dollar_framed += 1;
        }
        match outcome {
            Outcome::BadChecksum { .. } => report.bad_checksum += 1,
            Outcome::Partial(p) => {
                report.partial += 1;
                bump(&mut report.partial_reasons, p.name());
            }
            Outcome::Unknown(name) => {
                report.unknown += 1;
                bump(&mut report.unknown_types, &name);
            }
            Outcome::Read { talker, sentence } => {
                if sentence.is_void() {
                    report.void_fixes += 1;
                } else if sentence.is_empty() {
                    report.empty_values += 1;
                } else {
                    if let Sentence::Hdg { deviation_deg: Some(d), .. } = sentence {
                        if d != 0.0 {
                            g.hdg_deviation.0 += 1;
                            g.hdg_deviation.1 = g.hdg_deviation.1.max(d.abs());
                        }
                    }
                    if let Sentence::Zda { two_digit_year: true, .. } = sentence {
                        g.zda_two_digit_year += 1;
                    }
                    g.kept.push(Kept { talker, sentence });
                }
            }
        }
    })
    .map_err(|source| NmeaError::Io { path: path.into(), source })?;
    Ok((g, total, binary))
}

/// What the input looked like, for [`NmeaError::NotNmea`].
fn looked_like(g: &Gathered, report: &NmeaReport, total: u64, binary: u64) -> String {
    if total == 0 {
        return "the file is empty (0 bytes)".into();
    }
    if binary * 10 > total {
        return format!("{total} bytes, {:.0} % of them not text: a binary file, not an NMEA 0183 text log", 100.0 * binary as f64 / total as f64);
    }
    if g.bang > 0 {
        return format!("{} `!` sentences (AIS, e.g. `!AIVDM`) and no `$` sentence: nothing here is a compass or a GPS", g.bang);
    }
    if report.lines == g.too_long_lines && g.too_long_lines > 0 {
        return format!("{} line(s) longer than {MAX_LINE_BYTES} bytes and nothing else (an NMEA sentence is at most 82 characters)", g.too_long_lines);
    }
    if report.lines == 0 {
        return "only blank lines".into();
    }
    let first = g.first_line.as_deref().unwrap_or("");
    if report.sentences > 0 {
        return format!("{} lines, {} with a `$` but none a well-formed sentence (first line: {first:?})", report.lines, report.sentences);
    }
    format!("{} lines, no line holds a `$` sentence (first line: {first:?})", report.lines)
}

/// A one-line account of the sentences refused, for errors.
fn refused(report: &NmeaReport) -> String {
    let types: Vec<String> = report.unknown_types.iter().take(8).map(|(k, n)| format!("{k} {n}")).collect();
    format!(
        "{} sentences: {} bad checksum, {} partial, {} unknown ({}), {} void fixes, {} empty",
        report.sentences,
        report.bad_checksum,
        report.partial,
        report.unknown,
        types.join(", "),
        report.void_fixes,
        report.empty_values
    )
}


/// Imports a log from any reader (`path` names it in errors).
pub fn import_reader<R: Read>(reader: R, path: &Path, opts: &ImportOptions) -> Result<Imported, NmeaError> {
    if let Some(t) = &opts.reference_talker {
        if !(t.len() == 2 && t.bytes().all(|b| b.is_ascii_uppercase() || b.is_ascii_digit())) {
            return Err(NmeaError::BadTalker(t.clone()));
        }
    }
    let mut report = NmeaReport { time_rule: TIME_RULE.to_string(), ..NmeaReport::default() };
    let (mut g, total, binary) = gather(reader, path, &mut report)?;
    if g.dollar_framed == 0 {
        return Err(NmeaError::NotNmea { looked_like: looked_like(&g, &report, total, binary) });
    }
    let heading = |k: &Kept| matches!(k.sentence, Sentence::Hdg { .. } | Sentence::Hdm { .. } | Sentence::Hdt { .. });
    let course = |k: &Kept| matches!(k.sentence, Sentence::Rmc { course_deg: Some(_), .. } | Sentence::Vtg { course_deg: Some(_), .. });
    if !g.kept.iter().any(|k| heading(k) || course(k)) {
        return Err(NmeaError::NothingToCalibrate { detail: format!("no heading sentence (HDG, HDM, HDT) and no GPS course (RMC, VTG) among {}", refused(&report)) });
    }
    if !g.kept.iter().any(|k| k.sentence.stamp().is_some()) {
        return Err(NmeaError::NoTime { detail: refused(&report) });
    }
    let mut notes = Vec::new();
    let (compass, others, names) = one_source(&mut g.kept, &["HDG", "HDM"]);
    report.other_source += others;
    if !names.is_empty() {
        notes.push(format!("compass_heading_deg is from {} only; the headings of {} are another compass (or another sentence of it) and were not used", compass.as_deref().unwrap_or(""), names.join(", ")));
    }
    let compass_talker = compass.as_deref().map_or(MAGNETIC_COMPASS_TALKER, |c| &c[..2]);
    if let Some(t) = opts.reference_talker.as_deref().filter(|t| *t == compass_talker || *t == MAGNETIC_COMPASS_TALKER) {
        return Err(NmeaError::ReferenceIsTheCompass { talker: t.to_string(), compass: compass.clone().unwrap_or_else(|| format!("{t}: a magnetic compass")) });
    }
    notes.extend(independent_hdt_only(&mut g.kept, compass_talker, opts.reference_talker.as_deref(), &mut report));
    let (true_source, others, names) = one_source(&mut g.kept, &["HDT"]);
    report.other_source += others;
    if !names.is_empty() {
        notes.push(format!("ref_heading_deg is from {} only; the HDT of {} were not used", true_source.as_deref().unwrap_or(""), names.join(", ")));
    }
    let (t, dated) = times(&g.kept, &mut report);
    let Some(start) = t.iter().flatten().copied().reduce(f64::min) else {
        return Err(NmeaError::NoTime { detail: refused(&report) });
    };
    let has_hdt = g.kept.iter().zip(&t).any(|(k, t)| t.is_some() && matches!(k.sentence, Sentence::Hdt { .. }));
    report.reference = if has_hdt { Reference::Hdt } else { Reference::None };
    // The rows.
    const NAMES: [&str; 9] =
        [col::T, col::COMPASS_HEADING_DEG, col::VARIATION_DEG, col::REF_HEADING_DEG, col::COURSE_DEG, col::GPS_SPEED_MPS, col::LAT_DEG, col::LON_DEG, col::SPEED_MPS];
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); NAMES.len()];
    let mut gps_talkers: Vec<&str> = Vec::new();
    let mut sources: Vec<Vec<String>> = vec![Vec::new(); NAMES.len()];
    for (k, t) in g.kept.iter().zip(&t) {
        let Some(t) = *t else { continue };
        let mut row = [f64::NAN; 9];
        match k.sentence {
            Sentence::Hdg { heading_deg, variation_deg, .. } => {
                row[1] = heading_deg.unwrap_or(f64::NAN);
                row[2] = variation_deg.unwrap_or(f64::NAN);
            }
            Sentence::Hdm { heading_deg } => row[1] = heading_deg.unwrap_or(f64::NAN),
            Sentence::Hdt { heading_deg } => row[3] = heading_deg.unwrap_or(f64::NAN),
            Sentence::Rmc { lat_deg, lon_deg, speed_mps, course_deg, variation_deg, .. } => {
                row[2] = variation_deg.unwrap_or(f64::NAN);
                row[4] = course_deg.unwrap_or(f64::NAN);
                row[5] = speed_mps.unwrap_or(f64::NAN);
                row[6] = lat_deg.unwrap_or(f64::NAN);
                row[7] = lon_deg.unwrap_or(f64::NAN);
                if !has_hdt {
                    row[3] = crate::data::import::rules::course_at_speed_deg(row[4], row[5], opts.min_course_speed_mps);
                }
            }
            Sentence::Vtg { course_deg, speed_mps, .. } => {
                row[4] = course_deg.unwrap_or(f64::NAN);
                row[5] = speed_mps.unwrap_or(f64::NAN);
                if !has_hdt {
                    row[3] = crate::data::import::rules::course_at_speed_deg(row[4], row[5], opts.min_course_speed_mps);
                }
            }
            Sentence::Gga { lat_deg, lon_deg, .. } | Sentence::Gll { lat_deg, lon_deg, .. } => {
                row[6] = lat_deg.unwrap_or(f64::NAN);
                row[7] = lon_deg.unwrap_or(f64::NAN);
            }
            Sentence::Vhw { speed_mps } => row[8] = speed_mps.unwrap_or(f64::NAN),
            Sentence::Zda { .. } => {}
        }
        let gives_row = row[1..].iter().any(|v| v.is_finite());
        if gives_row || k.sentence.stamp().is_some() {
            *report.used.entry(k.sentence.kind().to_string()).or_default() += 1;
        }
        if matches!(k.sentence, Sentence::Rmc { .. } | Sentence::Vtg { .. } | Sentence::Gga { .. } | Sentence::Gll { .. }) && !gps_talkers.contains(&k.talker.as_str()) {
            gps_talkers.push(&k.talker);
        }
        if !gives_row {
            continue;
        }
        row[0] = t - start;
        for (c, v) in columns.iter_mut().zip(row) {
            c.push(v);
        }
        for (c, v) in row.iter().enumerate().skip(1) {
            let source = format!("{}{}", k.talker, k.sentence.kind());
            if v.is_finite() && !sources[c].contains(&source) && sources[c].len() < MAX_KEYS {
                sources[c].push(source);
            }
        }
    }
    report.rows = columns[0].len();
    let with = |c: usize| columns[c].iter().filter(|v| v.is_finite()).count();
    if with(1) + with(3) + with(4) == 0 {
        return Err(NmeaError::NothingToCalibrate {
            detail: format!(
                "no heading or course could be timed ({} before the first timed sentence, {} after the last, {} in gaps over {MAX_SPREAD_GAP_S} s)",
                report.untimed_before_first_time, report.untimed_after_last_time, report.untimed_in_gaps
            ),
        });
    }
    if !has_hdt && with(3) > 0 {
        report.reference = Reference::Course;
    }
    // The report's words.
    let start_day = (start / 86_400.0).floor();
    let start_tod = start - start_day * 86_400.0;
    report.start_time_of_day_utc = clock_text(start_tod);
    if dated {
        let d = Date::from_days_since_epoch(start_day as i64);
        report.start_utc = Some(format!("{:04}-{:02}-{:02}T{}Z", d.year, d.month, d.day, clock_text(start_tod)));
    } else {
        notes.push("the log has no date (no RMC date, no ZDA with a four-digit year): t counts from the first time of day; start_utc is unknown".into());
    }
    report.duration_s = columns[0].last().copied().unwrap_or(0.0);
    report.compass_source = compass.clone();
    if let Some(source) = compass.as_deref().filter(|s| s.ends_with("HDM")) {
        notes.push(format!("compass_heading_deg is {source}'s magnetic heading, taken as the compass's own reading: if the compass applies its own deviation table, the swing fits only what remains"));
    }
    if g.hdg_deviation.0 > 0 {
        notes.push(format!(
            "{} HDG sentences gave the compass's own deviation (up to {}°): present and NOT applied; compass_heading_deg is the sensor heading",
            g.hdg_deviation.0, g.hdg_deviation.1
        ));
    }
    if report.date_jumps > 0 {
        notes.push(format!(
            "{} RMC/ZDA dated more than {MAX_DATE_JUMP_S} s from the dated sentences before and after them (which agree with each other): a bad date, not used; the rest of the log is timed without them",
            report.date_jumps
        ));
    }
    if g.zda_two_digit_year > 0 {
        notes.push(format!("{} ZDA sentences gave a two-digit year: their date was not used (their time of day was)", g.zda_two_digit_year));
    }
    if report.missing_checksum > 0 {
        notes.push(format!("{} sentences had no *hh checksum: read without verification", report.missing_checksum));
    }
    if report.prefixed_lines > 0 {
        notes.push(format!("{} lines had text before the `$` (a logger's prefix?): skipped, the sentence read from its `$`", report.prefixed_lines));
    }
    if gps_talkers.len() > 1 {
        notes.push(format!("GPS sentences from {} talkers ({}): one receiver assumed", gps_talkers.len(), gps_talkers.join(", ")));
    }
    notes.push(match report.reference {
        Reference::Hdt => format!("ref_heading_deg is {}'s true heading", true_source.as_deref().unwrap_or("HDT")),
        Reference::Course => format!(
            "ref_heading_deg is the GPS course over ground where its sentence gives a ground speed of {} m/s or more ({} rows): course is not heading (in a current they differ by the crab angle)",
            opts.min_course_speed_mps,
            with(3)
        ),
        Reference::None => format!("no ref_heading_deg: no HDT, and no GPS course at a ground speed of {} m/s or more given in the same sentence", opts.min_course_speed_mps),
    });
    report.notes = notes;
    let keep: Vec<usize> = (0..NAMES.len()).filter(|&c| c == 0 || with(c) > 0).collect();
    report.columns = keep.iter().map(|&c| NAMES[c].to_string()).collect();
    for &c in keep.iter().filter(|&&c| c > 0) {
        let mut text = sources[c].join(", ");
        if c == 3 && report.reference == Reference::Course {
            text += &format!(" (course over ground at {} m/s or more)", opts.min_course_speed_mps);
        }
        report.column_sources.insert(NAMES[c].to_string(), text);
    }
    let mut columns: Vec<Option<Vec<f64>>> = columns.into_iter().map(Some).collect();
    let columns = keep.iter().filter_map(|&c| columns[c].take().map(|v| (NAMES[c], v))).collect();
    Ok(Imported { columns, report })
}

/// Imports a log from memory.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, NmeaError> {
    import_reader(bytes, Path::new("(memory)"), opts)
}

/// Reads a log file and imports it.
pub fn import_file(path: &Path, opts: &ImportOptions) -> Result<Imported, NmeaError> {
    let file = std::fs::File::open(path).map_err(|source| NmeaError::Io { path: path.into(), source })?;
    import_reader(std::io::BufReader::new(file), path, opts)
}
