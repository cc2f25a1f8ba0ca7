//! Fit speed: `magcal fit` (auto, the default, and `--model attitude`) in
//! process — the CSV read and the fit, as the command does them — beside
//! scipy's `least_squares` fitting the attitude-aided model once from its
//! equations (`xtask/python/fit_speed.py`, the fit apart from Python's start
//! and the read), on simulated 1 330 s swings (roll, pitch, gyro) logged at
//! the rate that gives each row count, the ratio measured in one run.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

use calib_core::cal::ModelKind;
use host_tools::compute::fit_auto;
use host_tools::doc::Reference;
use host_tools::compute::{fit_recording, FitOptions, GyroLag};
use host_tools::data::read_recording;
use host_tools::doc::CalDoc;
use magcal_sim::field_test::{paper_site, swing, GyroModel, SensorModel, SWING_SEGMENTS_S};
use serde_json::json;

/// Rows of the timed recordings: 10⁴, the 66 500 of a 50 Hz swing, 10⁵, 10⁶.
pub const ROWS: [usize; 4] = [10_000, 66_500, 100_000, 1_000_000];

/// scipy's numbers for one recording.
#[derive(serde::Deserialize)]
struct Scipy {
    seconds_read: f64,
    seconds_fit: f64,
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
}

fn scipy(root: &Path, csv: &Path, field_nt: f64) -> Result<Scipy, String> {
    let out = Command::new("python3")
        .arg(root.join("xtask/python/fit_speed.py"))
        .arg(csv)
        .arg(field_nt.to_string())
        .output()
        .map_err(|e| format!("python3: {e}"))?;
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).trim().lines().last().unwrap_or("failed").to_string());
    }
    serde_json::from_slice(&out.stdout).map_err(|e| format!("fit_speed.py's output: {e}"))
}

/// The largest difference of two calibrations' coefficients, relative to
/// the matrix's mean gain and the field's radius in raw units.
fn coefficient_difference(doc: &CalDoc, theirs: &Scipy, field_nt: f64) -> f64 {
    let gain = (doc.matrix[0][0] + doc.matrix[1][1] + doc.matrix[2][2]) / 3.0;
    let radius = field_nt / gain;
    let mut worst = 0.0f64;
    for i in 0..3 {
        worst = worst.max((doc.bias[i] - theirs.bias[i]).abs() / radius);
        for j in 0..3 {
            worst = worst.max((doc.matrix[i][j] - theirs.matrix[i][j]).abs() / gain);
        }
    }
    worst
}

/// Read and fit in process, s, and the document.
fn ours(csv: &Path, opts: &FitOptions, auto: bool) -> Result<(f64, CalDoc), String> {
    let start = Instant::now();
    let rec = read_recording(csv, &Default::default()).map_err(|e| e.to_string())?.recording;
    let doc = if auto { fit_auto(&rec, opts).map(|(d, _)| d) } else { fit_recording(&rec, &FitOptions { model: ModelKind::Attitude, ..opts.clone() }) };
    let doc = doc.map_err(|e| e.to_string())?;
    Ok((start.elapsed().as_secs_f64(), doc))
}

/// The stated target: `fit` (auto) no slower than scipy's single fit of
/// one model (ratio ≤ 1). Met at 66 500 rows in five runs of seven, about
/// met at 10⁵, missed at 10⁶ and at 10⁴ when scipy runs fast, so held: no
/// row's ratio may exceed this. Measured (release, 2 cores, quiet, seven
/// runs 00:41–01:12 UTC 2026-11-28): 10⁴ rows 0.54–1.30 (auto 0.13–0.14
/// s), 66 500 rows 0.76–1.10 (auto 0.78–0.85 s, 12–13 µs a row; scipy's
/// own 0.75–1.08 s: the 1.06 and 1.10 are its fastest runs), 10⁵
/// 0.78–1.22, 10⁶
/// 1.16–1.32 (15.3–15.8 s, 15.3–15.8 µs a row). With a site auto fits
/// seven candidates; the held gyro fit is made beside the free one (one
/// set of equations and dip-free passes) and the held attitude fit reads
/// the free one's data-alone dip. At 10⁶ rows (752 Hz) the held gyro fit
/// is not refused (at 66 500 rows it is), so its folds are fitted and
/// judged too (six candidates judged against five): 1.3 times the cost a
/// row at 66 500. With the same candidates the cost is linear
/// ([`LINEAR_RATIO_MAX`]). The stage before: 10⁶ rows 17.5–20 µs a row,
/// 66 500 rows 13 µs; three stages before 91–96 µs a row.
pub const AUTO_RATIO_HELD: f64 = 2.5;

/// The section's targets: at every row count, `fit` auto ÷ scipy's fit ≤ 1
/// (held at [`AUTO_RATIO_HELD`]) and one attitude fit ÷ scipy's ≤ 1.
pub fn targets(v: &serde_json::Value) -> Vec<super::targets::Target> {
    use super::targets::{Bound, Target};
    let mut out = Vec::new();
    for row in v["rows"].as_array().into_iter().flatten() {
        let n = row["rows"].as_u64().unwrap_or(0);
        out.push(
            Target::new("fit-speed", format!("{n} rows: `fit` auto ÷ scipy's fit"), row["auto_over_scipy"].as_f64(), Bound::AtMost(1.0))
                .held(Bound::AtMost(AUTO_RATIO_HELD), "auto fits every candidate (seven with a site), each on the whole recording and five held-out folds; scipy fits one model once; at 10⁶ rows (752 Hz) the held gyro candidate is judged too"),
        );
        out.push(Target::new("fit-speed", format!("{n} rows: `--model attitude` ÷ scipy's fit"), row["attitude_over_scipy"].as_f64(), Bound::AtMost(1.0)));
    }
    // Linear: with the same candidates (no site: the dip-held ones are not
    // tried, so the same are judged at every rate), each larger recording's
    // cost a row against the 50 Hz swing's.
    let rows: Vec<&serde_json::Value> = v["rows"].as_array().into_iter().flatten().collect();
    let per_row = |r: &serde_json::Value| r["auto_no_site_s"].as_f64().zip(r["rows"].as_u64()).map(|(s, n)| s / n as f64);
    let base = rows.iter().find(|r| r["rows"].as_u64() == Some(LINEAR_FROM_ROWS as u64)).and_then(|r| per_row(r));
    for row in rows.iter().filter(|r| r["rows"].as_u64().is_some_and(|n| n > LINEAR_FROM_ROWS as u64)) {
        let n = row["rows"].as_u64().unwrap_or(0);
        out.push(Target::new("fit-speed", format!("{n} rows: `fit` auto without a site, cost a row ÷ at {LINEAR_FROM_ROWS} rows"), per_row(row).zip(base).map(|(a, b)| a / b), Bound::AtMost(LINEAR_RATIO_MAX)));
    }
    out
}

/// The row count the linearity target compares against: the 50 Hz swing.
pub const LINEAR_FROM_ROWS: usize = 66_500;

/// The largest cost a row at 10⁵ and 10⁶ rows over that at
/// [`LINEAR_FROM_ROWS`], `fit` auto without a site. Measured (release,
/// 2 cores, quiet, five runs 01:02–01:14 UTC 2026-11-28): 10⁵ rows
/// 0.95–1.11, 10⁶ rows 1.10–1.21 in process (the bench: the 10⁶-row fits'
/// memory comes fresh from the kernel, 2.5 s of page clearing the
/// 66 500-row fits do not pay), 1.0 as separate `magcal fit` runs
/// (10.1–10.8 µs a row both). The limit leaves that effect and the runs'
/// scatter (±5 %) room, no more.
pub const LINEAR_RATIO_MAX: f64 = 1.35;

/// The section's numbers and its Markdown table.
pub fn section(root: &Path) -> (serde_json::Value, String) {
    let dir = root.join("target/bench/fit_speed");
    let mut md = String::from(
        "\n| rows | rate (Hz) | `fit` auto (s) | µs a row | candidates judged | auto without a site (s; µs a row, judged) | `--model attitude` (s) | scipy `least_squares` fit (s) | scipy read (s) | auto ÷ scipy fit | attitude ÷ scipy fit | coefficients vs scipy |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut rows = Vec::new();
    if let Err(e) = std::fs::create_dir_all(&dir) {
        return (json!({"error": e.to_string()}), format!("\nnot measured: {e}\n"));
    }
    let site = paper_site();
    let Ok(field) = site.field() else {
        return (json!({"error": "the site's field"}), "\nnot measured: the site's field\n".into());
    };
    let field_nt = field.total_nt();
    let opts = FitOptions { model: ModelKind::Attitude, field_nt, saturation: None, allow_weak: false, gyro_lag: GyroLag::Given(0.0), reference: Some(Reference::world_model(site, &field)) };
    let duration_s = SWING_SEGMENTS_S[2].1;
    for n in ROWS {
        // A hair under n / duration: the simulator's 10⁶-row cap is checked
        // on the product, which rounds above 10⁶ otherwise.
        let rate_hz = n as f64 / duration_s * (1.0 - 1e-12);
        let csv = dir.join(format!("swing_{n}.csv"));
        let written = swing(&SensorModel::paper_like(), &site, 1, rate_hz).map(|s| s.with_gyro(&GyroModel::mems(), 1)).map_err(|e| e.to_string()).and_then(|s| s.write(&csv).map_err(|e| e.to_string()));
        if let Err(e) = written {
            let _ = writeln!(md, "| {n} | {rate_hz:.1} | not simulated: {e} | | | | | | | | | |");
            rows.push(json!({"rows": n, "error": e}));
            continue;
        }
        let auto = ours(&csv, &opts, true);
        let auto_no_site = ours(&csv, &FitOptions { reference: None, ..opts.clone() }, true);
        let attitude = ours(&csv, &opts, false);
        let theirs = scipy(root, &csv, field_nt);
        let _ = std::fs::remove_file(&csv);
        let secs = |r: &Result<(f64, CalDoc), String>| r.as_ref().ok().map(|(s, _)| *s);
        let (auto_s, attitude_s, scipy_s) = (secs(&auto), secs(&attitude), theirs.as_ref().ok().map(|t| t.seconds_fit));
        let no_site_s = secs(&auto_no_site);
        // The candidates judged on held-out data (not refused).
        let judged = |r: &Result<(f64, CalDoc), String>| r.as_ref().ok().and_then(|(_, d)| d.quality.auto.as_ref()).map(|a| a.candidates.iter().filter(|c| c.held_out_deg.is_some()).count());
        let ratio = |a: Option<f64>| a.zip(scipy_s).map(|(a, b)| a / b);
        let agreement = attitude.as_ref().ok().zip(theirs.as_ref().ok()).map(|((_, d), t)| coefficient_difference(d, t, field_nt));
        let show = |v: Option<f64>, e: Option<&String>| v.map_or_else(|| format!("failed: {}", e.map_or("", |e| e.as_str())), |s| format!("{s:.2}"));
        let _ = writeln!(
            md,
            "| {n} | {rate_hz:.1} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
            show(auto_s, auto.as_ref().err()),
            auto_s.map_or("—".into(), |s| format!("{:.1}", 1e6 * s / n as f64)),
            judged(&auto).map_or("—".into(), |j| j.to_string()),
            no_site_s.map_or_else(|| show(None, auto_no_site.as_ref().err()), |s| format!("{s:.2} ({:.1}, {})", 1e6 * s / n as f64, judged(&auto_no_site).map_or("—".into(), |j| j.to_string()))),
            show(attitude_s, attitude.as_ref().err()),
            show(scipy_s, theirs.as_ref().err()),
            theirs.as_ref().map_or("—".into(), |t| format!("{:.2}", t.seconds_read)),
            ratio(auto_s).map_or("—".into(), |r| format!("{r:.2}")),
            ratio(attitude_s).map_or("—".into(), |r| format!("{r:.2}")),
            agreement.map_or("—".into(), |a| format!("{a:.1e}")),
        );
        rows.push(json!({
            "rows": n,
            "rate_hz": rate_hz,
            "auto_s": auto_s,
            "auto_error": auto.as_ref().err(),
            "auto_model": auto.as_ref().ok().map(|(_, d)| d.model.name()),
            "auto_judged": judged(&auto),
            "auto_no_site_s": no_site_s,
            "auto_no_site_error": auto_no_site.as_ref().err(),
            "auto_no_site_judged": judged(&auto_no_site),
            "attitude_s": attitude_s,
            "attitude_error": attitude.as_ref().err(),
            "scipy_fit_s": scipy_s,
            "scipy_read_s": theirs.as_ref().ok().map(|t| t.seconds_read),
            "scipy_error": theirs.as_ref().err(),
            "auto_over_scipy": ratio(auto_s),
            "attitude_over_scipy": ratio(attitude_s),
            "attitude_vs_scipy_coefficients": agreement,
        }));
    }
    let _ = std::fs::remove_dir(&dir);
    let profile = if cfg!(debug_assertions) { "a debug build: not the numbers to quote" } else { "release build" };
    (json!({"profile": profile, "rows": rows}), md)
}

/// The `results.md` section "Fit speed".
pub fn markdown(fit_speed_md: &str) -> String {
    format!(
        "\n## Fit speed\n\n`magcal fit` in process (the CSV read and the fit, one run each; `auto` fits every candidate with its five held-out folds) beside scipy's `least_squares` fitting the attitude-aided model once from its equations (`xtask/python/fit_speed.py`: TRF, analytic Jacobian, a plain pass then Huber's loss; the fit timed, Python's start and the read apart), on simulated 1 330 s swings with roll, pitch and a gyro at the rate that gives each row count; a ratio below 1 is faster than scipy. Candidates judged: those `auto` fitted on every fold and judged on held-out data (the rest refused); without a site the dip-held candidates are not tried, so the same are judged at every rate, and the cost a row shows whether the fit is linear. Coefficients vs scipy: the largest difference of the attitude fit's matrix and hard iron from scipy's, relative to the gain and the field. Time it from a release build: `cargo test --release -p xtask bench::tests::fit_speed_section -- --ignored --nocapture`.\n{fit_speed_md}"
    )
}
