//! Hostile cases: input. One way in (mechanism 1): a recording is
//! read and judged the same way by every command; and `merge`'s part of
//! mechanisms 4, 6 and 7 (bounded by the logs, a given offset checked
//! against the data, a search stopping at its window's edge said).

use std::path::{Path, PathBuf};

use crate::{data, magcal, p};

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn refused(o: &std::process::Output) -> String {
    assert!(!o.status.success(), "accepted: {}", stderr(o));
    let e = stderr(o);
    assert!(!e.contains("panicked"), "{e}");
    e
}

fn ok(o: &std::process::Output) -> String {
    assert!(o.status.success(), "{}", stderr(o));
    stderr(o)
}

/// `file` with the cells of `columns` changed by `f` (the header kept).
fn rewrite(file: &Path, out: &Path, f: impl Fn(&str, f64) -> Option<f64>) {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut s = header.join(",") + "\n";
    for line in lines {
        let cells: Vec<String> = line
            .split(',')
            .zip(&header)
            .map(|(c, h)| match c.parse::<f64>().ok().and_then(|v| f(h, v)) {
                Some(v) => format!("{v}"),
                None => c.to_string(),
            })
            .collect();
        s += &(cells.join(",") + "\n");
    }
    std::fs::write(out, s).unwrap();
}

/// A calibration of BROAD-05 (the README's fit: `--field-nt 44204`, model
/// auto).
fn broad05_cal(dir: &Path) -> PathBuf {
    let cal = dir.join("cal.json");
    ok(&magcal(&["fit", "--input", p(&data("broad-05/05_calib.csv")), "--field-nt", "44204", "--out", p(&cal)]));
    cal
}

/// `apply` on BROAD-05's validation part with roll and pitch in
/// radians said 141 rows `ok` at 9.9° against σ 1.9° (`fit` refused the
/// same columns, `apply` read them as degrees). Through the one way in,
/// every command refuses them, saying how to give their unit; given as
/// radians they are converted, and `apply` reads what it read in degrees.
#[test]
fn roll_and_pitch_in_radians_are_refused_by_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let cal = broad05_cal(dir.path());
    let radians = dir.path().join("val_rad.csv");
    rewrite(&data("broad-05/05_validate.csv"), &radians, |h, v| matches!(h, "roll_deg" | "pitch_deg").then(|| v.to_radians()));
    let out = dir.path().join("o.csv");
    let e = refused(&magcal(&["apply", "--input", p(&radians), "--cal", p(&cal), "--out", p(&out)]));
    assert!(e.contains("look like radians") && e.contains("roll_deg=roll_deg:rad"), "{e}");
    assert!(!out.exists());
    for cmd in [&["card", "--cal", p(&cal), "--input", p(&radians)][..], &["fit", "--input", p(&radians), "--field-nt", "44204", "--model", "sphere"][..]] {
        let e = refused(&magcal(cmd));
        assert!(e.contains("look like radians"), "{cmd:?}: {e}");
    }
    // Said to be radians: read as the degrees they are (the same summary
    // as the original file's).
    let summary = |input: &Path, extra: &[&str]| -> serde_json::Value {
        let o = magcal(&[&["apply", "--input", p(input), "--cal", p(&cal), "--out", p(&out), "--json"][..], extra].concat());
        ok(&o);
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let given = summary(&radians, &["--columns", "roll_deg=roll_deg:rad,pitch_deg=pitch_deg:rad"]);
    let degrees = summary(&data("broad-05/05_validate.csv"), &[]);
    assert_eq!(given["rows_per_state"], degrees["rows_per_state"]);
    let (a, b) = (given["heading_rms_deg"].as_f64().unwrap(), degrees["heading_rms_deg"].as_f64().unwrap());
    // Only the cells' 17 printed digits differ: measured equal to 1e-12.
    assert!((a - b).abs() < 1e-6, "{a} {b}");
}

/// A header with `mx` twice was read silently (the first one);
/// two columns mapped to one header name too.
#[test]
fn duplicated_columns_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let twice = dir.path().join("twice.csv");
    let mut s = String::from("t,mx,my,mz,mx\n");
    for k in 0..50 {
        s += &format!("{},{},{},300,{}\n", k as f64 * 0.1, 100 + k, 200 - k, -(k as i64));
    }
    std::fs::write(&twice, &s).unwrap();
    let e = refused(&magcal(&["fit", "--input", p(&twice), "--field-nt", "50000", "--model", "sphere"]));
    assert!(e.contains("twice.csv: the header has `mx` 2 times") && e.contains("--columns"), "{e}");
    let one = dir.path().join("one.csv");
    std::fs::write(&one, s.replacen("t,mx,my,mz,mx", "t,mx,my,mz,other", 1)).unwrap();
    let e = refused(&magcal(&["fit", "--input", p(&one), "--field-nt", "50000", "--model", "sphere", "--columns", "mx=other,my=other"]));
    assert!(e.contains("`mx` and `my` would both be read from the header's `other`"), "{e}");
    let e = refused(&magcal(&["fit", "--input", p(&one), "--field-nt", "50000", "--model", "sphere", "--columns", "my=mx"]));
    assert!(e.contains("`mx` and `my` would both be read from the header's `mx`"), "{e}");
}

/// A simulated swing (36.9° N, 50.6° E, 2021) written with `edit` applied.
fn swing(dir: &Path, name: &str, edit: impl Fn(&mut host_tools::data::Recording)) -> PathBuf {
    let raw = dir.join("swing_raw.csv");
    if !raw.exists() {
        ok(&magcal(&["simulate", "swing", "--seed", "3", "--out", p(&raw)]));
    }
    let mut rec = host_tools::data::Recording::read(&raw).unwrap();
    edit(&mut rec);
    let out = dir.join(name);
    rec.write(&out).unwrap();
    out
}

const SITE: [&str; 6] = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];

/// Three GPS placeholder rows at lat/lon (0, 0) refused a whole
/// recording ("6616 km from the site"). They are no positions: dropped,
/// counted and said; the fit is the one without them.
#[test]
fn placeholder_fixes_at_zero_zero_are_dropped_and_counted() {
    let dir = tempfile::tempdir().unwrap();
    let with = swing(dir.path(), "zeros.csv", |r| {
        let (lat, lon) = (r.lat_deg.as_mut().unwrap(), r.lon_deg.as_mut().unwrap());
        for i in [0, 1, 2] {
            (lat[i], lon[i]) = (0.0, 0.0);
        }
    });
    let without = swing(dir.path(), "nan.csv", |r| {
        let (lat, lon) = (r.lat_deg.as_mut().unwrap(), r.lon_deg.as_mut().unwrap());
        for i in [0, 1, 2] {
            (lat[i], lon[i]) = (f64::NAN, f64::NAN);
        }
    });
    let fit = |input: &Path| {
        let out = dir.path().join("c.json");
        let o = magcal(&[&["fit", "--input", p(input), "--model", "axis", "--out", p(&out)][..], &SITE[..]].concat());
        let e = ok(&o);
        (e, std::fs::read_to_string(&out).unwrap())
    };
    let (e, doc) = fit(&with);
    assert!(e.contains("3 row(s) at lat/lon (0, 0)") && e.contains("taken as no position") && !e.contains("km from the site"), "{e}");
    assert_eq!(doc, fit(&without).1);
}

/// Mechanism 1: the recording's positions against the site, by
/// distance and by declination. A run drifting 2° of latitude north of
/// the site (222 km, within the 500 km refused by distance): IGRF-14's
/// declination there is 0.64° from the site's (`magcal igrf`: 5.26° at
/// 36.9° N, 50.6° E; 6.55° at 40.9° N): refused, kept with `--allow-weak`
/// and said.
#[test]
fn a_declination_change_beyond_the_limit_is_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let north = swing(dir.path(), "north.csv", |r| {
        let n = r.len();
        r.lat_deg = Some((0..n).map(|i| 36.9 + 2.0 * i as f64 / n as f64).collect());
        r.lon_deg = Some(vec![50.6; n]);
    });
    let e = refused(&magcal(&[&["fit", "--input", p(&north), "--model", "axis"][..], &SITE[..]].concat()));
    assert!(e.contains("the declination there is 0.6") && e.contains("0.5° allowed") && e.contains("--allow-weak"), "{e}");
    let cal = dir.path().join("north.json");
    let e = ok(&magcal(&[&["fit", "--input", p(&north), "--model", "axis", "--allow-weak", "--out", p(&cal)][..], &SITE[..]].concat()));
    assert!(e.contains("warning: ") && e.contains("kept as weak results are allowed"), "{e}");
    // Kept, it travels with the document (before: said on stderr only, and
    // `apply` used the document without a word).
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&cal).unwrap()).unwrap();
    let marks = doc["quality"]["allowed_weak"].as_array().expect("the mark");
    assert!(marks.len() == 1 && marks[0].as_str().unwrap().starts_with("fit: ") && marks[0].as_str().unwrap().contains("the declination there is 0.6"), "{marks:?}");
    let e = refused(&magcal(&["apply", "--input", p(&north), "--cal", p(&cal), "--out", p(&dir.path().join("north-applied.csv"))]));
    assert!(e.contains("north.json") && e.contains("only because weak results were allowed") && e.contains("declination there is 0.6") && e.contains("--allow-weak"), "{e}");
    // 1° north (111 km, 0.32°): a warning of the distance only.
    let near = swing(dir.path(), "near.csv", |r| {
        let n = r.len();
        r.lat_deg = Some((0..n).map(|i| 36.9 + 1.0 * i as f64 / n as f64).collect());
        r.lon_deg = Some(vec![50.6; n]);
    });
    let e = ok(&magcal(&[&["fit", "--input", p(&near), "--model", "axis"][..], &SITE[..]].concat()));
    assert!(e.contains("km from the site") && !e.contains("declination there"), "{e}");
}

// ---- merge ----

use host_tools::data::{BoardLog, MergeReport, NavLog};
use magcal_sim::field_test::{self, paper_site, SensorModel};
use magcal_sim::logs::{self, LogSplit, NavHeading};

/// The swing test (seed 7, 50 Hz board) split into a board log and a
/// navigation log of every `nav_every`-th row, the navigation clock
/// 33.3 s behind… ahead: `t_nav = t_board − 33.3 s` (as the merge tests).
fn split_logs(nav_every: usize) -> (BoardLog, NavLog) {
    let sim = field_test::swing(&SensorModel::paper_like(), &paper_site(), 7, 50.0).unwrap();
    logs::split(&sim, &LogSplit { offset_s: -33.3, drift_ppm: 0.0, nav_every, trim_s: (5.0, 5.0), seed: 7, nav_heading: NavHeading::Ahrs })
}

/// The logs written with their `t` multiplied by `board_k` and `nav_k`.
fn write_logs(dir: &Path, (board, nav): &(BoardLog, NavLog), board_k: f64, nav_k: f64) -> (PathBuf, PathBuf) {
    let (b, n) = (dir.join("board.csv"), dir.join("nav.csv"));
    BoardLog { t_s: board.t_s.iter().map(|t| t * board_k).collect(), ..board.clone() }.write(&b).unwrap();
    NavLog { t_s: nav.t_s.iter().map(|t| t * nav_k).collect(), ..nav.clone() }.write(&n).unwrap();
    (b, n)
}

fn merge_report(o: &std::process::Output) -> MergeReport {
    ok(o);
    serde_json::from_slice(&o.stdout).expect("the report")
}

/// Both logs' `t` in microseconds (ArduPilot's `TimeUS`) aborted
/// allocating 319 GB; in milliseconds with `--max-offset-s 1e8` it took
/// over 120 s and 1.5 GB. Each log's unit is found from its step (50 Hz
/// board: 20 000 µs or 20 ms; 10 Hz navigation: 100 000 µs or 100 ms),
/// converted and said; the offset is the one put in. A step two units
/// explain (a 1 Hz log in ms: 1 000, or 1 kHz in µs) is refused, naming
/// the option that settles it.
#[test]
fn merge_finds_the_logs_time_unit_or_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let logs = split_logs(5);
    let out = dir.path().join("rec.csv");
    for (k, unit, extra) in [(1e6, "microseconds", &[][..]), (1e3, "milliseconds", &["--max-offset-s", "1e8"][..])] {
        let (b, n) = write_logs(dir.path(), &logs, k, k);
        let started = std::time::Instant::now();
        let o = magcal(&[&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--json"][..], extra].concat());
        let r = merge_report(&o);
        // Measured: the offset within 1 ms (as in seconds), in a few seconds.
        assert!((r.offset_s + 33.3).abs() < 0.01, "{unit}: {r:?}");
        assert!(started.elapsed().as_secs_f64() < 60.0, "{unit}: {:?}", started.elapsed());
        let e = stderr(&o);
        assert_eq!(e.matches(&format!("`t` read as {unit}")).count(), 2, "{e}");
        if !extra.is_empty() {
            // The window that does not fit the logs is said, and cut to them.
            assert!(e.contains("the search window 0 ± 100000000 s reaches beyond the offsets at which the logs overlap"), "{e}");
        }
    }
    // A 1 Hz navigation log in ms: 1 000 per step is 1 s in ms or 1 ms in µs.
    let slow = split_logs(50);
    let (b, n) = write_logs(dir.path(), &slow, 1.0, 1e3);
    let e = refused(&magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out)]));
    assert!(e.contains("nav.csv: `t`'s median step is 1000") && e.contains("--nav-columns"), "{e}");
    let r = merge_report(&magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--json", "--nav-columns", "t=t:ms"]));
    assert!((r.offset_s + 33.3).abs() < 0.05, "{r:?}");
}

/// Mechanism 4: every allocation bounded by the input's size. A
/// board log whose clock jumps by 10⁹ s (the search's grids would need
/// 5·10¹⁰ points) is refused before any grid is made, naming the log, its
/// span and the step.
#[test]
fn merge_refuses_a_log_whose_span_its_rows_cannot_fill() {
    let dir = tempfile::tempdir().unwrap();
    let (mut board, nav) = split_logs(5);
    let half = board.t_s.len() / 2;
    board.t_s.iter_mut().skip(half).for_each(|t| *t += 1e9);
    let (b, n) = write_logs(dir.path(), &(board, nav), 1.0, 1.0);
    let e = refused(&magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&dir.path().join("r.csv"))]));
    assert!(e.contains("the board log spans 1.0") && e.contains(&format!("after data row {half}")) && e.contains("does its clock jump"), "{e}");
}

/// `merge` interpolated a 0.1 Hz navigation log across its 10 s
/// steps without a word (roll 9.6° RMS off). Now only gaps up to 2 s are
/// interpolated (`--max-nav-gap-s`): the rows between are written without
/// navigation, counted and said.
#[test]
fn a_slow_navigation_log_is_not_interpolated_across_long_gaps() {
    let dir = tempfile::tempdir().unwrap();
    let (b, n) = write_logs(dir.path(), &split_logs(500), 1.0, 1.0);
    let out = dir.path().join("rec.csv");
    let o = magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--offset-s", "-33.3", "--json"]);
    let r = merge_report(&o);
    // One board sample in 500 falls on a navigation row.
    assert!(r.rows_in_nav_gaps as f64 > 0.99 * r.rows as f64, "{r:?}");
    assert_eq!(r.nav_gap_limit_s, 2.0);
    assert!(stderr(&o).contains("is longer than the 2 s interpolated across"), "{}", stderr(&o));
    let rec = host_tools::data::Recording::read(&out).unwrap();
    let with_roll = rec.roll_deg.unwrap().iter().filter(|v| v.is_finite()).count();
    assert_eq!(with_roll, r.rows - r.rows_in_nav_gaps);
    // Asked for: interpolated across its 10 s steps.
    let r = merge_report(&magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--offset-s", "-33.3", "--json", "--max-nav-gap-s", "20"]));
    assert_eq!(r.rows_in_nav_gaps, 0, "{r:?}");
}

/// `merge --offset-s` with the wrong sign was used unchecked.
/// The data show −33.3 s; +33.3 s given is refused naming both, kept with
/// `--allow-weak` and said; the right one is taken without a word.
#[test]
fn a_given_offset_the_data_disagree_with_is_refused_unless_allowed() {
    let dir = tempfile::tempdir().unwrap();
    let (b, n) = write_logs(dir.path(), &split_logs(5), 1.0, 1.0);
    let out = dir.path().join("rec.csv");
    let args = |offset: &'static str| vec!["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--json", "--offset-s", offset];
    let e = refused(&magcal(&args("33.3")));
    assert!(e.contains("the clock offset given, 33.300 s") && e.contains("agree best at -33.30") && e.contains("--allow-weak"), "{e}");
    assert!(!out.exists());
    let o = magcal(&[&args("33.3")[..], &["--allow-weak"]].concat());
    let r = merge_report(&o);
    assert!(r.offset_s == 33.3 && r.warnings.len() == 1 && r.warnings[0].contains("kept as weak results are allowed"), "{r:?}");
    assert!(stderr(&o).contains("warning: the clock offset given"), "{}", stderr(&o));
    let o = magcal(&args("-33.3"));
    let r = merge_report(&o);
    assert!(r.warnings.is_empty() && !stderr(&o).contains("warning"), "{r:?}");
}

/// Mechanism 7: an offset found at its search window's edge is
/// said, and refused with `--strict`: the true −33.3 s searched within
/// 0 ± 33.7 s is found 0.4 s inside the window's end.
#[test]
fn an_offset_at_the_window_edge_is_said_and_refused_when_strict() {
    let dir = tempfile::tempdir().unwrap();
    let (b, n) = write_logs(dir.path(), &split_logs(5), 1.0, 1.0);
    let out = dir.path().join("rec.csv");
    let args = vec!["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--json", "--max-offset-s", "33.7"];
    let o = magcal(&args);
    let r = merge_report(&o);
    assert!((r.offset_s + 33.3).abs() < 0.01, "{r:?}");
    assert!(r.warnings.iter().any(|w| w.contains("of the end of the offsets searched")), "{r:?}");
    let e = refused(&magcal(&[&args[..], &["--strict"]].concat()));
    assert!(e.contains("end of the offsets searched") && e.contains("refused as strict"), "{e}");
    // Well inside the window: nothing said.
    let r = merge_report(&magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--json", "--strict"]));
    assert!(r.warnings.is_empty(), "{r:?}");
}

/// A clock jump was reported as "offset outside the window".
/// The navigation clock steps 100 s forward halfway: the two halves agree
/// at offsets 100 s apart, and the refusal names the jump, where and how
/// large. Stepping 3 600 s (a GPS time fix), the first half merges alone:
/// the jump is said, with the rows it left without navigation.
#[test]
fn a_clock_jump_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let jumped = |step_s: f64| {
        let (board, mut nav) = split_logs(5);
        let half = nav.t_s.len() / 2;
        nav.t_s.iter_mut().skip(half).for_each(|t| *t += step_s);
        (write_logs(dir.path(), &(board, nav), 1.0, 1.0), half)
    };
    let out = dir.path().join("r.csv");
    let ((b, n), half) = jumped(100.0);
    let e = refused(&magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out)]));
    assert!(e.contains("the navigation log's time steps from") && e.contains(&format!("after data row {half} (100.100 s")) && e.contains("clock jump"), "{e}");
    let ((b, n), half) = jumped(3600.0);
    let o = magcal(&["merge", "--board", p(&b), "--nav", p(&n), "--out", p(&out), "--json"]);
    let r = merge_report(&o);
    assert!(r.warnings.iter().any(|w| w.contains(&format!("after data row {half} (3600.100 s")) && w.contains("clock jump")), "{r:?}");
    assert!(r.rows_in_nav_gaps > r.rows / 3, "{r:?}");
}
