//! The log-based workflow as a user runs it, one `magcal` invocation per
//! step: the board's log and the navigation computer's log of a swing test
//! and of an out-and-back run (simulated, on two clocks), merged, then
//! fit → backstep → swing → card → export.
//!
//! The board logs are written in `magcal log`'s columns (`t, mx, my, mz,
//! temp_c, health`, board time in whole ms); the expected clocks are the
//! ones the logs were cut with, and the expected heading accuracy is the
//! simulator's truth on a separate validation run.

use std::path::Path;
use std::process::{Command, Output};

use host_tools::data::MergeReport;
use host_tools::doc::CalDoc;
use magcal_sim::field_test::{self, paper_site, RunKind, RunParams, SensorModel};
use magcal_sim::logs::{split, LogSplit, NavHeading};
use magcal_sim::scenario::heading_rms_deg;

fn magcal(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_magcal")).args(args).output().expect("run magcal");
    assert!(out.status.success(), "magcal {}: {}", args.join(" "), String::from_utf8_lossy(&out.stderr));
    out
}

/// `magcal log`'s file: every column, `temp_c` empty (the protocol does
/// not carry it yet), `health` 0.
fn write_board_log(path: &Path, t_s: &[f64], mag: &[[f64; 3]]) {
    let mut text = String::from("t,mx,my,mz,temp_c,health\n");
    for (t, m) in t_s.iter().zip(mag) {
        text += &format!("{t:.3},{},{},{},,0\n", m[0], m[1], m[2]);
    }
    std::fs::write(path, text).unwrap();
}

#[test]
fn log_merge_fit_backstep_swing_card_export() {
    // The board's sensor (raw in nT at the bridges, as ArduPilot's driver
    // would report it: the export infers the unit).
    let (sensor, site) = (SensorModel::board_like(), paper_site());
    let swing_sim = field_test::swing(&sensor, &site, 31, 50.0).unwrap();
    let run_sim = field_test::run(&sensor, &site, &RunParams::paper_like(), 131, 25.0, RunKind::Run).unwrap();
    let validation = field_test::run(&sensor, &site, &RunParams::validation(), 231, 2.0, RunKind::Validation).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let cuts = [("swing", &swing_sim, 52.5, 90.0, 5), ("run", &run_sim, -17.25, -70.0, 5)];
    for (name, sim, offset_s, drift_ppm, nav_every) in cuts {
        let (board, nav) = split(sim, &LogSplit { offset_s, drift_ppm, nav_every, trim_s: (10.0, 10.0), seed: 7, nav_heading: NavHeading::Ahrs });
        write_board_log(Path::new(&p(&format!("{name}_board.csv"))), &board.t_s, &board.mag);
        nav.write(Path::new(&p(&format!("{name}_nav.csv")))).unwrap();
    }
    let (lat, lon, date) = ("36.9", "50.6", "2021.0");

    // magcal merge --board swing_board.csv --nav swing_nav.csv --out swing.csv
    for (name, _, offset_s, _, _) in cuts {
        let out = magcal(&["merge", "--board", &p(&format!("{name}_board.csv")), "--nav", &p(&format!("{name}_nav.csv")), "--out", &p(&format!("{name}.csv")), "--json"]);
        let r: MergeReport = serde_json::from_slice(&out.stdout).unwrap();
        eprintln!("{name}: offset {:.4} s (put in {offset_s}), drift {:.1} ppm", r.offset_s, r.drift_ppm);
        // The target is 20 ms; the run (few turns, 5 Hz navigation)
        // is the harder one (magcal/tests/commands/merge.rs measured 64 ms there).
        assert!((r.offset_s - offset_s).abs() < if name == "swing" { 0.02 } else { 0.2 }, "{name}: {r:?}");
    }
    // magcal fit --input swing.csv --model axis --lat 36.9 --lon 50.6 --date 2021.0 --out cal_step1.json
    magcal(&["fit", "--input", &p("swing.csv"), "--model", "axis", "--lat", lat, "--lon", lon, "--date", date, "--out", &p("cal_step1.json")]);
    // magcal backstep --input run.csv --cal cal_step1.json --swing-input swing.csv --lat … --out cal_backstep.json
    magcal(&["backstep", "--input", &p("run.csv"), "--cal", &p("cal_step1.json"), "--swing-input", &p("swing.csv"), "--lat", lat, "--lon", lon, "--date", date, "--out", &p("cal_backstep.json")]);
    // magcal swing --input run.csv --cal cal_backstep.json --estimate-delay --out cal_final.json
    magcal(&["swing", "--input", &p("run.csv"), "--cal", &p("cal_backstep.json"), "--estimate-delay", "--out", &p("cal_final.json")]);
    // magcal card --input run.csv --cal cal_final.json --json
    let card: serde_json::Value = serde_json::from_slice(&magcal(&["card", "--input", &p("run.csv"), "--cal", &p("cal_final.json"), "--json"]).stdout).unwrap();
    // magcal export --cal cal_final.json --format ardupilot --out compass.parm
    magcal(&["export", "--cal", &p("cal_final.json"), "--format", "ardupilot", "--out", &p("compass.parm")]);

    let (before, after) = (card["before"]["rms_deg"].as_f64().unwrap(), card["after"]["rms_deg"].as_f64().unwrap());
    eprintln!("card against the GPS course: {before:.2}° before, {after:.2}° after");
    assert!(after < before, "{card}");
    let docs = ["cal_step1.json", "cal_backstep.json", "cal_final.json"].map(|f| CalDoc::load(Path::new(&p(f))).unwrap());
    let rms = docs.each_ref().map(|d| heading_rms_deg(d, &validation));
    eprintln!("validation heading RMS: step 1 {:.3}°, back-stepped {:.3}°, final {:.3}°", rms[0], rms[1], rms[2]);
    assert!(rms[2] < rms[0], "{rms:?}");
    // Measured 0.239° (step 1: 0.367°).
    assert!(rms[2] < 0.5, "{rms:?}");

    // The same three steps on the single-clock recordings the logs were
    // cut from: the target is the same validation RMS within 0.02°.
    swing_sim.recording.write(Path::new(&p("swing_single.csv"))).unwrap();
    run_sim.recording.write(Path::new(&p("run_single.csv"))).unwrap();
    magcal(&["fit", "--input", &p("swing_single.csv"), "--model", "axis", "--lat", lat, "--lon", lon, "--date", date, "--out", &p("s1.json")]);
    magcal(&["backstep", "--input", &p("run_single.csv"), "--cal", &p("s1.json"), "--swing-input", &p("swing_single.csv"), "--lat", lat, "--lon", lon, "--date", date, "--out", &p("s2.json")]);
    magcal(&["swing", "--input", &p("run_single.csv"), "--cal", &p("s2.json"), "--estimate-delay", "--out", &p("s3.json")]);
    let single = heading_rms_deg(&CalDoc::load(Path::new(&p("s3.json"))).unwrap(), &validation);
    eprintln!("validation heading RMS: single clock {single:.4}°, merged logs {:.4}° (difference {:+.4}°)", rms[2], rms[2] - single);
    assert!((rms[2] - single).abs() < 0.02, "single {single}, merged {}", rms[2]);
    let parm = std::fs::read_to_string(p("compass.parm")).unwrap();
    assert!(parm.lines().any(|l| l.starts_with("COMPASS_OFS_X,")), "{parm}");
}
