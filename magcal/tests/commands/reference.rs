//! An independent reference behind every answer, from the
//! command line: the world model at the site judges `fit`, `fit` without
//! `--model` chooses on held-out data, and `apply` judges a recording
//! against the document's reference, not only against what the stream
//! teaches itself. The expected values come from the data's own READMEs
//! (IGRF-14 at the site, the peer calibrations' scatter, the true
//! calibration's heading RMS), not from the code under test.

use std::path::Path;
use std::process::Output;
use super::{magcal, p, data};

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The columns of a CSV by name (NaN for an empty cell).
fn columns(path: &Path) -> std::collections::HashMap<String, Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let names: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    let mut cols: std::collections::HashMap<String, Vec<f64>> = names.iter().map(|n| (n.clone(), Vec::new())).collect();
    for l in lines {
        for (n, v) in names.iter().zip(l.split(',')) {
            cols.get_mut(n).unwrap().push(v.parse().unwrap_or(f64::NAN));
        }
    }
    cols
}

#[derive(serde::Deserialize)]
struct Check {
    inclination_deg: Option<f64>,
    agrees: bool,
    #[serde(default)]
    disagreement: String,
}

#[derive(serde::Deserialize)]
struct Reference {
    source: String,
    inclination_deg: Option<f64>,
    inclination_sigma_deg: Option<f64>,
    check: Option<Check>,
}

#[derive(serde::Deserialize)]
struct Doc {
    model: String,
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
    reference: Option<Reference>,
    #[serde(default)]
    quality: serde_json::Map<String, serde_json::Value>,
}

fn read_doc(path: &Path) -> Doc {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Levelled dip of `h = M (raw − b)`, degrees.
fn dip_deg(doc: &Doc, raw: [f64; 3], roll_deg: f64, pitch_deg: f64) -> f64 {
    let d = [raw[0] - doc.bias[0], raw[1] - doc.bias[1], raw[2] - doc.bias[2]];
    let h: Vec<f64> = doc.matrix.iter().map(|r| r[0] * d[0] + r[1] * d[1] + r[2] * d[2]).collect();
    let (sr, cr, sp, cp) = (roll_deg.to_radians().sin(), roll_deg.to_radians().cos(), pitch_deg.to_radians().sin(), pitch_deg.to_radians().cos());
    // Z-Y-X Euler angles: level = R_y(pitch) R_x(roll) h.
    let y1 = cr * h[1] - sr * h[2];
    let z1 = sr * h[1] + cr * h[2];
    let x2 = cp * h[0] + sp * z1;
    let z2 = -sp * h[0] + cp * z1;
    z2.atan2(x2.hypot(y1)).to_degrees()
}

const SG236_SITE: [&str; 6] = ["--lat", "46.902", "--lon", "-124.894", "--date", "2023-06-01"];
/// IGRF-14's inclination at SG236's site (its README).
const SG236_IGRF_DIP_DEG: f64 = 67.82;

#[test]
fn a_glider_fitted_at_its_site_holds_igrf_dip_on_later_dives_and_says_so_in_its_document() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cal.json");
    let input = data("seaglider-sg236/sg236_calib.csv");
    let mut args = vec!["fit", "--input", p(&input), "--out", p(&out)];
    args.extend(SG236_SITE);
    let o = magcal(&args);
    ok(&o);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("model auto") && stderr.contains("kept attitude"), "{stderr}");
    let doc = read_doc(&out);
    assert_eq!(doc.model, "attitude");
    let r = doc.reference.as_ref().expect("a reference block");
    assert_eq!(r.source, "igrf14");
    assert!((r.inclination_deg.unwrap() - SG236_IGRF_DIP_DEG).abs() < 0.05, "{:?}", r.inclination_deg);
    assert!((0.5..=2.0).contains(&r.inclination_sigma_deg.unwrap()));
    let check = r.check.as_ref().unwrap();
    assert!(check.agrees && check.disagreement.is_empty());
    assert!((check.inclination_deg.unwrap() - SG236_IGRF_DIP_DEG).abs() < 1.5);
    assert!(doc.quality.contains_key("auto"), "the candidates' table is in the document");
    // Judged on dives 4–5 below 3 m (the README's rule): measured dip mean
    // 0.37° off IGRF and scatter 0.61°; the glider's own calibration 0.78°.
    let v = columns(&data("seaglider-sg236/sg236_validate.csv"));
    let dips: Vec<f64> = (0..v["mx"].len())
        .filter(|&i| v["depth_m"][i] > 3.0)
        .map(|i| dip_deg(&doc, [v["mx"][i], v["my"][i], v["mz"][i]], v["roll_deg"][i], v["pitch_deg"][i]))
        .filter(|d| d.is_finite())
        .collect();
    let mean = dips.iter().sum::<f64>() / dips.len() as f64;
    let sd = (dips.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / (dips.len() - 1) as f64).sqrt();
    assert!((mean - SG236_IGRF_DIP_DEG).abs() < 1.0, "held-out dip mean {mean:.2}°");
    assert!(sd <= 0.78, "held-out dip scatter {sd:.2}° against the glider's own 0.78°");
}

#[test]
fn a_fit_that_disagrees_with_the_world_model_is_refused_with_the_numbers_or_kept_with_the_disagreement() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("cal.json");
    let input = data("seaglider-sg236/sg236_calib.csv");
    // The wrong site: latitude 10° N, where IGRF's dip is about 28°.
    let wrong = ["--lat", "10", "--lon", "-124.894", "--date", "2023-06-01"];
    let mut args = vec!["fit", "--model", "attitude", "--input", p(&input), "--out", p(&out)];
    args.extend(wrong);
    let o = magcal(&args);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("disagrees with the reference field") && e.contains("where the reference gives 27.") && e.contains("--allow-weak"), "{e}");
    assert!(!out.exists());
    args.push("--allow-weak");
    ok(&magcal(&args));
    let doc = read_doc(&out);
    let check = doc.reference.unwrap().check.unwrap();
    assert!(!check.agrees && check.disagreement.contains("dip"), "{}", check.disagreement);

    // The roll and pitch columns in radians under degree names: levelled
    // with them the field is hardly levelled at all (measured dip 89.6°).
    let text = std::fs::read_to_string(&input).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let names: Vec<&str> = header.split(',').collect();
    let (ri, pi) = (names.iter().position(|n| *n == "roll_deg").unwrap(), names.iter().position(|n| *n == "pitch_deg").unwrap());
    let mut rad = format!("{header}\n");
    for l in lines {
        let mut cells: Vec<String> = l.split(',').map(String::from).collect();
        for k in [ri, pi] {
            if let Ok(v) = cells[k].parse::<f64>() {
                cells[k] = v.to_radians().to_string();
            }
        }
        rad.push_str(&cells.join(","));
        rad.push('\n');
    }
    let rad_path = dir.path().join("radians.csv");
    std::fs::write(&rad_path, rad).unwrap();
    let mut args = vec!["fit", "--model", "attitude", "--input", p(&rad_path), "--out", p(&out)];
    args.extend(SG236_SITE);
    let o = magcal(&args);
    assert!(!o.status.success());
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("look like radians"), "{e}");
    // Without a site too, and by default: refused by what the field shows
    // levelled both ways (before: accepted, predicting 0.15°).
    for model in ["attitude", "auto"] {
        let o = magcal(&["fit", "--model", model, "--input", p(&rad_path), "--field-nt", "52203", "--out", p(&out)]);
        assert!(!o.status.success());
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("look like radians"), "{model}: {e}");
    }
    // Said to be radians, they are read as such (measured 623 nT residual).
    ok(&magcal(&["fit", "--model", "attitude", "--input", p(&rad_path), "--field-nt", "52203", "--out", p(&out), "--columns", "roll_deg=roll_deg:rad,pitch_deg=pitch_deg:rad"]));
    // Degrees of a vehicle that stays within ±3° (the simulator's swing
    // test with small rolls and pitches): not taken for radians.
    let small = dir.path().join("small.csv");
    ok(&magcal(&["simulate", "swing", "--seed", "4", "--roll-amp-deg", "2.5", "--pitch-amp-deg", "1.5", "--out", p(&small)]));
    let o = magcal(&["fit", "--model", "attitude", "--input", p(&small), "--field-nt", "48000", "--out", p(&out)]);
    ok(&o);
}

/// `fit` without `--model` on a BROAD trial's calibration part, `apply` on
/// its validation part: the heading RMS with the constant offset removed
/// (the trials' truth heading has its own zero), and the document's
/// `expected_heading_rms_deg`.
fn broad_expected_and_observed(dir: &Path, trial: &str, field_nt: &str) -> (std::process::Output, f64, f64) {
    let out = dir.join("cal.json");
    let o = magcal(&["fit", "--input", p(&data(&format!("broad-{trial}_calib.csv"))), "--field-nt", field_nt, "--out", p(&out)]);
    ok(&o);
    let expected = read_doc(&out).quality["expected_heading_rms_deg"].as_f64().unwrap();
    let applied = dir.join("applied.csv");
    let a = magcal(&["apply", "--input", p(&data(&format!("broad-{trial}_validate.csv"))), "--cal", p(&out), "--out", p(&applied), "--json"]);
    ok(&a);
    #[derive(serde::Deserialize)]
    struct Summary {
        heading_rms_deg: f64,
        constant_offset_deg: f64,
    }
    let s: Summary = serde_json::from_slice(&a.stdout).unwrap();
    let observed = (s.heading_rms_deg.powi(2) - s.constant_offset_deg.powi(2)).max(0.0).sqrt();
    (o, expected, observed)
}

#[test]
fn fit_without_a_model_chooses_on_held_out_blocks_and_predicts_what_the_validation_shows() {
    let dir = tempfile::tempdir().unwrap();
    let (o, predicted, observed) = broad_expected_and_observed(dir.path(), "05/05", "44204");
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("held-out") && stderr.contains("attitude") && stderr.contains("gyro") && stderr.contains("sphere"), "{stderr}");
    // The floor (the true calibration) is 2.22° (the data's README);
    // measured: gyro kept, 1.69° observed against 1.81° expected.
    assert!(observed < 2.22 + 0.5, "{observed}");
    // Pooled over the five BROAD trials with a calibration and a
    // validation part (field: each truth's `field_nt`): one trial's RMS is
    // one draw, so single ratios scatter; the pool is held tightly.
    // Measured: 0.87 (02), 0.95 (03), 0.93 (05), 1.07 (06), 1.03 (09);
    // pooled 0.97.
    let mut ratios = vec![observed / predicted];
    for (trial, field_nt) in [("02-limited/02", "44591"), ("03/03", "45014"), ("06/06", "44152"), ("09/09", "44497")] {
        let (_, expected, observed) = broad_expected_and_observed(dir.path(), trial, field_nt);
        eprintln!("broad-{trial}: observed {observed:.3}° expected {expected:.3}°");
        ratios.push(observed / expected);
    }
    let pooled = (ratios.iter().map(|r| r * r).sum::<f64>() / ratios.len() as f64).sqrt();
    eprintln!("observed / expected: {ratios:?}, pooled {pooled:.3}");
    assert!(ratios.iter().all(|r| (0.5..=2.0).contains(r)), "{ratios:?}");
    assert!((0.7..=1.4).contains(&pooled), "{pooled}");
}

#[derive(Debug, serde::Deserialize)]
struct ApplySummary {
    rows_per_state: std::collections::BTreeMap<String, usize>,
    heading_rms_ok_deg: Option<f64>,
    inclination_source: String,
    hard_iron_applied: bool,
}

#[test]
fn apply_with_a_wrong_calibration_is_not_ok_against_the_documents_reference() {
    let dir = tempfile::tempdir().unwrap();
    let d = |f: &str| dir.path().join(f);
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    // The README's chain.
    let (swing, run_csv, validation) = (d("swing.csv"), d("run.csv"), d("validation.csv"));
    let (cal1, cal2, cal3) = (d("cal1.json"), d("cal2.json"), d("cal3.json"));
    ok(&magcal(&["simulate", "swing", "--seed", "1", "--out", p(&swing)]));
    ok(&magcal(&["simulate", "run", "--seed", "2", "--out", p(&run_csv)]));
    ok(&magcal(&["simulate", "validation", "--seed", "3", "--out", p(&validation)]));
    let mut a = vec!["fit", "--input", p(&swing), "--model", "axis", "--out", p(&cal1)];
    a.extend(site);
    ok(&magcal(&a));
    let mut a = vec!["backstep", "--input", p(&run_csv), "--cal", p(&cal1), "--out", p(&cal2)];
    a.extend(site);
    ok(&magcal(&a));
    ok(&magcal(&["swing", "--input", p(&run_csv), "--cal", p(&cal2), "--estimate-delay", "--out", p(&cal3)]));
    let right: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&cal3).unwrap()).unwrap();
    let variant = |name: &str, f: &dyn Fn(&mut serde_json::Value)| {
        let mut v = right.clone();
        f(&mut v);
        std::fs::write(d(name), v.to_string()).unwrap();
        d(name)
    };
    let zero = variant("zero.json", &|v| v["bias"] = serde_json::json!([0, 0, 0]));
    let b300 = variant("b300.json", &|v| v["bias"][0] = serde_json::json!(v["bias"][0].as_f64().unwrap() + 300.0));
    let x10 = variant("x10.json", &|v| {
        for r in 0..3 {
            for c in 0..3 {
                v["matrix"][r][c] = serde_json::json!(10.0 * v["matrix"][r][c].as_f64().unwrap());
            }
        }
    });
    // An identity calibration written by hand: no quality, no reference.
    let identity = variant("identity.json", &|v| {
        *v = serde_json::json!({"model": "full", "bias": [0, 0, 0], "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "field_nt": v["field_nt"]});
    });
    let t = columns(&validation)["t"].clone();
    let t0 = t[0];
    let run = |cal: &Path, with_site: bool| -> (ApplySummary, f64) {
        let out = dir.path().join("applied.csv");
        let mut a = vec!["apply", "--input", p(&validation), "--cal", p(cal), "--out", p(&out), "--json", "--columns", "ref_heading_deg=true_heading_deg"];
        if with_site {
            a.extend(site);
        }
        let o = magcal(&a);
        ok(&o);
        let s: ApplySummary = serde_json::from_slice(&o.stdout).unwrap();
        let text = std::fs::read_to_string(&out).unwrap();
        let states: Vec<String> = text.lines().skip(1).map(|l| l.rsplit(',').next().unwrap().to_string()).collect();
        let after: Vec<&String> = states.iter().zip(&t).filter(|(_, &t)| t >= t0 + 10.0).map(|(s, _)| s).collect();
        let not_ok = after.iter().filter(|s| s.as_str() != "ok").count() as f64 / after.len() as f64;
        (s, not_ok)
    };
    // The right one: measured 20 441 of 20 450 ok at 0.224°; after the
    // first 10 s a share of 0.0001 not ok (2 rows).
    let (s, not_ok) = run(&cal3, false);
    assert_eq!(s.inclination_source, "document");
    eprintln!("right calibration: {not_ok:.5} not ok after 10 s, {:?} on ok rows", s.heading_rms_ok_deg);
    assert!(not_ok < 0.001 && s.heading_rms_ok_deg.unwrap() < 0.4, "{:?} {:?}", s.rows_per_state, s.heading_rms_ok_deg);
    // Every document of the chain carries IGRF-14's reference, and the one
    // that goes to the board expects what the validation shows: measured
    // 0.196° expected (the covariance alone predicts 0.046°) against 0.224°.
    let doc = read_doc(&cal3);
    assert_eq!(doc.reference.as_ref().map(|r| r.source.as_str()), Some("igrf14"));
    // One run of several: the pool is held in
    // `the_expected_heading_rms_is_what_validation_shows_pooled_over_seeds`.
    let expected = doc.quality["expected_heading_rms_deg"].as_f64().unwrap();
    let observed = s.heading_rms_ok_deg.unwrap();
    assert!((0.5..=2.0).contains(&(observed / expected)), "observed {observed} expected {expected}");
    // Identity and 10× scale: never ok (measured: every row after 10 s;
    // the identity's hand-written document holds no inclination, so the
    // site's is used, and before the guard's offset limit the on-line hard
    // iron passed 17 126 rows at 53°).
    for (cal, with_site) in [(&identity, true), (&x10, false)] {
        let (s, not_ok) = run(cal, with_site);
        assert!(not_ok >= 0.95, "{}: {not_ok} {:?}", cal.display(), s.rows_per_state);
    }
    let (s, _) = run(&identity, true);
    assert_eq!(s.inclination_source, "site");
    // The bias zeroed: 18 750 nT (0.38 F) of hard iron, more than the
    // on-line estimate may carry: never ok (measured: every row after 10 s;
    // before the guard's limit, 98 % ok at 0.69°, 1.4° in the first 1 000 s
    // against a 0.27° σ).
    let (s, not_ok) = run(&zero, false);
    assert!(not_ok >= 0.95, "{not_ok} {:?}", s.rows_per_state);
    // 300 counts off (about 1 500 nT): found invalid, and the on-line hard
    // iron, checked against the document's dip, is applied; but the
    // simulator's validation run logs no gyro, so nothing independent of
    // the field confirms its headings (the on-line hard iron's guard) and no row is ok
    // with it (measured: every row after 10 s not ok; before the guard,
    // 0.23° on the rows it called ok, and with the first step's stale
    // 378 nT scatter 1.93°).
    let (s, not_ok) = run(&b300, false);
    assert!(s.hard_iron_applied, "{s:?}");
    assert!(not_ok >= 0.95, "{not_ok} {:?}", s.rows_per_state);
    if let Some(rms) = s.heading_rms_ok_deg {
        assert!(rms < 0.5, "ok rows {rms}° {:?}", s.rows_per_state);
    }
}

#[test]
fn apply_with_a_wrong_calibration_on_a_real_trial_is_never_ok() {
    // BROAD trial 05's validation part with its true calibration and three
    // wrong ones. Measured with the lab's inclination: the true one 0.4 %
    // of rows not ok after the first 10 s; each wrong one 100 % (`cargo
    // xtask bench`, bench::real_data, learns the dip: the same).
    let dir = tempfile::tempdir().unwrap();
    let truth: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(data("broad-05/05.truth.json")).unwrap()).unwrap();
    let input = data("broad-05/05_validate.csv");
    let t = columns(&input)["t"].clone();
    let m = &truth["matrix"];
    let x10: Vec<Vec<f64>> = (0..3).map(|r| (0..3).map(|c| 10.0 * m[r][c].as_f64().unwrap()).collect()).collect();
    let cases = [
        ("true", truth["bias"].clone(), m.clone(), false),
        ("zeroed", serde_json::json!([0, 0, 0]), m.clone(), true),
        ("identity", serde_json::json!([0, 0, 0]), serde_json::json!([[1, 0, 0], [0, 1, 0], [0, 0, 1]]), true),
        ("x10", truth["bias"].clone(), serde_json::json!(x10), true),
    ];
    for (name, bias, matrix, wrong) in cases {
        let cal = dir.path().join(format!("{name}.json"));
        std::fs::write(&cal, serde_json::json!({"model": "full", "bias": bias, "matrix": matrix, "field_nt": truth["field_nt"]}).to_string()).unwrap();
        let out = dir.path().join("out.csv");
        // The lab's inclination (the data's README, 69.513°) as the reference.
        ok(&magcal(&["apply", "--input", p(&input), "--cal", p(&cal), "--out", p(&out), "--inclination-deg", "69.513"]));
        let text = std::fs::read_to_string(&out).unwrap();
        let after: Vec<bool> = text.lines().skip(1).zip(&t).filter(|(_, &ti)| ti >= t[0] + 10.0).map(|(l, _)| !l.ends_with(",ok")).collect();
        let not_ok = after.iter().filter(|b| **b).count() as f64 / after.len() as f64;
        if wrong {
            assert!(not_ok >= 0.95, "{name}: {not_ok}");
        } else {
            assert!(not_ok < 0.05, "{name}: {not_ok}");
        }
        // Without a reference, nothing is ok: the right calibration's rows
        // are unjudged, the wrong ones' not ok either, and apply says why.
        let o = magcal(&["apply", "--input", p(&input), "--cal", p(&cal), "--out", p(&out)]);
        ok(&o);
        assert!(String::from_utf8_lossy(&o.stderr).contains("holds no reference inclination"), "the learned dip is said");
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(!text.lines().any(|l| l.ends_with(",ok")), "{name}");
        if !wrong {
            assert!(text.lines().filter(|l| l.ends_with(",unjudged")).count() > 900, "{name}");
        }
    }
}

/// The README's chain on simulated recordings (swing, out-and-back run,
/// validation from `seed`, `seed + 1`, `seed + 2`): `fit --model axis` at
/// the site, `backstep`, `swing --estimate-delay`; then `apply` on the
/// validation run against its true heading. Returns the document's
/// `expected_heading_rms_deg` and the RMS on the rows judged ok.
fn chain_expected_and_observed(dir: &Path, seed: u64) -> (f64, f64) {
    let d = |f: &str| dir.join(format!("{seed}-{f}"));
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let (swing, run_csv, validation) = (d("swing.csv"), d("run.csv"), d("validation.csv"));
    let (cal1, cal2, cal3, applied) = (d("cal1.json"), d("cal2.json"), d("cal3.json"), d("applied.csv"));
    let seeds = [seed, seed + 1, seed + 2].map(|s| s.to_string());
    ok(&magcal(&["simulate", "swing", "--seed", &seeds[0], "--out", p(&swing)]));
    ok(&magcal(&["simulate", "run", "--seed", &seeds[1], "--out", p(&run_csv)]));
    ok(&magcal(&["simulate", "validation", "--seed", &seeds[2], "--out", p(&validation)]));
    let mut a = vec!["fit", "--input", p(&swing), "--model", "axis", "--out", p(&cal1)];
    a.extend(site);
    ok(&magcal(&a));
    let mut a = vec!["backstep", "--input", p(&run_csv), "--cal", p(&cal1), "--out", p(&cal2)];
    a.extend(site);
    ok(&magcal(&a));
    ok(&magcal(&["swing", "--input", p(&run_csv), "--cal", p(&cal2), "--estimate-delay", "--out", p(&cal3)]));
    let o = magcal(&["apply", "--input", p(&validation), "--cal", p(&cal3), "--out", p(&applied), "--json", "--columns", "ref_heading_deg=true_heading_deg"]);
    ok(&o);
    let s: ApplySummary = serde_json::from_slice(&o.stdout).unwrap();
    let expected = read_doc(&cal3).quality["expected_heading_rms_deg"].as_f64().unwrap();
    (expected, s.heading_rms_ok_deg.unwrap())
}

/// What a document expects (`expected_heading_rms_deg`) is what the
/// validation shows, pooled over three simulated chains (the first is the
/// one above): one run's RMS is one draw (the calibration's error is one
/// per chain), so only the pool is held tightly, as the joint
/// back-stepping's prediction is.
#[test]
fn the_expected_heading_rms_is_what_validation_shows_pooled_over_seeds() {
    let dir = tempfile::tempdir().unwrap();
    let mut ratios = Vec::new();
    for seed in [1u64, 11, 21] {
        let (expected, observed) = chain_expected_and_observed(dir.path(), seed);
        eprintln!("seeds {seed}…: observed {observed:.4}° expected {expected:.4}°, ratio {:.3}", observed / expected);
        ratios.push(observed / expected);
    }
    let pooled = (ratios.iter().map(|r| r * r).sum::<f64>() / ratios.len() as f64).sqrt();
    eprintln!("observed / expected: {ratios:?}, pooled {pooled:.3}");
    // Measured: 1.143, 1.156, 1.144 (seeds 31 and 41: 1.149, 1.140);
    // pooled 1.148. The expectation is low by a steady 15 %, inside the
    // band; a σ scaled ×1.8 or ×0.6 is not.
    assert!(ratios.iter().all(|r| (0.5..=2.0).contains(r)), "{ratios:?}");
    assert!((0.7..=1.4).contains(&pooled), "{pooled}");
}
