//! Findings against the CLI: bad input is refused where it
//! enters, with the input named; an input is never overwritten; what a
//! result is measured against is said.

use std::process::Output;

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::conformance::SplitMix64;
use calib_core::heading::{ned_field, ned_to_body};
use host_tools::doc::CalDoc;
use host_tools::data::Recording;
use super::{magcal, p};

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).to_string()
}

/// The one-line error of a refused command (nothing on stdout).
fn refused(out: &Output) -> String {
    assert!(!out.status.success(), "accepted: {}", stderr(out));
    assert!(out.stdout.is_empty());
    let e = stderr(out);
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
    e
}

/// `n` field samples in random directions: `bias + radius · u`, or only
/// those with `u_z < z_max` (a cap).
fn sphere(n: usize, bias: [f64; 3], radius: f64, z_max: f64, seed: u64) -> Recording {
    let mut rng = SplitMix64::new(seed);
    let mut mag = Vec::new();
    while mag.len() < n {
        let u = rng.direction();
        if u[2] < z_max {
            mag.push([0, 1, 2].map(|k| bias[k] + radius * u[k]));
        }
    }
    Recording { mag, ..Recording::default() }
}

/// A calibration document in milligauss raw units (gain 100 nT per unit).
fn mgauss_doc(field_nt: f64) -> CalDoc {
    let cal = FieldCal { bias: [12.0, -30.0, 8.0], matrix: [[100.0, 0.0, 0.0], [0.0, 100.0, 0.0], [0.0, 0.0, 100.0]] };
    CalDoc::new(ModelKind::Axis, &cal, field_nt, Default::default())
}

#[test]
fn a_field_typed_in_microtesla_is_refused_naming_the_unit() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("s.csv");
    sphere(400, [0.0; 3], 489.5, 2.0, 1).write(&input).unwrap();
    // 48.953 µT typed for nT: IGRF's 48 953 nT at the README's site.
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48.953"]));
    assert!(e.contains("--field-nt 48.953") && e.contains("µT") && e.contains("48953 nT"), "{e}");
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "0.48953"]));
    assert!(e.contains("Gauss"), "{e}");
    // A step-1 calibration made with it is refused by backstep before any
    // work (it went on to a resting bias of −248 020 ± 246 000 raw).
    // (Written by hand: the one document check refuses to save it.)
    let cal = dir.path().join("cal1.json");
    std::fs::write(&cal, serde_json::to_string(&mgauss_doc(48.953)).unwrap()).unwrap();
    let e = refused(&magcal(&["backstep", "--input", p(&input), "--cal", p(&cal), "--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"]));
    assert!(e.contains("cal1.json: coefficients refused: field_nt 48.953") && e.contains("µT"), "{e}");
    // Given components that are not the Earth's: refused too.
    mgauss_doc(48_730.0).save(&cal).unwrap();
    let e = refused(&magcal(&["backstep", "--input", p(&input), "--cal", p(&cal), "--field-h-nt", "27.3", "--field-z-nt", "40.6"]));
    assert!(e.contains("µT"), "{e}");
}

#[test]
fn an_input_is_never_overwritten_and_outputs_are_checked_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("s.csv");
    sphere(400, [0.0; 3], 48_730.0, 2.0, 2).write(&input).unwrap();
    let raw = std::fs::read(&input).unwrap();
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730", "--out", p(&input)]));
    assert!(e.contains("would be overwritten"), "{e}");
    // The same file by another name.
    let other_name = dir.path().join(".").join("s.csv");
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730", "--out", p(&other_name)]));
    assert!(e.contains("would be overwritten"), "{e}");
    assert_eq!(std::fs::read(&input).unwrap(), raw, "the recording is untouched");

    let log = dir.path().join("LOG.bin");
    std::fs::write(&log, b"not looked at").unwrap();
    let e = refused(&magcal(&["import", "--dataflash", p(&log), "--out", p(&log)]));
    assert!(e.contains("would be overwritten"), "{e}");

    let cal = dir.path().join("c.json");
    mgauss_doc(48_730.0).save(&cal).unwrap();
    let doc_text = std::fs::read(&cal).unwrap();
    for args in [
        &["export", "--cal", p(&cal), "--format", "px4", "--out", p(&cal)][..],
        &["swing", "--input", p(&input), "--cal", p(&cal), "--delay-s", "0", "--out", p(&cal)][..],
        &["backstep", "--input", p(&input), "--cal", p(&cal), "--field-h-nt", "27300", "--field-z-nt", "40600", "--out", p(&input)][..],
        &["card", "--input", p(&input), "--cal", p(&cal), "--csv", p(&input)][..],
    ] {
        let e = refused(&magcal(args));
        assert!(e.contains("would be overwritten"), "{args:?}: {e}");
    }
    assert_eq!(std::fs::read(&cal).unwrap(), doc_text, "the calibration is untouched");
    assert_eq!(std::fs::read(&input).unwrap(), raw);

    // --out naming a folder: refused before the work, nothing left beside it.
    let folder = dir.path().join("out");
    std::fs::create_dir(&folder).unwrap();
    let e = refused(&magcal(&["export", "--cal", p(&cal), "--format", "px4", "--raw-unit", "mgauss", "--out", p(&folder)]));
    assert!(e.contains("is a directory"), "{e}");
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730", "--out", p(&folder)]));
    assert!(e.contains("is a directory"), "{e}");
    let tmp: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).filter(|n| n.to_string_lossy().ends_with("tmp")).collect();
    assert!(tmp.is_empty(), "left behind: {tmp:?}");

    // The same file through a hard or a symbolic link, the
    // calibration as apply's output, a device node: each refused before
    // the work, nothing touched.
    let hard = dir.path().join("hard.csv");
    std::fs::hard_link(&input, &hard).unwrap();
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730", "--out", p(&hard)]));
    assert!(e.contains("would be overwritten"), "{e}");
    let e = refused(&magcal(&["apply", "--input", p(&input), "--cal", p(&cal), "--out", p(&hard)]));
    assert!(e.contains("would be overwritten"), "{e}");
    let e = refused(&magcal(&["apply", "--input", p(&input), "--cal", p(&cal), "--out", p(&cal)]));
    assert!(e.contains("would be overwritten") && e.contains("c.json"), "{e}");
    #[cfg(unix)]
    {
        let soft = dir.path().join("soft.json");
        std::os::unix::fs::symlink(&cal, &soft).unwrap();
        let e = refused(&magcal(&["apply", "--input", p(&input), "--cal", p(&cal), "--out", p(&soft)]));
        assert!(e.contains("would be overwritten"), "{e}");
        let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730", "--out", "/dev/null"]));
        assert!(e.contains("a device"), "{e}");
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata("/dev/null").unwrap().file_type().is_char_device(), "/dev/null is still a device");
    }
    assert_eq!(std::fs::read(&cal).unwrap(), doc_text, "the calibration is untouched");
    assert_eq!(std::fs::read(&input).unwrap(), raw);
    // An existing output is replaced, and said so on stderr.
    let again = dir.path().join("sim.csv");
    for round in 0..2 {
        let o = magcal(&["simulate", "swing", "--seed", "1", "--out", p(&again)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(stderr(&o).contains("exists and will be replaced"), round == 1, "{}", stderr(&o));
    }

    // A missing folder is said before the work: this run has no attitude,
    // so the back-stepping itself would fail — the folder is named first.
    let missing = dir.path().join("nowhere").join("cal2.json");
    let e = refused(&magcal(&["backstep", "--input", p(&input), "--cal", p(&cal), "--field-h-nt", "27300", "--field-z-nt", "40600", "--out", p(&missing)]));
    assert!(e.contains("nowhere") && e.contains("does not exist"), "{e}");
}

#[test]
fn a_refusal_caused_by_the_input_names_the_input() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("biased.csv");
    // A centre of 2·10⁷ raw units: beyond the documents' bias limit (10⁷).
    sphere(400, [2e7, 0.0, 0.0], 500.0, 2.0, 3).write(&input).unwrap();
    let out = dir.path().join("o.json");
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "sphere", "--field-nt", "48730", "--out", p(&out)]));
    // Refused before any document is made (fitted coefficients no
    // sensor has are the fit's failure, not the writer's).
    assert!(e.contains("biased.csv") && e.contains("coefficients are unusable") && e.contains("bias is beyond") && !e.contains("o.json"), "{e}");
    assert!(!out.exists());
}

#[test]
fn a_calibration_with_a_byte_order_mark_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("bom.json");
    let text = serde_json::to_string_pretty(&mgauss_doc(48_730.0)).unwrap();
    std::fs::write(&cal, format!("\u{feff}{text}")).unwrap();
    let out = magcal(&["export", "--cal", p(&cal), "--format", "ardupilot", "--raw-unit", "mgauss", "--out", p(&dir.path().join("a.parm"))]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn px4_export_refuses_raw_units_that_make_no_sense_of_the_gain() {
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("cal.json");
    mgauss_doc(48_730.0).save(&cal).unwrap();
    let out_path = dir.path().join("px4.params");
    // The document's raw units are mGauss (gain 100 nT per unit): as gauss
    // XSCALE would be 0.001, as nT 100 (both were written before).
    for unit in ["gauss", "nt", "ut"] {
        let e = refused(&magcal(&["export", "--cal", p(&cal), "--format", "px4", "--raw-unit", unit, "--out", p(&out_path)]));
        assert!(e.contains("--raw-unit") && e.contains("gain"), "{unit}: {e}");
        assert!(!out_path.exists());
    }
    let out = magcal(&["export", "--cal", p(&cal), "--format", "px4", "--raw-unit", "mgauss", "--out", p(&out_path)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = std::fs::read_to_string(&out_path).unwrap();
    // QGroundControl's format: vehicle, component, name, value, type.
    assert!(text.lines().any(|l| l.split('\t').collect::<Vec<_>>()[..] == ["1", "1", "CAL_MAG0_XSCALE", "1", "9"]), "{text}");
}

#[test]
fn ortho_is_gated_on_coverage_and_says_its_quality() {
    let dir = tempfile::tempdir().unwrap();
    let cap = dir.path().join("cap.csv");
    // The bottom of the sphere (u_z < −0.6): 2 of the 6 equal-area bands
    // touched, 33 % of the bins (measured), below the triangular model's 40 %.
    sphere(1440, [0.0; 3], 2.0, -0.6, 4).write(&cap).unwrap();
    let e = refused(&magcal(&["ortho", "--input", p(&cap), "--zero-bias"]));
    assert!(e.contains("cap.csv") && e.contains("field directions were visited") && e.contains("--allow-weak"), "{e}");
    let out = magcal(&["ortho", "--input", p(&cap), "--zero-bias", "--allow-weak", "--json"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let covered = doc["quality"]["coverage_pct"].as_u64().unwrap();
    assert!((25..40).contains(&covered), "{doc}");

    // A whole sphere without a bias: no warning, full coverage.
    let whole = dir.path().join("whole.csv");
    sphere(1440, [0.0; 3], 2.0, 2.0, 5).write(&whole).unwrap();
    let out = magcal(&["ortho", "--input", p(&whole), "--zero-bias", "--json"]);
    assert!(out.status.success() && !stderr(&out).contains("warning"), "{}", stderr(&out));
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(doc["quality"]["coverage_pct"].as_u64().unwrap() >= 95 && doc["quality"]["residual_rms_pct"].as_f64().unwrap() < 1e-6, "{doc}");
    // With a bias of 15 % of the radius, --zero-bias is warned about.
    let biased = dir.path().join("biased.csv");
    sphere(1440, [0.2, -0.15, 0.1], 2.0, 2.0, 6).write(&biased).unwrap();
    let out = magcal(&["ortho", "--input", p(&biased), "--zero-bias", "--allow-weak"]);
    let err = stderr(&out);
    assert!(err.contains("warning: --zero-bias") && err.contains("[0.2000, -0.1500, 0.1000]"), "{err}");
}

#[test]
fn positions_far_from_the_site_are_refused_and_near_ones_warned() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("far.csv");
    let mut rec = sphere(400, [0.0; 3], 48_953.0, 2.0, 7);
    let n = rec.len();
    // 36.9° N, 50.6° E given; the recording made at 36.9° S, 129.4° W.
    rec.lat_deg = Some(vec![-36.9; n]);
    rec.lon_deg = Some(vec![-129.4; n]);
    rec.write(&input).unwrap();
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let e = refused(&magcal(&[&["fit", "--input", p(&input), "--model", "axis"][..], &site[..]].concat()));
    // The antipode is 20 015 km away.
    assert!(e.contains("-36.90000°, -129.40000°") && e.contains("--lat 36.9 --lon 50.6") && e.contains("20015 km"), "{e}");
    // 0.3° of latitude north (33 km): a warning.
    rec.lat_deg = Some(vec![37.2; n]);
    rec.lon_deg = Some(vec![50.6; n]);
    rec.write(&input).unwrap();
    let out = magcal(&[&["fit", "--input", p(&input), "--model", "axis"][..], &site[..]].concat());
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("warning: ") && stderr(&out).contains(" 33 km from the site"), "{}", stderr(&out));
    // The report checks the same (as the other commands): the antipode
    // refused before any page is written.
    rec.lat_deg = Some(vec![-36.9; n]);
    rec.lon_deg = Some(vec![-129.4; n]);
    rec.write(&input).unwrap();
    let out_dir = dir.path().join("report");
    let e = refused(&magcal(&[&["report", "--run", p(&input), "--out", p(&out_dir)][..], &site[..]].concat()));
    assert!(e.contains("20015 km") && e.contains("--lat 36.9 --lon 50.6"), "{e}");
    assert!(!out_dir.join("index.html").exists());
}

#[test]
fn report_without_inputs_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("r");
    let e = refused(&magcal(&["report", "--out", p(&out_dir)]));
    assert!(e.contains("nothing to report"), "{e}");
    assert!(!out_dir.join("index.html").exists());
}

#[test]
fn igrf_reaches_the_deepest_ocean() {
    let at = |h: &str| magcal(&["igrf", "--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01", "--height-m", h, "--json"]);
    let (top, deep) = (at("0"), at("-6000"));
    assert!(deep.status.success(), "{}", stderr(&deep));
    let f = |o: &Output| serde_json::from_slice::<serde_json::Value>(&o.stdout).unwrap()["total_nt"].as_f64().unwrap();
    // The dipole part grows as r⁻³: (6371.2 / 6365.2)³ − 1 = 0.28 %.
    let growth = f(&deep) / f(&top) - 1.0;
    assert!((0.002..0.005).contains(&growth), "{growth}");
    assert!(at("-11000").status.success());
    assert!(refused(&at("-12000")).contains("-11 000 m"));
}

#[test]
fn fit_without_out_says_nothing_was_saved() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("s.csv");
    sphere(400, [0.0; 3], 48_730.0, 2.0, 8).write(&input).unwrap();
    let out = magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730"]);
    assert!(out.status.success());
    assert!(stderr(&out).contains("not saved"), "{}", stderr(&out));
}

#[test]
fn a_swing_on_one_course_warns_that_the_crab_goes_into_a() {
    // One leg at 62° (± 2° of steering), GPS course 2.8° off the heading
    // (a current's crab angle), no speed column.
    let mut rec = Recording { t_s: Some(vec![]), roll_deg: Some(vec![]), pitch_deg: Some(vec![]), ref_heading_deg: Some(vec![]), ..Recording::default() };
    let dip = 56.1f64.to_radians();
    for k in 0..3000 {
        let t = k as f64;
        let psi = (62.0 + 2.0 * (0.01 * t).sin()).to_radians();
        rec.mag.push(ned_to_body(ned_field(48_953.0, dip, 0.0), 0.0, 0.0, psi));
        rec.t_s.as_mut().unwrap().push(t);
        rec.roll_deg.as_mut().unwrap().push(0.0);
        rec.pitch_deg.as_mut().unwrap().push(0.0);
        rec.ref_heading_deg.as_mut().unwrap().push(psi.to_degrees() + 2.8);
    }
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("leg.csv");
    rec.write(&input).unwrap();
    let cal = dir.path().join("cal.json");
    CalDoc::new(ModelKind::Full, &FieldCal::identity(), 48_953.0, Default::default()).save(&cal).unwrap();
    let out = magcal(&["swing", "--input", p(&input), "--cal", p(&cal), "--delay-s", "0"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(err.contains("one course") && err.contains("go into A"), "{err}");
    let summary = String::from_utf8_lossy(&out.stdout);
    assert!(summary.contains("GPS course holds the crab angle"), "{summary}");
    // The crab is what A took: 2.8°.
    assert!(summary.contains("A=0.04887") || summary.contains("A=-0.04887"), "{summary}");
}

#[test]
fn backstep_says_its_two_biases_are_not_separable_without_a_swing_test() {
    let dir = tempfile::tempdir().unwrap();
    let f = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (scenario, out) in [("swing", "swing.csv"), ("run", "run.csv")] {
        let o = magcal(&["simulate", scenario, "--seed", "21", "--rate-hz", "1", "--out", &f(out)]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let o = magcal(&[&["fit", "--input", &f("swing.csv"), "--model", "axis", "--out", &f("cal1.json")][..], &site[..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let o = magcal(&[&["backstep", "--input", &f("run.csv"), "--cal", &f("cal1.json")][..], &site[..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("without --swing-input") && stderr(&o).contains("not observable apart"), "{}", stderr(&o));
    let o = magcal(&[&["backstep", "--input", &f("run.csv"), "--cal", &f("cal1.json"), "--swing-input", &f("swing.csv")][..], &site[..]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("not observable apart"), "{}", stderr(&o));
}

#[test]
fn an_impossible_attitude_or_a_glitch_is_refused_naming_the_row() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("run.csv");
    let mut rec = sphere(200, [0.0; 3], 48_730.0, 2.0, 9);
    let mut roll = vec![3.0; rec.len()];
    roll[40] = 999.0;
    rec.roll_deg = Some(roll);
    rec.write(&input).unwrap();
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730"]));
    // Data row 41 is line 42 (the header is line 1).
    assert!(e.contains("run.csv:42: column `roll_deg`: 999 is outside ±180°"), "{e}");
    let mut rec = sphere(200, [0.0; 3], 48_730.0, 2.0, 9);
    rec.mag[120] = [1e7, 0.0, 0.0];
    rec.write(&input).unwrap();
    let e = refused(&magcal(&["fit", "--input", p(&input), "--model", "axis", "--field-nt", "48730"]));
    assert!(e.contains("data row 121") && e.contains("glitch"), "{e}");
}

#[test]
fn the_report_takes_the_site_from_the_recordings_and_labels_what_it_shows() {
    let dir = tempfile::tempdir().unwrap();
    let f = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    for (scenario, out) in [("swing", "swing.csv"), ("validation", "validation.csv")] {
        let o = magcal(&["simulate", scenario, "--seed", "31", "--rate-hz", "1", "--out", &f(out)]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let o = magcal(&["fit", "--input", &f("swing.csv"), "--model", "axis", "--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01", "--out", &f("cal.json")]);
    assert!(o.status.success(), "{}", stderr(&o));
    // No --lat/--lon/--date: the site was "not available" though the
    // validation run carries its positions (near the simulator's 36.9° N, 50.6° E: 36.88° N, 50.61° E measured).
    let o = magcal(&["report", "--validation", &f("validation.csv"), "--cal", &f("cal.json"), "--out", &f("report")]);
    assert!(o.status.success(), "{}", stderr(&o));
    let html = std::fs::read_to_string(dir.path().join("report/index.html")).unwrap();
    assert!(html.contains("the recordings' mean position") && html.contains("36.8") && html.contains("50.6"), "site");
    // No --before: not "not available" beside the card's uncalibrated before.
    assert!(html.contains("not given (no coefficients before; the card's “before” is the uncalibrated heading)"));
    assert!(html.contains("from the fit's covariance only") && !html.contains("the fit's uncertainty and the heading noise"));
}
