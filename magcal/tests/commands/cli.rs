//! The `magcal` binary against the contract of docs/INTERFACES.md, on
//! recordings made here with known truth.

use std::path::Path;
use std::process::Output;

use calib_core::cal::{FieldCal, ModelKind, Swing};
use calib_core::conformance::SplitMix64;
use calib_core::heading::{ned_field, ned_to_body, wrap_two_pi};
use calib_core::ortho::{gamma, OrthoAngles};
use host_tools::doc::CalDoc;
use host_tools::data::Recording;
use super::{magcal};

fn ok_json(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "magcal failed: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).expect("stdout is exactly one JSON document")
}

fn one_line_error(out: &Output) -> String {
    assert!(!out.status.success());
    assert!(out.stdout.is_empty(), "nothing on stdout on failure");
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    err
}

fn path_str(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn fit_prints_and_writes_the_calibration_document() {
    // The paper's Table 2 "whole run" coefficients, a full tumble, no noise.
    let (b, s, f) = ([-1865.0, 1385.0, -903.0], [0.19556, 0.09001, 0.16142], 48_730.0);
    let mut rng = SplitMix64::new(1);
    let mag = (0..500)
        .map(|_| {
            let u = rng.direction();
            [0, 1, 2].map(|k| b[k] + s[k] * f * u[k])
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("swing.csv");
    let out_path = dir.path().join("cal.json");
    Recording { mag, ..Recording::default() }.write(&input).unwrap();
    let out = magcal(&["fit", "--input", path_str(&input), "--model", "axis", "--field-nt", "48730", "--json", "--out", path_str(&out_path)]);
    let doc = ok_json(&out);
    assert_eq!(doc["model"], "axis");
    assert_eq!(doc["field_nt"], 48_730.0);
    for k in 0..3 {
        assert!((doc["bias"][k].as_f64().unwrap() - b[k]).abs() < 1e-6, "{doc}");
        assert!((1.0 / doc["matrix"][k][k].as_f64().unwrap() - s[k]).abs() < 1e-9);
    }
    assert!(doc["quality"]["residual_rms_nt"].as_f64().unwrap() < 1e-6);
    assert!(doc["quality"]["coverage_pct"].as_u64().unwrap() >= 95, "500 random directions fill nearly all 72 bins");
    // --out wrote the same document.
    let saved: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out_path).unwrap()).unwrap();
    assert_eq!(saved, doc);
}

#[test]
fn swing_estimates_the_gps_delay_and_the_fourier_terms() {
    // A vehicle turning and rolling; the magnetometer's heading is off by the
    // paper's Table 7 swing error; GPS course only every other 30 s, 2 s late.
    let paper = Swing { a: 0.14199, b: -0.01101, c: 0.01071, d: 0.00610, e: 0.05528 };
    let dip = 55.7f64.to_radians();
    let field = 48_730.0;
    let distorted = |psi: f64| {
        let mut h = psi;
        for _ in 0..60 {
            h = psi - paper.correction_rad(h);
        }
        wrap_two_pi(h)
    };
    let truth = |t: f64| wrap_two_pi(0.014 * t + 0.1 * (0.011 * t).sin());
    let mut rec = Recording { t_s: Some(vec![]), roll_deg: Some(vec![]), pitch_deg: Some(vec![]), ref_heading_deg: Some(vec![]), ..Recording::default() };
    for k in 0..6000 {
        let t = k as f64 * 0.5;
        let (roll, pitch) = (0.3 * (0.05 * t).sin(), 0.1 * (0.037 * t).cos());
        let h = ned_to_body(ned_field(field, dip, 0.0), roll, pitch, distorted(truth(t)));
        rec.mag.push(h);
        rec.t_s.as_mut().unwrap().push(t);
        rec.roll_deg.as_mut().unwrap().push(roll.to_degrees());
        rec.pitch_deg.as_mut().unwrap().push(pitch.to_degrees());
        let surface = ((t / 120.0) as u32).is_multiple_of(2) && t >= 2.0;
        rec.ref_heading_deg.as_mut().unwrap().push(if surface { truth(t - 2.0).to_degrees() } else { f64::NAN });
    }
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("run.csv");
    rec.write(&input).unwrap();
    let cal = dir.path().join("cal.json");
    CalDoc::new(ModelKind::Full, &FieldCal::identity(), field, Default::default()).save(&cal).unwrap();
    let doc = ok_json(&magcal(&["swing", "--input", path_str(&input), "--cal", path_str(&cal), "--estimate-delay", "--json"]));
    let q = &doc["quality"]["swing"];
    assert!((q["delay_s"].as_f64().unwrap() - 2.0).abs() < 0.05, "{q}");
    assert_eq!(q["terms"], 5);
    for (name, want) in ["a", "b", "c", "d", "e"].iter().zip(paper.to_array()) {
        let got = doc["swing"][name].as_f64().unwrap();
        assert!((got - want).abs() < 2e-3, "{name}: {got} vs {want}");
    }
    assert!(q["after_rms_deg"].as_f64().unwrap() < 0.1 * q["before_rms_deg"].as_f64().unwrap());
    // With the delay given instead.
    let doc = ok_json(&magcal(&["swing", "--input", path_str(&input), "--cal", path_str(&cal), "--delay-s", "2", "--json"]));
    assert!((doc["swing"]["a"].as_f64().unwrap() - paper.a).abs() < 2e-3);
}

#[test]
fn ortho_identifies_paper_001s_simulated_sensor() {
    let truth = OrthoAngles { theta_rad: 0.06, phi_rad: 0.08, psi_rad: -0.04, k_xz: 0.95, k_yz: 1.05 };
    let g = gamma(&truth);
    let mut rng = SplitMix64::new(7);
    let mag = (0..1440)
        .map(|_| {
            let u = rng.direction().map(|v| v * 2.0);
            [0, 1, 2].map(|i| g[i][0] * u[0] + g[i][1] * u[1] + g[i][2] * u[2] + 1e-3 * rng.gauss())
        })
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("turntable.csv");
    Recording { mag, ..Recording::default() }.write(&input).unwrap();
    for solver in ["pairwise", "linear", "all", "ml"] {
        let doc = ok_json(&magcal(&["ortho", "--input", path_str(&input), "--zero-bias", "--solver", solver, "--json"]));
        let j = [
            ("theta_rad", truth.theta_rad),
            ("phi_rad", truth.phi_rad),
            ("psi_rad", truth.psi_rad),
            ("k_xz", truth.k_xz),
            ("k_yz", truth.k_yz),
        ]
        .iter()
        .map(|(k, v)| ((doc[k].as_f64().unwrap() - v) / v).powi(2))
        .sum::<f64>()
        .sqrt();
        assert!(j < 0.05, "{solver}: J = {j}, {doc}");
        assert_eq!(doc["q"].as_array().unwrap().len(), 5);
    }
}

#[test]
fn bad_input_gets_one_line_errors_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.csv");
    std::fs::write(&empty, "").unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", path_str(&empty), "--model", "full", "--field-nt", "48000"]));
    assert!(e.contains("empty file"), "{e}");

    let no_mz = dir.path().join("no_mz.csv");
    std::fs::write(&no_mz, "t,mx,my\n0,1,2\n").unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", path_str(&no_mz), "--model", "full", "--field-nt", "48000"]));
    assert!(e.contains("missing column `mz`"), "{e}");

    // Rotation about z only: the paper's Table 2 case 1.
    let yaw_only = dir.path().join("yaw.csv");
    let mag = (0..360).map(|k| {
        let p = (k as f64).to_radians();
        [100.0 + 5000.0 * p.cos(), -50.0 + 4800.0 * p.sin(), 8000.0]
    }).collect();
    Recording { mag, ..Recording::default() }.write(&yaw_only).unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", path_str(&yaw_only), "--model", "axis", "--field-nt", "48000"]));
    assert!(e.contains("excitation") || e.contains("impossible") || e.contains("directions"), "{e}");

    let e = one_line_error(&magcal(&["fit", "--input", path_str(&no_mz), "--model", "full"]));
    assert!(e.contains("--field-nt"), "{e}");

    let cal = dir.path().join("cal.json");
    std::fs::write(&cal, "{\"model\":\"full\"}").unwrap();
    let e = one_line_error(&magcal(&["swing", "--input", path_str(&yaw_only), "--cal", path_str(&cal), "--delay-s", "1"]));
    assert!(e.contains("not a calibration document"), "{e}");
    let e = one_line_error(&magcal(&["swing", "--input", path_str(&yaw_only), "--cal", path_str(&cal)]));
    assert!(e.contains("--estimate-delay"), "{e}");
}

#[test]
fn igrf_prints_the_interface_fields() {
    // Official check value: 2025.0, 5 km, 45°N 135°E.
    let doc = ok_json(&magcal(&["igrf", "--lat", "45", "--lon", "135", "--height-m", "5000", "--date", "2025.0", "--json"]));
    assert_eq!(doc["model"], "IGRF-14");
    for (k, want, tol) in [
        ("north_nt", 25147.3, 0.1),
        ("east_nt", -5003.2, 0.1),
        ("down_nt", 46410.1, 0.1),
        ("horizontal_nt", 25640.2, 0.1),
        ("total_nt", 53021.9, 0.1),
        ("declination_deg", -11.252, 0.001),
        ("inclination_deg", 61.081, 0.001),
    ] {
        let got = doc[k].as_f64().unwrap();
        assert!((got - want).abs() <= tol, "{k}: {got} vs {want}");
    }
    let wmm = ok_json(&magcal(&["igrf", "--lat", "45", "--lon", "135", "--date", "2026-03-01", "--model", "wmm2025", "--json"]));
    assert_eq!(wmm["model"], "WMM2025");
    let e = one_line_error(&magcal(&["igrf", "--lat", "0", "--lon", "0", "--date", "2031-01-01"]));
    assert!(e.contains("outside"), "{e}");
}

/// The documented chain on simulated recordings: `simulate` → `fit --model
/// axis --lat --lon --date` → `backstep` (trace) → `swing --estimate-delay`.
#[test]
fn the_documented_chain_runs_on_simulated_field_tests() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (scenario, seed, out) in [("swing", "11", "swing.csv"), ("run", "12", "run.csv")] {
        let o = magcal(&["simulate", scenario, "--seed", seed, "--rate-hz", "1", "--out", &p(out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(dir.path().join(out.replace(".csv", ".truth.json")).exists());
    }
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let fit = ok_json(&magcal(&[&["fit", "--input", &p("swing.csv"), "--model", "axis", "--out", &p("cal1.json"), "--json"][..], &site[..]].concat()));
    assert_eq!(fit["model"], "axis");
    assert!(fit["declination_deg"].as_f64().unwrap() > 4.0, "declination from IGRF: {}", fit["declination_deg"]);

    let bs = ok_json(&magcal(&[&["backstep", "--input", &p("run.csv"), "--cal", &p("cal1.json"), "--out", &p("cal2.json"), "--json"][..], &site[..]].concat()));
    let trace = bs["trace"].as_array().unwrap();
    assert!(trace.len() >= 2);
    for e in trace {
        for k in ["step_nt", "hh_nt", "hz_nt", "f_nt"] {
            assert!(e[k].is_number(), "trace entry lacks {k}: {e}");
        }
    }
    let before = trace[0]["step_nt"].as_f64().unwrap();
    let after = trace.last().unwrap()["step_nt"].as_f64().unwrap();
    assert!(before.abs() > 300.0 && after.abs() < 5.0, "step {before} → {after}");

    let paper = ok_json(&magcal(&[&["backstep", "--input", &p("run.csv"), "--cal", &p("cal1.json"), "--method", "paper", "--json"][..], &site[..]].concat()));
    let pt = paper["trace"].as_array().unwrap();
    assert_eq!(pt[1]["correction"], "horizontal scale (Hh ratio)");
    assert_eq!(pt[2]["correction"], "sz for no step");
    assert_eq!(pt[3]["correction"], "bz from magnitude");

    let sw = ok_json(&magcal(&["swing", "--input", &p("run.csv"), "--cal", &p("cal2.json"), "--estimate-delay", "--out", &p("cal3.json"), "--json"]));
    let delay = sw["quality"]["swing"]["delay_s"].as_f64().unwrap();
    assert!((delay - 2.0).abs() < 0.6, "delay {delay}");
    assert!(sw["swing"]["a"].is_number());
    // The final document loads and validates.
    CalDoc::load(Path::new(&p("cal3.json"))).unwrap();

    // The report: one self-contained page with the papers' figures for
    // these calibrations, and the deviation card of the run against its GPS
    // reference (no validation run given).
    let rep = ok_json(&magcal(&["report", "--run", &p("run.csv"), "--swing-input", &p("swing.csv"), "--cal", &p("cal1.json"), "--cal", &p("cal3.json"), "--out", &p("report"), "--json"]));
    // Card, 2 coverage maps, field, heading at the surface, the back-stepping
    // trace (cal3 carries cal2's), 2 histograms.
    assert_eq!(rep["figures"], 8, "{rep}");
    assert_eq!(rep["card"]["against"], "GPS course (run, at the surface)");
    let html = std::fs::read_to_string(dir.path().join("report/index.html")).unwrap();
    assert_eq!(html.matches("<svg").count(), 8);
    assert!(html.contains("cal1") && html.contains("cal3") && html.contains("|H|, nT"));
    assert!(!html.contains("src=") && !html.contains("<script"), "self-contained");
    // What was not given is said: no validation run, no site.
    let missing: Vec<&str> = rep["missing"].as_array().unwrap().iter().filter_map(|m| m.as_str()).collect();
    assert!(missing.iter().any(|m| m.starts_with("heading against truth")), "{missing:?}");
    assert!(html.contains("Not available: no validation run with a truth heading"));
    let card: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.path().join("report/deviation_card.json")).unwrap()).unwrap();
    assert!(card["samples"].as_u64().unwrap() > 0);
    // The swing-fitted cal3 leaves the GPS course within a few degrees (the
    // swing fit's own after RMS above is the same data).
    assert!(card["after"]["rms_deg"].as_f64().unwrap() < 5.0, "{card}");
    // The same from a session directory, with a validation run and its
    // truth (`magcal simulate validation` writes `true_heading_deg`) and the
    // session's settings: the headline and card come from the validation run.
    let sess = dir.path().join("session");
    std::fs::create_dir(&sess).unwrap();
    for (from, to) in [("swing.csv", "swing.csv"), ("run.csv", "run.csv"), ("cal1.json", "cal_step1.json"), ("cal2.json", "cal_backstep.json"), ("cal3.json", "cal_final.json")] {
        std::fs::copy(dir.path().join(from), sess.join(to)).unwrap();
    }
    let o = magcal(&["simulate", "validation", "--seed", "13", "--rate-hz", "1", "--out", sess.join("validation_truth.csv").to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let settings = host_tools::doc::SessionSettings { lat_deg: 36.9, lon_deg: 50.6, decimal_year: 2021.0, vehicle: "simulated".into(), firmware: "0.1.0".into(), reproduce: vec![] };
    std::fs::write(sess.join("settings.json"), serde_json::to_string(&settings).unwrap()).unwrap();
    let rep = ok_json(&magcal(&["report", "--session", sess.to_str().unwrap(), "--json"]));
    assert_eq!(rep["card"]["against"], "truth (validation run)", "{rep}");
    assert!(rep["index"].as_str().unwrap().ends_with("session/report/index.html"));
    let html = std::fs::read_to_string(sess.join("report/index.html")).unwrap();
    assert!(html.contains("2021-01-01") && html.contains("simulated, firmware 0.1.0"));
    assert!(html.contains("Heading RMS from the final calibration applied to the validation recording"));
    let card: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(sess.join("report/deviation_card.json")).unwrap()).unwrap();
    // cal3 against the simulated truth: measured 0.22° RMS; the bound is a
    // few times that.
    let after = card["after"]["rms_deg"].as_f64().unwrap();
    assert!(after < 1.0, "{card}");

    // Neither a session nor an output directory: a clear refusal.
    assert!(one_line_error(&magcal(&["report", "--cal", &p("cal1.json")])).contains("--out"));
}

/// The bad-data catalogue (README): each case its own message, no panic, no
/// coefficients.
#[test]
fn bad_data_catalogue() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let mut rng = SplitMix64::new(21);
    let sphere = |scale: f64, rng: &mut SplitMix64| -> Vec<[f64; 3]> { (0..400).map(|_| rng.direction().map(|v| v * scale + 3.0)).collect() };

    // Units are guessed from the magnitude against the reference.
    Recording { mag: sphere(48.73, &mut rng), ..Recording::default() }.write(Path::new(&p("ut.csv"))).unwrap();
    let doc = ok_json(&magcal(&["fit", "--input", &p("ut.csv"), "--model", "full", "--field-nt", "48730", "--json", "--out", &p("ut.json")]));
    assert_eq!(doc["quality"]["input_units_guess"], "µT");
    Recording { mag: sphere(48_730.0, &mut rng), ..Recording::default() }.write(Path::new(&p("nt.csv"))).unwrap();
    let doc = ok_json(&magcal(&["fit", "--input", &p("nt.csv"), "--model", "full", "--field-nt", "48730", "--json", "--out", &p("nt.json")]));
    assert_eq!(doc["quality"]["input_units_guess"], "nT");

    // A µT recording against an nT calibration: refused, not silently wrong.
    let mut rec = Recording { t_s: Some(vec![]), roll_deg: Some(vec![]), pitch_deg: Some(vec![]), ref_heading_deg: Some(vec![]), ..Recording::default() };
    for k in 0..200 {
        rec.mag.push(rng.direction().map(|v| v * 48.73));
        rec.t_s.as_mut().unwrap().push(k as f64);
        rec.roll_deg.as_mut().unwrap().push(0.0);
        rec.pitch_deg.as_mut().unwrap().push(0.0);
        rec.ref_heading_deg.as_mut().unwrap().push((k * 7 % 360) as f64);
    }
    rec.write(Path::new(&p("ut_run.csv"))).unwrap();
    let e = one_line_error(&magcal(&["swing", "--input", &p("ut_run.csv"), "--cal", &p("nt.json"), "--delay-s", "0"]));
    assert!(e.contains("different units") && e.contains("µT"), "{e}");

    // A stuck axis: z never changes.
    let stuck: Vec<[f64; 3]> = (0..400).map(|_| {
        let d = rng.direction();
        [d[0] * 48_730.0, d[1] * 48_730.0, 12.0]
    }).collect();
    Recording { mag: stuck, ..Recording::default() }.write(Path::new(&p("stuck.csv"))).unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", &p("stuck.csv"), "--model", "full", "--field-nt", "48730"]));
    assert!(e.contains("excitation") || e.contains("ellipsoid") || e.contains("directions"), "{e}");

    // NaN cells are "not available"; an infinity is not a number.
    std::fs::write(p("inf.csv"), "mx,my,mz\n1,2,inf\n").unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", &p("inf.csv"), "--model", "sphere", "--field-nt", "48730"]));
    assert!(e.contains("`inf` is not a number"), "{e}");
    std::fs::write(p("header.csv"), "t,mx,my,mz\n").unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", &p("header.csv"), "--model", "sphere", "--field-nt", "48730"]));
    assert!(e.contains("header only"), "{e}");
    std::fs::write(p("nan.csv"), "mx,my,mz\nnan,nan,nan\n,,\n").unwrap();
    let e = one_line_error(&magcal(&["fit", "--input", &p("nan.csv"), "--model", "sphere", "--field-nt", "48730"]));
    assert!(e.contains("no row has all of mx, my, mz"), "{e}");
    // Saturated samples, when the saturation level is given.
    let e = one_line_error(&magcal(&["fit", "--input", &p("nt.csv"), "--model", "full", "--field-nt", "48730", "--saturation", "30000"]));
    assert!(e.contains("saturated"), "{e}");
    // A missing file.
    let e = one_line_error(&magcal(&["fit", "--input", &p("nope.csv"), "--model", "full", "--field-nt", "48730"]));
    assert!(e.contains("No such file"), "{e}");
}

mod arbitrary_bytes {
    use host_tools::doc::CalDoc;
    use host_tools::data::Recording;
    use proptest::prelude::*;
    use std::path::Path;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn csv_reader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            let _ = Recording::from_reader(&bytes[..], Path::new("x.csv"));
        }

        #[test]
        fn csv_like_text_never_panics(lines in proptest::collection::vec("[-0-9a-z.,nN ]{0,24}", 0..12)) {
            let text = format!("t,mx,my,mz\n{}", lines.join("\n"));
            let _ = Recording::from_reader(text.as_bytes(), Path::new("x.csv"));
        }

        #[test]
        fn caldoc_loader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            if let Ok(doc) = serde_json::from_slice::<CalDoc>(&bytes) {
                let _ = doc.validate(Path::new("x.json"));
            }
        }
    }
}

/// The gyro-aided fit's acceptance: `magcal fit --model gyro` on broad-05's
/// calibration part prints coefficients whose heading on the validation
/// part (against the optical reference, one offset removed) is within 0.5°
/// of the true calibration's 2.22°; `fit --help` lists the model.
#[test]
fn fit_with_the_gyro_model_calibrates_broad05() {
    let help = magcal(&["fit", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("gyro"));
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/broad-05");
    let out = magcal(&["fit", "--input", &data.join("05_calib.csv").to_string_lossy(), "--model", "gyro", "--field-nt", "44204", "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let doc: CalDoc = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(doc.model, ModelKind::Gyro);
    assert!(doc.quality.predicted_heading_rms_deg.is_some_and(|p| p > 0.0 && p < 2.0));
    let cal: FieldCal<f64> = doc.field_cal();
    let val = Recording::read(&data.join("05_validate.csv")).unwrap();
    let text = std::fs::read_to_string(data.join("05_validate.csv")).unwrap();
    let col = text.lines().next().unwrap().split(',').position(|c| c == "truth_heading_deg").unwrap();
    let optical: Vec<f64> = text.lines().skip(1).map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect();
    let (roll, pitch) = (val.roll_deg.unwrap(), val.pitch_deg.unwrap());
    let headings = (0..val.mag.len()).map(|i| calib_core::heading::magnetic_heading_rad(cal.apply(val.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
    let (rms, _) = host_tools::compute::heading_rms_after_offset_deg(headings.zip(optical));
    // Measured: 1.67° (the true calibration: 2.22°).
    assert!(rms.rms < 2.22 + 0.5, "{}", rms.rms);
}
