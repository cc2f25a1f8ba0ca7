use super::*;
use crate::compute::card::DeviationCard;
use crate::data::Recording;
use crate::doc::CalDoc;
use crate::geomag::Site;
use calib_core::heading::wrap_pi;
use calib_core::cal::{FieldCal, ModelKind};

/// Level or tilted vehicle in a field 20 000 nT north, 40 000 nT down
/// (x forward, y starboard, z down), raw = true field + `bias_nt`; the
/// heading is `psi`, the attitude (roll, pitch) is applied as the sensor
/// sees it, so a tilt-compensated heading gets `psi` back.
fn body_field(psi_deg: f64, roll_deg: f64, pitch_deg: f64, bias_nt: [f64; 3]) -> [f64; 3] {
    let (s, c) = psi_deg.to_radians().sin_cos();
    // Earth → heading frame (yaw).
    let (n, e, d) = (20_000.0, 0.0, 40_000.0);
    let (x1, y1, z1) = (c * n + s * e, -s * n + c * e, d);
    // Pitch about y, then roll about x (body = Rx(φ)ᵀ Ry(θ)ᵀ …).
    let (st, ct) = pitch_deg.to_radians().sin_cos();
    let (x2, y2, z2) = (ct * x1 - st * z1, y1, st * x1 + ct * z1);
    let (sp, cp) = roll_deg.to_radians().sin_cos();
    let (x3, y3, z3) = (x2, cp * y2 + sp * z2, -sp * y2 + cp * z2);
    [x3 + bias_nt[0], y3 + bias_nt[1], z3 + bias_nt[2]]
}

const BIAS: [f64; 3] = [0.0, 1000.0, 0.0];

fn docs() -> (CalDoc, CalDoc) {
    let raw = CalDoc::new(ModelKind::Sphere, &FieldCal::identity(), 44_721.4, Default::default());
    let mut fixed = CalDoc::new(ModelKind::Sphere, &FieldCal { bias: BIAS, matrix: FieldCal::<f64>::identity().matrix }, 44_721.4, Default::default());
    fixed.quality.predicted_heading_rms_deg = Some(0.25);
    // The reference the integrity judges against: the test field's dip,
    // atan(40 000 / 20 000).
    fixed.reference = Some(crate::doc::reference::Reference { inclination_deg: Some(2f64.atan().to_degrees()), ..crate::doc::reference::Reference::user_intensity(44_721.4) });
    (raw, fixed)
}

fn recording(headings: &[f64], roll: &[f64], pitch: &[f64]) -> Recording {
    Recording {
        t_s: Some((0..headings.len()).map(|i| i as f64 * 0.5).collect()),
        mag: headings.iter().zip(roll.iter().zip(pitch)).map(|(h, (r, p))| body_field(*h, *r, *p, BIAS)).collect(),
        roll_deg: Some(roll.to_vec()),
        pitch_deg: Some(pitch.to_vec()),
        ref_heading_deg: Some(headings.to_vec()),
        ..Recording::default()
    }
}

#[test]
fn decimal_years_become_dates() {
    assert_eq!(date_of_decimal_year(2021.0), "2021-01-01");
    // 2020 is a leap year: 0.5 × 366 = day 183 (0-based) = 2 July.
    assert_eq!(date_of_decimal_year(2020.5), "2020-07-02");
    assert_eq!(date_of_decimal_year(2023.999), "2023-12-31");
}

#[test]
fn a_full_report_has_every_section_the_card_and_the_physics_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let (raw, fixed) = docs();
    // Swing: every heading, roll ±50°, pitch ±8°.
    let n = 3600;
    let sh: Vec<f64> = (0..n).map(|i| i as f64 * 0.1).collect();
    // Roll −50…+50° and pitch −8…+8° in a scrambled order (every value
    // within each 30° of heading).
    let sr: Vec<f64> = (0..n).map(|i| ((i * 37) % 101) as f64 - 50.0).collect();
    let sp: Vec<f64> = (0..n).map(|i| ((i * 13) % 17) as f64 - 8.0).collect();
    let swing = recording(&sh, &sr, &sp);
    // Run: out on 30°, back on 210°, level.
    let rh: Vec<f64> = (0..400).map(|i| if i < 200 { 30.0 } else { 210.0 }).collect();
    let run = recording(&rh, &vec![0.0; 400], &vec![0.0; 400]);
    // Validation: every 1° of heading, level; truth = the heading.
    let vh: Vec<f64> = (0..360).map(f64::from).collect();
    let val = recording(&vh, &vec![0.0; 360], &vec![0.0; 360]);
    let site = Site::new(36.9, 50.6, "2021-01-01").unwrap();
    let inputs = ReportInputs {
        run: Some(&run),
        swing: Some(&swing),
        validation: Some(Validation { recording: &val, truth_deg: &vh, truth_column: "true_heading_deg" }),
        cals: vec![("raw".into(), &raw), ("final".into(), &fixed)],
        before: Some(&raw),
        field_nt: Some(44_721.4),
        site: Some(site),
        summary: None,
        settings: None,
    };
    let out = write_report(dir.path(), &inputs).unwrap();
    assert!(out.missing.iter().all(|m| m.starts_with("backstep")), "only the trace is missing: {:?}", out.missing);
    let html = std::fs::read_to_string(&out.index).unwrap();
    for id in ["headline", "card", "coverage", "field", "heading", "integrity", "backstep", "residuals", "coefficients"] {
        assert!(html.contains(&format!("<section id=\"{id}\">")), "section {id}");
    }
    // Self-contained: no fetches (the only URL is the SVG namespace), print CSS.
    assert!(!html.contains("<img") && !html.contains("src=") && !html.contains("<script"));
    assert_eq!(html.matches("http").count(), html.matches("http://www.w3.org/2000/svg").count());
    assert!(html.contains("@media print"));
    // 9 since the integrity section's figure joined.
    assert_eq!(out.figures, 9, "card, 2 coverage, field, run heading, validation heading, integrity, 2 histograms");
    assert_eq!(html.matches("<svg").count(), 9);
    // The headline: the final calibration removes the bias exactly (0°);
    // before, the raw heading errs by physics: ψ − atan2(H sin ψ − b, H cos ψ).
    let before: f64 = (vh.iter().map(|p| {
        let r = p.to_radians();
        let e = wrap_pi(r - (20_000.0 * r.sin() - 1000.0).atan2(20_000.0 * r.cos()));
        e * e
    }).sum::<f64>() / 360.0).sqrt().to_degrees();
    assert!((before - 2.03).abs() < 0.03, "{before}"); // atan(1/20)/√2 = 2.025°
    assert!(html.contains(&format!("{before:.2}° → 0.00°")), "headline");
    assert!(html.contains("0.25° RMS"), "predicted heading error");
    assert!(html.contains("2021-01-01") && html.contains("36.9000° N"));
    // IGRF at the site, as the geomag module gives it.
    assert!(html.contains(&format!("F {:.0} nT", site.field().unwrap().total_nt())));
    // The card: against the truth, after = 0 everywhere.
    let card = out.card.unwrap();
    assert_eq!(card.against, "truth (validation run)");
    let json: DeviationCard = serde_json::from_str(&std::fs::read_to_string(&card.json).unwrap()).unwrap();
    assert_eq!(json.samples, 360);
    assert!(json.after.rms_deg.unwrap() < 1e-9);
    assert!((json.before.rms_deg.unwrap() - before).abs() < 1e-6);
    assert!(std::fs::read_to_string(&card.text).unwrap().contains("NNE"));
    assert!(std::fs::read_to_string(&card.csv).unwrap().lines().count() > 24);
    // Coverage: the swing reached every heading and ±40° roll, so no gap in
    // roll; pitch ±8° > the ±7° gate.
    let said = html.split(" gaps in roll").next().unwrap_or("");
    assert!(html.contains("0 gaps in roll, 0 in pitch"), "{}", &said[said.len().saturating_sub(40)..]);
}

#[test]
fn missing_inputs_are_said_not_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fixed) = docs();
    let inputs = ReportInputs { run: None, swing: None, validation: None, cals: vec![("final".into(), &fixed)], before: None, field_nt: None, site: None, summary: None, settings: None };
    let out = write_report(dir.path(), &inputs).unwrap();
    let html = std::fs::read_to_string(&out.index).unwrap();
    for section in ["headline", "card", "coverage", "field", "heading at the surface", "heading against truth", "backstep", "field residuals", "heading residuals"] {
        assert!(out.missing.iter().any(|m| m.starts_with(section)), "{section} missing in {:?}", out.missing);
    }
    assert_eq!(html.matches("class=\"missing\"").count(), out.missing.len());
    assert!(html.contains("not available (no site given)"));
    assert!(out.card.is_none() && out.figures == 0);
}

#[test]
fn a_swing_with_small_roll_shows_its_gaps() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fixed) = docs();
    // Every heading but roll only 0…+25°: roll cells from −40 to 0 and from
    // 30 to 40 are empty: 12 headings × (4 + 1) rows = 60 gaps.
    let n = 720;
    let h: Vec<f64> = (0..n).map(|i| i as f64 * 0.5).collect();
    let r: Vec<f64> = (0..n).map(|i| 12.5 + 12.5 * (i as f64 * 0.7).sin()).collect();
    let p: Vec<f64> = (0..n).map(|i| 9.0 * (i as f64 * 0.3).sin()).collect();
    let swing = recording(&h, &r, &p);
    let inputs = ReportInputs { run: None, swing: Some(&swing), validation: None, cals: vec![("final".into(), &fixed)], before: None, field_nt: None, site: None, summary: None, settings: None };
    let out = write_report(dir.path(), &inputs).unwrap();
    let html = std::fs::read_to_string(&out.index).unwrap();
    assert!(html.contains("60 gaps in roll, 0 in pitch"));
    // The map crosses each gap: two strokes a gap, in the gap red.
    let roll_map = html.split("heading × roll").nth(1).unwrap().split("</svg>").next().unwrap();
    assert_eq!(roll_map.matches("stroke=\"#D62728\"").count(), 2 * 60);
}


#[test]
fn inputs_that_lack_a_column_leave_their_section_saying_why() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fixed) = docs();
    let h: Vec<f64> = (0..100).map(|i| f64::from(i) * 3.6).collect();
    let mut run = recording(&h, &[0.0; 100], &[0.0; 100]);
    run.t_s = None;
    let mut swing = run.clone();
    swing.roll_deg = None;
    // A truth column that is empty everywhere: no card.
    let val = recording(&h, &[0.0; 100], &[0.0; 100]);
    let truth = vec![f64::NAN; 100];
    let inputs = ReportInputs {
        run: Some(&run),
        swing: Some(&swing),
        validation: Some(Validation { recording: &val, truth_deg: &truth, truth_column: "true_heading_deg" }),
        cals: vec![("final".into(), &fixed)],
        before: None,
        field_nt: None,
        site: None,
        summary: None,
        settings: None,
    };
    let out = write_report(dir.path(), &inputs).unwrap();
    let said = |prefix: &str, text: &str| out.missing.iter().any(|m| m.starts_with(prefix) && m.contains(text));
    assert!(said("field", "no `t` column"), "{:?}", out.missing);
    assert!(said("coverage", "no roll_deg/pitch_deg"), "{:?}", out.missing);
    assert!(said("card", "nothing to put on the card"), "{:?}", out.missing);
    assert!(out.card.is_none());
    // A truth column of the wrong length is bad input, refused.
    let short = vec![0.0; 99];
    let inputs = ReportInputs { validation: Some(Validation { recording: &val, truth_deg: &short, truth_column: "true_heading_deg" }), ..inputs };
    assert!(matches!(write_report(dir.path(), &inputs), Err(ReportError::TruthLength { truth_rows: 99, recording_rows: 100 })));
}

/// The integrity section on a validation run with a steel object passed:
/// the rows where the field is off are not ok, the figure is there with
/// its ±σ band and one colour per state seen.
#[test]
fn the_integrity_section_shows_a_disturbance_on_the_validation_run() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fixed) = docs();
    // 600 rows at 2 Hz turning 1° a row, level; rows 300–339 (20 s) carry
    // 5000 nT more along x (11 % of F, ~9× the 1.2 % scatter the monitor
    // expects): a hull passed at a few metres.
    let n = 600;
    let h: Vec<f64> = (0..n).map(|i| f64::from(i % 360)).collect();
    let mut val = recording(&h, &vec![0.0; n as usize], &vec![0.0; n as usize]);
    for m in &mut val.mag[300..340] {
        m[0] += 5000.0;
    }
    let inputs = validation_only(&val, &h, "true_heading_deg", &fixed);
    let out = write_report(dir.path(), &inputs).unwrap();
    let html = std::fs::read_to_string(&out.index).unwrap();
    let section = html.split("<section id=\"integrity\">").nth(1).expect("the section").split("</section>").next().unwrap();
    assert!(!out.missing.iter().any(|m| m.starts_with("integrity")), "{:?}", out.missing);
    assert!(section.contains("Heading error by integrity state") && section.contains("±1σ predicted"));
    assert_eq!(section.matches("<svg").count(), 1);
    // Rows per state: the 40 rows of the hull are not ok, and the rows
    // after it are ok again within the misfit fraction's exit (τ = 2 s to a
    // tenth: τ ln 10 = 4.6 s, 9 rows at 2 Hz), so at most 50 rows in one
    // stretch of at most 20 s + 4.6 s + a row. The hull's field, held in
    // the body over a 40° arc, raises the horizontal intensity there as a
    // gain error would over that arc; the two-cycle test's half-circles
    // seen before it (rows 0–299 turned 300°) show no two-cycle variation
    // and veto it. Measured: 2 disturbed + 46 cal_invalid, one stretch of
    // 24.0 s (as before the two-cycle test); without the veto 2 + 182.
    let count = |state: &str| -> usize {
        let cell = section.split(&format!("<td class=\"l\">{state}</td><td>")).nth(1).unwrap();
        cell.split('<').next().unwrap().parse().unwrap()
    };
    let not_ok = count("disturbed") + count("cal_invalid");
    assert!((40..=50).contains(&not_ok), "{not_ok}");
    let longest_s: f64 = section
        .split("Longest disturbance</th><td>")
        .nth(1)
        .and_then(|c| c.split(' ').next())
        .and_then(|c| c.parse().ok())
        .unwrap_or(f64::NAN);
    assert!((20.0..=25.1).contains(&longest_s), "{longest_s}");
    assert_eq!(count("ok") + not_ok + count("no_attitude"), 600);
    assert_eq!(count("no_attitude"), 0);
    // The disturbed rows' dots are orange (the state's colour) in the figure.
    assert!(section.contains("#FF7F0E") || section.contains("#D62728"));
    assert!(section.contains("Longest disturbance"));
    // The curve over the gates, the board's point marked.
    let board = section.split("(board)</b></td>").nth(1).expect("the board's row").split("</tr>").next().unwrap();
    let cells: Vec<&str> = board.split("<td>").skip(1).map(|c| c.split('<').next().unwrap()).collect();
    // Measured: 35 rows off by more than 5°, all flagged; 98.6 % of the
    // 560 good rows ok (the 8 rows of the exit above; without the
    // two-cycle test's veto 74.3 %); 0.00° on the ok rows (noise-free).
    assert_eq!(cells.first().copied(), Some("35"), "{cells:?}");
    assert_eq!(cells.get(1).copied(), Some("100.0 %"), "{cells:?}");
    let good_ok: f64 = cells.get(3).and_then(|c| c.trim_end_matches(" %").parse().ok()).unwrap_or(f64::NAN);
    assert!(good_ok > 98.0, "{cells:?}");
    assert_eq!(section.matches("<tr><td class=\"l\">").count() - 5, 7, "seven points and five states");
}

/// Without a validation run the section says so; with one whose truth is
/// empty and no reference heading, the table is there and the figure said missing.
#[test]
fn the_integrity_section_without_its_inputs_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let (_, fixed) = docs();
    let inputs = ReportInputs { run: None, swing: None, validation: None, cals: vec![("final".into(), &fixed)], before: None, field_nt: None, site: None, summary: None, settings: None };
    let out = write_report(dir.path(), &inputs).unwrap();
    assert!(out.missing.iter().any(|m| m.starts_with("integrity: no validation run")), "{:?}", out.missing);
    let h: Vec<f64> = (0..100).map(|i| f64::from(i) * 3.6).collect();
    let mut val = recording(&h, &[0.0; 100], &[0.0; 100]);
    val.ref_heading_deg = None;
    let truth = vec![f64::NAN; 100];
    let inputs = ReportInputs { validation: Some(Validation { recording: &val, truth_deg: &truth, truth_column: "true_heading_deg" }), ..inputs };
    let out = write_report(dir.path(), &inputs).unwrap();
    assert!(out.missing.iter().any(|m| m.starts_with("integrity figure")), "{:?}", out.missing);
    let html = std::fs::read_to_string(&out.index).unwrap();
    assert!(html.contains("<td class=\"l\">ok</td><td>100</td>"));
}

/// A validation heading from a GPS course
/// (`--truth-column ref_heading_deg`) is not the truth, and the headline
/// says so; a truth column keeps the "true-heading" label.
#[test]
fn the_headline_names_a_reference_that_is_not_the_truth() {
    let (_, fixed) = docs();
    let h: Vec<f64> = (0..100).map(|i| f64::from(i) * 3.6).collect();
    let val = recording(&h, &[0.0; 100], &[0.0; 100]);
    let headline = |column: &str| {
        let dir = tempfile::tempdir().unwrap();
        let out = write_report(dir.path(), &validation_only(&val, &h, column, &fixed)).unwrap();
        let html = std::fs::read_to_string(&out.index).unwrap();
        html.split("<table class=\"headline\">").nth(1).unwrap().split("</table>").next().unwrap().to_string()
    };
    let gps = headline("ref_heading_deg");
    assert!(gps.contains("Heading RMS against `ref_heading_deg`") && gps.contains("not the truth") && gps.contains("crab angle"), "{gps}");
    assert!(!gps.contains("True-heading RMS"), "{gps}");
    for column in ["true_heading_deg", "TRUE_HEADING"] {
        let truth = headline(column);
        assert!(truth.contains("True-heading RMS on validation") && !truth.contains("not the truth"), "{column}: {truth}");
    }
}

/// Inputs with only a validation run (its truth from `column`) and one
/// final calibration.
fn validation_only<'a>(val: &'a Recording, truth_deg: &'a [f64], column: &'a str, fixed: &'a CalDoc) -> ReportInputs<'a> {
    ReportInputs {
        run: None,
        swing: None,
        validation: Some(Validation { recording: val, truth_deg, truth_column: column }),
        cals: vec![("final".into(), fixed)],
        before: None,
        field_nt: None,
        site: None,
        summary: None,
        settings: None,
    }
}

/// Every integrity state has its own colour in the report's figure: the
/// states of `IntegrityState::ALL`, none sharing one; ok green, calibration
/// invalid red, no attitude grey (the legend's words).
#[test]
fn every_integrity_state_has_its_own_colour() {
    use calib_core::integrity::IntegrityState;
    let colours: Vec<(u8, u8, u8)> = IntegrityState::ALL
        .iter()
        .map(|&s| {
            let c = sections::state_colour(s);
            (c.0, c.1, c.2)
        })
        .collect();
    for (i, c) in colours.iter().enumerate() {
        assert!(!colours[..i].contains(c), "{:?} shares {c:?}", IntegrityState::ALL[i]);
    }
    let of = |s: IntegrityState| colours[s.index()];
    let (r, g, b) = of(IntegrityState::Ok);
    assert!(g > r && g > b, "ok {:?}", (r, g, b));
    let (r, g, b) = of(IntegrityState::CalInvalid);
    assert!(r > g && r > b, "cal_invalid {:?}", (r, g, b));
    let (r, g, b) = of(IntegrityState::NoAttitude);
    assert!(r == g && g == b, "no_attitude {:?}", (r, g, b));
}
