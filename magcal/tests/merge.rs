//! `magcal merge` on logs made from simulated field tests: the simulator's
//! recording (one clock) split into a board log on a board clock with a
//! known offset and drift and a slower navigation log, then merged. The
//! expected offset and drift are the ones put in; the expected calibration
//! is the one the single-clock recording gives.

use std::path::Path;
use std::process::Command;

use calib_core::conformance::SplitMix64;
use host_tools::compute::{self, ChainOptions};
use host_tools::data::merge::{merge, BoardLog, Clock, MergeError, MergeReport, NavLog};
use host_tools::data::pairing::ClockMap;
use host_tools::data::{Recording, RecordingError};
use magcal_sim::field_test::{self, paper_site, RunParams, SensorModel, Simulation};
use magcal_sim::scenario::heading_rms_deg;

/// Navigation-clock time of the simulation's first row, s.
const NAV_T0_S: f64 = 1000.0;

/// Splits a simulation (one row per board sample) into a board log whose
/// clock runs `t_nav = t_board + offset_s + drift_ppm·10⁻⁶·(t_board − first)`
/// (board times in whole milliseconds, as the board stamps them) and a
/// navigation log of every `nav_every`-th row within `trim_s` of each end
/// (the AHRS heading with 0.15° of noise, the GPS as simulated).
fn split(sim: &Simulation, offset_s: f64, drift_ppm: f64, nav_every: usize, trim_s: (f64, f64), seed: u64) -> (BoardLog, NavLog) {
    let rec = &sim.recording;
    let t = rec.t_s.as_ref().unwrap();
    let first_board = NAV_T0_S + t[0] - offset_s;
    let map = ClockMap { offset_s, drift_ppm, board_ref_s: first_board };
    let board = BoardLog {
        t_s: t.iter().map(|&ts| (map.to_board(NAV_T0_S + ts) * 1000.0).round() / 1000.0).collect(),
        mag: rec.mag.clone(),
        temp_c: None,
        health: None,
    };
    let end = *t.last().unwrap();
    let rows: Vec<usize> = (0..t.len()).step_by(nav_every).filter(|&i| t[i] >= t[0] + trim_s.0 && t[i] <= end - trim_s.1).collect();
    let pick = |c: &Option<Vec<f64>>| c.as_ref().map(|c| rows.iter().map(|&i| c[i]).collect::<Vec<f64>>());
    let mut rng = SplitMix64::new(seed);
    let nav = NavLog {
        t_s: rows.iter().map(|&i| NAV_T0_S + t[i]).collect(),
        roll_deg: pick(&rec.roll_deg).unwrap(),
        pitch_deg: pick(&rec.pitch_deg).unwrap(),
        heading_deg: Some(rows.iter().map(|&i| (sim.true_heading_deg[i] + 0.15 * rng.gauss()).rem_euclid(360.0)).collect()),
        ref_heading_deg: pick(&rec.ref_heading_deg),
        lat_deg: pick(&rec.lat_deg),
        lon_deg: pick(&rec.lon_deg),
        gyro_rad_s: None,
        speed_mps: None,
        motor_current_a: None,
    };
    (board, nav)
}

fn estimate() -> Clock {
    Clock::Estimate { center_s: 0.0, max_offset_s: 120.0 }
}

/// Issue 14's number: clocks up to ±60 s and 100 ppm apart, a 50 Hz board
/// and a 10 Hz navigation log of the swing test: the offset is recovered
/// within 20 ms on several seeds. With the AHRS heading the fine stage
/// fits the raw field to the attitude (any lag but the true one leaves a
/// misfit).
#[test]
fn the_clock_offset_and_drift_are_recovered_from_the_turns() {
    let sensor = SensorModel::paper_like();
    let cases = [(1u64, 37.25, 100.0), (2, -58.7, -100.0), (3, 4.013, 60.0), (4, 59.9, -35.0), (5, -12.5, 0.0)];
    let mut worst_offset: f64 = 0.0;
    let mut worst_drift: f64 = 0.0;
    for (seed, offset_s, drift_ppm) in cases {
        let sim = field_test::swing(&sensor, &paper_site(), seed, 50.0).unwrap();
        let (board, nav) = split(&sim, offset_s, drift_ppm, 5, (20.0, 15.0), seed);
        let merged = merge(&board, &nav, estimate()).unwrap();
        let r = &merged.report;
        let (e_off, e_drift) = (r.offset_s - offset_s, r.drift_ppm - drift_ppm);
        eprintln!(
            "seed {seed}: offset {offset_s} s → {:.4} ± {:.4} s (error {:+.1} ms), drift {drift_ppm} ppm → {:.1} ± {:.1} ppm, {} windows, r {:.2}",
            r.offset_s,
            r.offset_sigma_s,
            e_off * 1e3,
            r.drift_ppm,
            r.drift_sigma_ppm,
            r.windows_used,
            r.peak_correlation
        );
        worst_offset = worst_offset.max(e_off.abs());
        worst_drift = worst_drift.max(e_drift.abs());
        assert!(r.drift_fitted && r.windows_used >= 5, "{r:?}");
        // Board samples before and after the navigation log are left out.
        assert!(r.board_samples_outside_nav > 30 * 50 && r.rows + r.board_samples_outside_nav == r.board_samples, "{r:?}");
        assert_eq!(r.rows_in_nav_gaps, 0);
    }
    eprintln!("worst offset error {:.1} ms, worst drift error {:.1} ppm", worst_offset * 1e3, worst_drift);
    // Measured: worst 0.9 ms and 0.8 ppm over these five seeds (issue 14
    // asks for 20 ms).
    assert!(worst_offset < 0.004, "offset error {worst_offset} s");
    assert!(worst_drift < 4.0, "drift error {worst_drift} ppm");
}

fn write_logs(dir: &Path, board: &BoardLog, nav: &NavLog) {
    board.write(&dir.join("board.csv")).unwrap();
    nav.write(&dir.join("nav.csv")).unwrap();
}


