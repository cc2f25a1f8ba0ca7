//! The clock found on simulated logs with a known offset, the refusals and
//! the logs' reading.

use super::*;

/// The rotation body → NED of roll, pitch, heading in degrees (Z-Y-X),
/// row-major, multiplied out by hand (the test's own reference).
fn rotation(roll_deg: f64, pitch_deg: f64, heading_deg: f64) -> [f64; 9] {
    let (sr, cr) = roll_deg.to_radians().sin_cos();
    let (sp, cp) = pitch_deg.to_radians().sin_cos();
    let (sy, cy) = heading_deg.to_radians().sin_cos();
    [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, -sp, cp * sr, cp * cr]
}

/// A vehicle turning in a constant field (NED nT): navigation at 10 Hz
/// on its clock from `nav_start_s` for `len_s`, the board at 50 Hz on
/// a clock `offset_s` behind (`t_nav = t_board + offset_s`), a linear
/// sensor with hard iron.
fn logs(offset_s: f64, nav_start_s: f64, len_s: f64, turning: bool) -> (BoardLog, NavLog) {
    let att = |t: f64| {
        if turning {
            (20.0 * (0.3 * t).sin(), 8.0 * (0.17 * t).sin(), (90.0 * (0.05 * t).sin() + 30.0 * (0.23 * t + 1.0).sin()).rem_euclid(360.0))
        } else {
            (1.0, -2.0, 100.0)
        }
    };
    logs_with(offset_s, nav_start_s, len_s, att)
}

/// [`logs`] with the attitude `att(t)` (roll, pitch, heading; degrees).
fn logs_with(offset_s: f64, nav_start_s: f64, len_s: f64, att: impl Fn(f64) -> (f64, f64, f64)) -> (BoardLog, NavLog) {
    let f = [20_000.0, 1_000.0, 40_000.0];
    let field = |t: f64| {
        let (r, p, h) = att(t);
        let m = rotation(r, p, h);
        // Rᵀ·f, then gains and hard iron.
        let body = [0, 1, 2].map(|c| m[c] * f[0] + m[3 + c] * f[1] + m[6 + c] * f[2]);
        [0.2 * body[0] + 1500.0, 0.09 * body[1] - 700.0, 0.16 * body[2] + 300.0]
    };
    let nav_t: Vec<f64> = (0..(len_s * 10.0) as usize).map(|k| nav_start_s + k as f64 * 0.1).collect();
    let nav = NavLog {
        roll_deg: nav_t.iter().map(|&t| att(t).0).collect(),
        pitch_deg: nav_t.iter().map(|&t| att(t).1).collect(),
        heading_deg: Some(nav_t.iter().map(|&t| att(t).2).collect()),
        // GPS at the surface only: the first 30 s.
        ref_heading_deg: Some(nav_t.iter().map(|&t| if t < nav_start_s + 30.0 { att(t).2 } else { f64::NAN }).collect()),
        t_s: nav_t,
        ..NavLog::default()
    };
    let board_t: Vec<f64> = (0..((len_s + 40.0) * 50.0) as usize).map(|k| nav_start_s - offset_s - 20.0 + k as f64 * 0.02).collect();
    let board = BoardLog { mag: board_t.iter().map(|&t| field(t + offset_s)).collect(), t_s: board_t, temp_c: None, health: None };
    (board, nav)
}

#[test]
fn the_offset_is_found_and_nothing_is_extrapolated() {
    let (board, nav) = logs(-47.3, 500.0, 300.0, true);
    let m = merge(&board, &nav, Clock::default()).unwrap();
    let r = &m.report;
    eprintln!("offset error {:.2e} s (σ {:.1e} s), drift {:.1e} ppm, {} board samples outside", r.offset_s + 47.3, r.offset_sigma_s, r.drift_ppm, r.board_samples_outside_nav);
    // Noise-free logs: measured −0.91 µs (σ 0.24 µs) and 0.005 ppm; a
    // bias of a millisecond on the offset is a thousand times that.
    assert!((r.offset_s + 47.3).abs() < 5e-6 && r.drift_ppm.abs() < 0.03, "{r:?}");
    // 20 s of board samples before and after the navigation log are left out.
    assert!((r.board_samples_outside_nav as f64 - 40.0 * 50.0).abs() < 10.0, "{r:?}");
    let rec = &m.recording;
    let t = rec.t_s.as_ref().unwrap();
    assert!(t[0] >= nav.t_s[0] && *t.last().unwrap() <= *nav.t_s.last().unwrap());
    // GPS course only while both neighbours have it: the first 30 s.
    let gps = rec.ref_heading_deg.as_ref().unwrap();
    assert!(t.iter().zip(gps).all(|(t, g)| g.is_finite() == (*t <= nav.t_s[0] + 29.9 + 1e-6)), "GPS where it was");
    // Headings interpolated the short way round stay within 0…360.
    assert!(m.extra.heading_deg.as_ref().unwrap().iter().all(|h| (0.0..360.0).contains(h)));
}

#[test]
fn a_given_offset_is_used_as_given() {
    let (board, nav) = logs(12.0, 0.0, 100.0, false);
    let m = merge(&board, &nav, Clock::Given { offset_s: 12.0, drift_ppm: 0.0 }).unwrap();
    assert!(!m.report.estimated && m.report.offset_s == 12.0);
    assert_eq!(m.recording.roll_deg.as_ref().unwrap()[0], 1.0);
}

/// A given offset with the wrong sign was once used unchecked. The
/// data show −47.3 s: +47.3 s is refused naming both, kept when weak
/// results are allowed (and said); the right one passes unsaid.
#[test]
fn a_given_offset_is_checked_against_the_data() {
    let (board, nav) = logs(-47.3, 500.0, 300.0, true);
    let given = |offset_s: f64, allow_weak: bool| merge_with(&board, &nav, Clock::Given { offset_s, drift_ppm: 0.0 }, &MergeOptions { allow_weak, ..MergeOptions::default() });
    let e = given(47.3, false).unwrap_err();
    let MergeError::GivenOffsetDisagrees { found_s, diff_s, .. } = e else { panic!("{e}") };
    // Measured: found −0.07 µs from the truth, the difference 0.9 µs
    // from the 94.6 s put in.
    eprintln!("found {:.2e} s off, difference {:.2e} s off", found_s + 47.3, diff_s - 94.6);
    assert!((found_s + 47.3).abs() < 5e-7 && (diff_s - 94.6).abs() < 5e-6, "{e}");
    let m = given(47.3, true).unwrap();
    assert!(m.report.offset_s == 47.3 && m.report.warnings.len() == 1, "{:?}", m.report);
    let m = given(-47.3, false).unwrap();
    assert!(m.report.warnings.is_empty() && m.report.notes.is_empty(), "{:?}", m.report);
}

/// The navigation is interpolated across gaps up to the limit only: a
/// 10 Hz log with its rows at 50.0 … 52.9 s cut out leaves the board
/// samples strictly between 49.9 s and 53.0 s without navigation
/// (50 Hz: 3.1 s × 50 − 1 = 154).
#[test]
fn navigation_gaps_beyond_the_limit_are_left_empty_and_counted() {
    let (board, mut nav) = logs(0.0, 0.0, 100.0, true);
    let keep: Vec<bool> = nav.t_s.iter().map(|t| !(50.0..53.0).contains(t)).collect();
    let cut = |v: &[f64]| v.iter().zip(&keep).filter(|(_, k)| **k).map(|(x, _)| *x).collect::<Vec<f64>>();
    nav = NavLog { t_s: cut(&nav.t_s), roll_deg: cut(&nav.roll_deg), pitch_deg: cut(&nav.pitch_deg), heading_deg: nav.heading_deg.as_deref().map(cut), ref_heading_deg: nav.ref_heading_deg.as_deref().map(cut), ..NavLog::default() };
    let clock = Clock::Given { offset_s: 0.0, drift_ppm: 0.0 };
    let m = merge_with(&board, &nav, clock, &MergeOptions::default()).unwrap();
    assert_eq!(m.report.rows_in_nav_gaps, 154, "{:?}", m.report);
    assert_eq!(m.report.nav_gap_limit_s, MAX_NAV_GAP_S);
}

#[test]
fn logs_that_do_not_overlap_are_refused() {
    let (board, mut nav) = logs(0.0, 0.0, 100.0, true);
    for t in nav.t_s.iter_mut() {
        *t += 5000.0;
    }
    let e = merge(&board, &nav, Clock::default()).unwrap_err();
    assert!(matches!(e, MergeError::NoOverlap { .. }), "{e}");
    assert!(e.to_string().contains("do not overlap"), "{e}");
    let e = merge(&board, &nav, Clock::Given { offset_s: 0.0, drift_ppm: 0.0 }).unwrap_err();
    assert!(matches!(e, MergeError::NoOverlap { .. }), "{e}");
}

#[test]
fn logs_without_rotation_are_refused() {
    let (board, nav) = logs(3.0, 0.0, 200.0, false);
    let e = merge(&board, &nav, Clock::default()).unwrap_err();
    assert!(matches!(e, MergeError::NoRotation(_)), "{e}");
    assert!(e.to_string().contains("give the clock offset"), "{e}");
}

/// A search window of ± 0 s with the true offset 37.25 s
/// wrote a recording 37 s out of line; now a window too narrow to tell
/// where the logs agree best is refused.
#[test]
fn a_search_window_too_narrow_is_refused() {
    let (board, nav) = logs(37.25, 0.0, 200.0, true);
    let e = merge(&board, &nav, Clock::Estimate { center_s: 0.0, max_offset_s: 0.0 }).unwrap_err();
    assert!(matches!(e, MergeError::SearchWindowTooNarrow { .. }) && e.to_string().contains("too narrow"), "{e}");
}

/// `--max-offset-s 1e300` once panicked (capacity overflow) and
/// 1e5 ran for minutes; the search now stops where the logs stop
/// overlapping, so any window finishes as fast as the logs' spans allow.
#[test]
fn a_huge_search_window_is_bounded_by_the_logs() {
    let (board, nav) = logs(-47.3, 500.0, 200.0, true);
    for max_offset_s in [1e5, 1e300] {
        let started = std::time::Instant::now();
        let m = merge(&board, &nav, Clock::Estimate { center_s: 0.0, max_offset_s }).unwrap();
        eprintln!("window ± {max_offset_s} s: offset error {:.2e} s in {:?}", m.report.offset_s + 47.3, started.elapsed());
        // Measured: 3.4 µs off, in well under a second (debug build);
        // the time limit guards against a search that grows with the
        // window (minutes before), with room for a loaded CI machine.
        assert!((m.report.offset_s + 47.3).abs() < 2e-5, "{max_offset_s}: {:?}", m.report);
        assert!(started.elapsed().as_secs_f64() < 30.0, "{max_offset_s}: {:?}", started.elapsed());
    }
}

/// A true offset beyond the search window once said "turn the
/// vehicle"; now the refusal names the window and how to move it.
#[test]
fn an_offset_beyond_the_window_names_the_window() {
    let (board, nav) = logs(-47.3, 500.0, 200.0, true);
    let e = merge(&board, &nav, Clock::Estimate { center_s: 0.0, max_offset_s: 20.0 }).unwrap_err();
    assert!(matches!(e, MergeError::OutsideWindow { .. } | MergeError::NoAgreement { .. } | MergeError::NotUnique { .. }), "{e}");
    let text = e.to_string();
    assert!(text.contains("0 ± 20 s") && text.contains("search window"), "{text}");
}

/// Without a heading column the tilt alone times the logs (the field's
/// component along the down direction is constant): noise-free logs,
/// the offset put in found within 1 µs (measured: 0.14 µs).
#[test]
fn without_a_heading_the_tilt_times_the_logs() {
    let (board, mut nav) = logs(23.4, 100.0, 300.0, true);
    (nav.heading_deg, nav.ref_heading_deg) = (None, None);
    let m = merge(&board, &nav, Clock::default()).unwrap();
    let r = &m.report;
    assert_eq!(r.timed_by, Some(SharedSignal::Tilt), "{r:?}");
    assert!(r.signals.contains(&SharedSignal::Tilt) && !r.signals.contains(&SharedSignal::Attitude), "{r:?}");
    eprintln!("offset error {:.2e} s", r.offset_s - 23.4);
    assert!((r.offset_s - 23.4).abs() < 1e-6, "{r:?}");
    assert!(r.margin_sigma.is_none_or(|m| m >= judge::MIN_MARGIN_SIGMA), "{r:?}");
}

/// A motion that repeats every 30 s, within the ±120 s searched: the
/// logs agree as well 30 s away as at the true offset, and the merge
/// is refused naming two offsets, both the true one give or take whole
/// periods (the truth: 12 s; measured: 42 s and 72 s, 0.0 σ apart).
#[test]
fn a_motion_that_repeats_within_the_window_is_refused_naming_both_offsets() {
    let w = |t: f64| std::f64::consts::TAU * t / 30.0;
    let att = |t: f64| (20.0 * w(t).sin(), 8.0 * (2.0 * w(t) + 1.0).sin(), (100.0 + 60.0 * w(t).cos()).rem_euclid(360.0));
    let (board, nav) = logs_with(12.0, 0.0, 400.0, att);
    let e = merge(&board, &nav, Clock::default()).unwrap_err();
    let MergeError::NotUnique { best_s, runner_up_s, .. } = e else { panic!("{e}") };
    let periods = |x: f64| (x - 12.0) / 30.0;
    for x in [best_s, runner_up_s] {
        assert!((periods(x) - periods(x).round()).abs() < 0.02, "{x} is not 12 s give or take whole periods: {e}");
    }
    assert!((best_s - runner_up_s).abs() > 15.0, "{e}");
    let text = e.to_string();
    assert!(text.contains(&format!("{best_s:.2} s")) && text.contains(&format!("{runner_up_s:.2} s")) && text.contains("centre a narrower window"), "{text}");
}

fn read_board(text: &str) -> Result<BoardLog, RecordingError> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("board.csv");
    std::fs::write(&p, text).unwrap();
    BoardLog::read(&p)
}

fn read_nav(text: &str) -> Result<NavLog, RecordingError> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nav.csv");
    std::fs::write(&p, text).unwrap();
    NavLog::read(&p)
}

#[test]
fn missing_columns_and_time_running_backwards_are_refused() {
    let e = read_board("t,mx,my\n0,1,2\n").unwrap_err();
    assert!(matches!(e, RecordingError::MissingColumn { column: "mz", .. }), "{e}");
    let e = read_board("mx,my,mz\n0,1,2\n").unwrap_err();
    assert!(matches!(e, RecordingError::MissingColumn { column: "t", .. }), "{e}");
    let e = read_nav("t,roll_deg,heading_deg\n0,1,2\n").unwrap_err();
    assert!(matches!(e, RecordingError::MissingColumn { column: "pitch_deg", .. }), "{e}");
    let e = read_board("t,mx,my,mz\n0.0,1,2,3\n0.02,1,2,3\n0.01,1,2,3\n").unwrap_err();
    assert!(matches!(e, RecordingError::TimeBackwards { line: 4, .. }), "{e}");
    let e = read_nav("t,roll_deg,pitch_deg\n5,0,0\n4,0,0\n").unwrap_err();
    assert!(matches!(e, RecordingError::TimeBackwards { line: 3, .. }), "{e}");
    let e = read_board("t,mx,my,mz\n,1,2,3\n").unwrap_err();
    assert!(matches!(e, RecordingError::BadNumber { .. }), "a row without a time: {e}");
    // Optional columns are read; empty cells are absent.
    let b = read_board("t,mx,my,mz,temp_c,health\n0,1,2,3,20.5,0\n0.01,,2,3,,1\n").unwrap();
    let temp = b.temp_c.as_ref().unwrap();
    assert!(temp[0] == 20.5 && temp[1].is_nan());
    assert!(b.mag[1][0].is_nan() && b.health.as_ref().unwrap()[1] == 1.0);
}

#[test]
fn saturated_samples_are_written_without_a_field() {
    let (mut board, nav) = logs(0.0, 0.0, 60.0, false);
    let mut health = vec![0.0; board.t_s.len()];
    health[2000] = HEALTH_SATURATED as f64;
    board.health = Some(health);
    let m = merge(&board, &nav, Clock::Given { offset_s: 0.0, drift_ppm: 0.0 }).unwrap();
    assert_eq!(m.report.saturated_rows, 1);
    assert_eq!(m.recording.mag.iter().filter(|v| v[0].is_nan()).count(), 1);
}
