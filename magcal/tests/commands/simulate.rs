//! `magcal simulate`: the bench's effects runs are reachable from the CLI
//! (the README's five-effects numbers come from commands a reader can run),
//! and no size flag makes it allocate or write without bound.


use magcal_sim::effects::Effects;
use magcal_sim::scenario::effects_data;
use magcal_sim::SensorModel;
use super::{magcal, p};

/// `simulate swing|run|validation --runs effects --effects all` with the
/// bench's seeds (s, s + 100, s + 200) and rates (5, 2, 2 Hz) writes the
/// very recordings (and truths) `cargo xtask bench`'s effects section
/// scores for seed s.
#[test]
fn the_cli_writes_the_benchs_effects_runs() {
    let dir = tempfile::tempdir().unwrap();
    let seed = 2;
    let bench = effects_data(&SensorModel::paper_like(), seed, &Effects::all()).unwrap();
    for (name, sim, cli_seed, rate) in [("swing", &bench.swing, seed, "5"), ("run", &bench.run, seed + 100, "2"), ("validation", &bench.validation, seed + 200, "2")] {
        let want = dir.path().join(format!("bench_{name}.csv"));
        sim.write(&want).unwrap();
        let got = dir.path().join(format!("cli_{name}.csv"));
        let s = cli_seed.to_string();
        let out = magcal(&["simulate", name, "--runs", "effects", "--effects", "all", "--seed", &s, "--rate-hz", rate, "--out", p(&got)]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let (a, b) = (std::fs::read(&want).unwrap(), std::fs::read(&got).unwrap());
        assert!(a.len() > 100_000 && a == b, "{name}: the CLI's recording differs from the bench's ({} vs {} bytes)", b.len(), a.len());
        let (a, b) = (std::fs::read(want.with_extension("truth.json")).unwrap(), std::fs::read(got.with_extension("truth.json")).unwrap());
        assert!(a == b, "{name}: truth differs");
    }
    // The same run from the documented flags alone (the paper's base with
    // the bench's legs and speeds): the same rows (its truth records the
    // paper's 0.1 m/s current, replaced by the current effect's).
    let flags = dir.path().join("flags_run.csv");
    let out = magcal(&["simulate", "run", "--effects", "all", "--leg-m", "5000", "--speed-mps", "1.2", "--speed-back-mps", "0.9", "--seed", "102", "--rate-hz", "2", "--out", p(&flags)]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read(&flags).unwrap() == std::fs::read(dir.path().join("bench_run.csv")).unwrap());
}

/// Every size flag is bounded before any work, with the limit named:
/// `--leg-m 1e12` used to abort allocating 40 TB, `--leg-m 2e6` to write
/// 1.6 GB.
#[test]
fn size_flags_are_bounded_with_the_limit_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.csv");
    for (args, limit) in [
        (vec!["--leg-m", "1e12"], "100000 m"),
        (vec!["--leg-m", "2e6"], "100000 m"),
        (vec!["--speed-mps", "50"], "10 m/s"),
        (vec!["--leg-m", "100000", "--speed-mps", "0.2", "--rate-hz", "50"], "1e6 rows"),
        (vec!["--rate-hz", "5000"], "1000 Hz"),
        (vec!["--leg-m", "NaN"], "must be finite"),
        (vec!["--current-to-deg", "inf"], "must be finite"),
    ] {
        let mut all = vec!["simulate", "run", "--out", p(&out)];
        all.extend(&args);
        let started = std::time::Instant::now();
        let o = magcal(&all);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && o.status.code() == Some(1), "{args:?}: {:?} {err}", o.status);
        assert!(err.contains(limit), "{args:?}: {err}");
        assert!(started.elapsed().as_secs_f64() < 5.0, "{args:?}");
        assert!(!out.exists(), "{args:?} wrote a file");
    }
    let o = magcal(&["simulate", "swing", "--rate-hz", "1000", "--effects", "thrusters", "--thrust-test", "--out", p(&out)]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("1e6 rows"), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The text of an HTML fragment, tags stripped.
fn text_of(html: &str) -> String {
    let mut out = String::new();
    let mut in_tag = false;
    for c in html.chars() {
        match c {
            '<' => in_tag = true,
            '>' => in_tag = false,
            c if !in_tag => out.push(c),
            _ => {}
        }
    }
    out.trim().to_string()
}

/// The cells after the first of the first table row in `html` whose first
/// cell (`<td>` or `<th>`) reads `label`.
fn table_row(html: &str, label: &str) -> Option<Vec<String>> {
    html.split("<tr>").skip(1).find_map(|row| {
        let row = row.split("</tr>").next().unwrap_or("");
        // Each "</t" ends a cell: the text from the cell's opening tag on.
        let cells: Vec<String> = row.split("</t").filter_map(|c| c.split_once('>')).map(|(_, v)| text_of(v)).collect();
        (cells.first().map(String::as_str) == Some(label)).then(|| cells[1..].iter().filter(|c| !c.is_empty()).cloned().collect())
    })
}

/// The number at the start of a cell ("0.27°", "99.4 %", "3161").
fn number(cell: &str) -> f64 {
    let n: String = cell.chars().take_while(|c| c.is_ascii_digit() || *c == '.' || *c == '-').collect();
    n.parse().unwrap_or_else(|_| panic!("not a number: {cell:?}"))
}

/// The report's integrity section on a validation run past the simulator's
/// steel pier (`--effects structure`), through the README's commands:
/// simulate the swing test, a short run (2 km legs) and the validation run
/// (1.5 km legs at 2 Hz, the pier 1 km along the outbound leg), fit →
/// back-stepping → swing fit, then `report --validation`.
///
/// Measured (seeds 1, 2, 3): 3 180 rows, 3 161 ok, 2 disturbed, 17
/// cal_invalid, none without attitude; the 19 not-ok rows are the pier's
/// passage (t 498–507 s, 3.9–12.4 m from it, 580–2 290 nT at the sensor by
/// the truth column); heading RMS on the ok rows 0.27° against the truth,
/// predicted σ 0.25°, observed ÷ predicted 1.04 (0.33 while the σ took
/// each component's noise from the first step's |F| scatter, 378 nT, not
/// the back-stepping's per-axis residual, 91 nT: `Reference::noise_nt`);
/// longest disturbance 9.5 s.
#[test]
fn the_report_shows_the_integrity_along_a_validation_run_past_the_pier() {
    let dir = tempfile::tempdir().unwrap();
    let f = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let site = ["--lat", "36.9", "--lon", "50.6", "--date", "2021-01-01"];
    let steps: Vec<Vec<String>> = vec![
        vec!["simulate".into(), "swing".into(), "--seed".into(), "1".into(), "--out".into(), f("swing.csv")],
        vec!["simulate".into(), "run".into(), "--seed".into(), "2".into(), "--leg-m".into(), "2000".into(), "--out".into(), f("run.csv")],
        vec!["simulate".into(), "validation".into(), "--seed".into(), "3".into(), "--effects".into(), "structure".into(), "--leg-m".into(), "1500".into(), "--rate-hz".into(), "2".into(), "--out".into(), f("validation.csv")],
        [vec!["fit".into(), "--input".into(), f("swing.csv"), "--model".into(), "axis".into(), "--out".into(), f("cal1.json")], site.iter().map(|s| s.to_string()).collect()].concat(),
        [vec!["backstep".into(), "--input".into(), f("run.csv"), "--cal".into(), f("cal1.json"), "--out".into(), f("cal2.json")], site.iter().map(|s| s.to_string()).collect()].concat(),
        vec!["swing".into(), "--input".into(), f("run.csv"), "--cal".into(), f("cal2.json"), "--estimate-delay".into(), "--out".into(), f("cal3.json")],
        vec!["report".into(), "--run".into(), f("run.csv"), "--swing-input".into(), f("swing.csv"), "--validation".into(), f("validation.csv"), "--cal".into(), f("cal1.json"), "--cal".into(), f("cal3.json"), "--out".into(), f("report"), "--json".into()],
    ];
    let mut last = None;
    for args in &steps {
        let a: Vec<&str> = args.iter().map(String::as_str).collect();
        let out = magcal(&a);
        assert!(out.status.success(), "{a:?}: {}", String::from_utf8_lossy(&out.stderr));
        last = Some(out);
    }
    let rep: serde_json::Value = serde_json::from_slice(&last.unwrap().stdout).expect("the report's JSON");
    let missing = rep["missing"].as_array().unwrap();
    assert!(!missing.iter().any(|m| m.as_str().unwrap_or("").starts_with("integrity")), "{missing:?}");
    let html = std::fs::read_to_string(dir.path().join("report/index.html")).unwrap();
    let start = html.find("<section id=\"integrity\"><h2>Integrity along the validation run</h2>").expect("the integrity section");
    let section = &html[start..start + html[start..].find("</section>").unwrap()];
    assert!(!section.contains("Not available"), "{section}");
    let rows = |state: &str| number(&table_row(section, state).unwrap_or_else(|| panic!("no {state} row"))[0]);
    let (ok, disturbed, cal_invalid, no_attitude) = (rows("ok"), rows("disturbed"), rows("cal_invalid"), rows("no_attitude"));
    // The validation file's rows, all judged.
    let total = std::fs::read_to_string(f("validation.csv")).unwrap().lines().count() as f64 - 1.0;
    assert_eq!(ok + disturbed + cal_invalid + no_attitude, total);
    // The pier's passage is not ok (39 rows measured), the rest is.
    let not_ok = disturbed + cal_invalid;
    assert!((8.0..=80.0).contains(&not_ok), "{not_ok} rows not ok");
    assert!(ok / total > 0.97 && no_attitude == 0.0, "{ok} of {total} ok");
    let cell = |label: &str| number(&table_row(section, label).unwrap_or_else(|| panic!("no row {label}"))[0]);
    let observed = cell("Heading RMS on ok rows, observed");
    let predicted = cell("Predicted σ on ok rows (RMS)");
    let ratio = cell("Observed ÷ predicted (0.5–2: honest)");
    assert!(observed > 0.05 && observed < 1.0, "observed {observed}°");
    assert!(predicted > 0.05 && predicted < 3.0, "predicted {predicted}°");
    eprintln!("rows ok {ok}, disturbed {disturbed}, cal_invalid {cal_invalid}; observed {observed}° predicted {predicted}° ratio {ratio}");
    // Printed to 2 decimals from the unrounded values: the quotient of the
    // rounded ones is within their rounding (±0.005 each) of it.
    let rounding = 0.005 / predicted + 0.005 * observed / (predicted * predicted) + 0.005;
    assert!((ratio - observed / predicted).abs() <= rounding, "{ratio} vs {observed}/{predicted}");
    // Honest: the 0.5–2 asked.
    assert!(ratio > 0.5 && ratio < 2.0, "observed ÷ predicted {ratio}");
    // Where: the rows not ok are the pier's passage. `magcal apply` judges
    // the rows as the report did; every one not ok lies within 5 s of a row
    // where the simulator's truth puts more than 300 nT of the pier at the
    // sensor (measured: t 498–507 s, 580–2 290 nT).
    let out = magcal(&["apply", "--input", &f("validation.csv"), "--cal", &f("cal3.json"), "--out", &f("applied.csv")]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let column = |path: &str, name: &str| -> Vec<String> {
        let text = std::fs::read_to_string(path).unwrap();
        let mut lines = text.lines();
        let k = lines.next().unwrap().split(',').position(|c| c == name).unwrap_or_else(|| panic!("{path}: no {name}"));
        lines.map(|l| l.split(',').nth(k).unwrap_or("").to_string()).collect()
    };
    let t: Vec<f64> = column(&f("validation.csv"), "t").iter().map(|v| v.parse().unwrap()).collect();
    let pier: Vec<f64> = column(&f("validation.csv"), "truth_disturbance_nt").iter().map(|v| v.parse().unwrap_or(0.0)).collect();
    let states = column(&f("applied.csv"), "integrity");
    assert_eq!(states.len(), t.len());
    let near_pier: Vec<f64> = t.iter().zip(&pier).filter(|(_, d)| **d > 300.0).map(|(t, _)| *t).collect();
    assert!(!near_pier.is_empty());
    let flagged: Vec<f64> = t.iter().zip(&states).filter(|(_, s)| s.as_str() != "ok").map(|(t, _)| *t).collect();
    assert_eq!(flagged.len() as f64, not_ok);
    // Away from the pier at most three rows in a thousand (false alarms):
    // measured 4 of 3 180 (at 254, 261, 1 171 and 1 402 s) since a back-stepped document's gates
    // use its own run residual ⊕ its intensity's 1σ (139 nT on the README's
    // chain) instead of the first step's 378 nT, which let a bias 300
    // counts off pass as ok at 1.93° (magcal/tests/commands/reference.rs); none
    // with the stale scatter.
    let away: Vec<f64> = flagged.iter().copied().filter(|tf| !near_pier.iter().any(|tp| (tp - tf).abs() <= 5.0)).collect();
    assert!(away.len() as f64 <= 3e-3 * total, "rows not ok away from the pier at {away:?} s ({:?} s)", (near_pier.first(), near_pier.last()));
    let longest = cell("Longest disturbance");
    assert!(longest > 2.0 && longest < 40.0, "longest disturbance {longest} s");
    // The figure: the heading error coloured by state.
    assert!(section.contains("<svg") && section.contains("Heading error by integrity state"));
}
