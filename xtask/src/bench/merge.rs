//! Logs on two clocks: `magcal merge`, its clock tables and the chain on merged logs.

use std::fmt::Write as _;

use anyhow::Result;
use serde_json::json;

/// One log shape of the merge section: simulated logs cut into a board log
/// and a navigation log (every `nav_every`-th row, with the heading
/// `nav_heading` says) whose clocks differ by ±60 s and ±100 ppm, merged
/// with the offset searched within ±120 s; the offset and drift errors and
/// their stated σ per case, then over the cases the worst error and the
/// RMS error over the RMS σ (1 when the σ tells the truth).
pub fn merge_rate(
    label: &str,
    target_ms: f64,
    sim: &dyn Fn(u64) -> Option<magcal_sim::field_test::Simulation>,
    nav_every: usize,
    nav_heading: magcal_sim::logs::NavHeading,
    md: &mut String,
) -> serde_json::Value {
    use host_tools::data::{merge, Clock};
    use magcal_sim::logs::{split, LogSplit};
    let estimate = Clock::Estimate { center_s: 0.0, max_offset_s: 120.0 };
    let (mut rows, mut errors) = (Vec::new(), Vec::new());
    for base in MERGE_SHAPE_SEEDS {
        for (k, (offset_s, drift_ppm)) in [(60.0f64, 100.0f64), (60.0, -100.0), (-60.0, 100.0), (-60.0, -100.0)].into_iter().enumerate() {
            // Each case its own noise (its own simulation), so the RMS
            // error over the RMS σ is measured on as many realisations.
            let seed = 4 * base + k as u64;
            let Some(sim) = sim(seed) else { continue };
            // A little off the round numbers, so no grid lines up by chance.
            let offset_s = offset_s - 0.0137 * offset_s.signum() * base as f64;
            let (board, nav) = split(&sim, &LogSplit { offset_s, drift_ppm, nav_every, trim_s: (20.0, 15.0), seed, nav_heading });
            match merge(&board, &nav, estimate) {
                Ok(m) => {
                    let r = &m.report;
                    let (e_ms, e_ppm, s_ms) = ((r.offset_s - offset_s) * 1e3, r.drift_ppm - drift_ppm, r.offset_sigma_s * 1e3);
                    errors.push((e_ms, s_ms));
                    let _ = writeln!(md, "| {label} | {seed} | {offset_s:.4} | {drift_ppm} | {e_ms:+.2} | {s_ms:.2} | {:+.2} | {e_ppm:+.1} | {:.1} |", e_ms / s_ms, r.drift_sigma_ppm);
                    rows.push(json!({"seed": seed, "offset_s": offset_s, "drift_ppm": drift_ppm, "offset_error_ms": e_ms, "offset_sigma_ms": s_ms, "drift_error_ppm": e_ppm, "drift_sigma_ppm": r.drift_sigma_ppm}));
                }
                Err(e) => {
                    let _ = writeln!(md, "| {label} | {seed} | {offset_s:.4} | {drift_ppm} | refused: {e} | | | | |");
                    rows.push(json!({"seed": seed, "offset_s": offset_s, "drift_ppm": drift_ppm, "error": e.to_string()}));
                }
            }
        }
    }
    let n = errors.len().max(1) as f64;
    let worst_ms = errors.iter().map(|e| e.0.abs()).fold(0.0, f64::max);
    let rms = |f: fn(&(f64, f64)) -> f64| (errors.iter().map(|e| f(e).powi(2)).sum::<f64>() / n).sqrt();
    let (rms_error_ms, rms_sigma_ms) = (rms(|e| e.0), rms(|e| e.1));
    json!({"rate": label, "cases": rows, "merged": errors.len(), "refused": rows.len() - errors.len(), "target_ms": target_ms, "worst_offset_error_ms": worst_ms, "rms_offset_error_ms": rms_error_ms, "rms_offset_sigma_ms": rms_sigma_ms, "error_over_sigma": rms_error_ms / rms_sigma_ms})
}

/// Seeds of the merge section's chain on merged logs.
pub const MERGE_SEEDS: [u64; 3] = [11, 12, 13];

/// Seeds of the merge section's clock tables: each with four clocks, each
/// clock its own simulation (seed 4·s + k), so that the RMS error over the
/// RMS stated σ is measured on 24 noise realisations per log shape.
pub const MERGE_SHAPE_SEEDS: [u64; 6] = [11, 12, 13, 14, 15, 16];

/// The clock tables of the merge section ([`merge_rate`], one per log
/// shape): swing tests with a 50 Hz board and a 10 Hz navigation log (with
/// the AHRS heading); swing tests with both logs at 5 Hz, with the AHRS
/// heading and without a heading column (roll, pitch, position only);
/// out-and-back runs with both logs at 1 Hz; and runs of 400 s of circles
/// at the surface then the legs with their dives, both logs at 1 Hz, whose
/// only heading is the GPS course at the surface (the two shapes without an AHRS heading).
pub fn merge_shapes() -> (Vec<serde_json::Value>, String) {
    use magcal_sim::field_test::{self, paper_site, RunKind, RunParams, SensorModel};
    use magcal_sim::logs::NavHeading;
    let (sensor, site) = (SensorModel::paper_like(), paper_site());
    let mut md = String::from("| logs | seed | offset put in (s) | drift put in (ppm) | offset error (ms) | offset σ (ms) | error / σ | drift error (ppm) | drift σ (ppm) |\n|---|---|---|---|---|---|---|---|---|\n");
    let swing = |rate_hz: f64| move |seed: u64| field_test::swing(&sensor, &site, seed, rate_hz).ok();
    let rates = vec![
        merge_rate("swing, board 50 Hz, navigation 10 Hz", 20.0, &swing(50.0), 5, NavHeading::Ahrs, &mut md),
        merge_rate("swing, both 5 Hz", 20.0, &swing(5.0), 1, NavHeading::Ahrs, &mut md),
        merge_rate("swing, both 5 Hz, no heading column", 20.0, &swing(5.0), 1, NavHeading::None, &mut md),
        merge_rate("run, both 1 Hz", 50.0, &|seed| field_test::run(&sensor, &site, &RunParams::paper_like(), seed + 50, 1.0, RunKind::Run).ok(), 1, NavHeading::Ahrs, &mut md),
        merge_rate(
            "circles then legs, both 1 Hz, GPS course at the surface only",
            50.0,
            &|seed| field_test::run(&sensor, &site, &RunParams::circles_then_legs(400.0), seed + 60, 1.0, RunKind::Run).ok(),
            1,
            NavHeading::CourseOnly,
            &mut md,
        ),
    ];
    md.push_str("\n| logs | merged | refused | worst offset error (ms) | target (ms) | RMS error (ms) | RMS stated σ (ms) | RMS error / RMS σ (0.5–2 asked) |\n|---|---|---|---|---|---|---|---|\n");
    for r in &rates {
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        let _ = writeln!(md, "| {} | {} | {} | {:.2} | {} | {:.2} | {:.2} | {:.2} |", r["rate"].as_str().unwrap_or(""), r["merged"], r["refused"], f("worst_offset_error_ms"), f("target_ms"), f("rms_offset_error_ms"), f("rms_offset_sigma_ms"), f("error_over_sigma"));
    }
    md.push('\n');
    (rates, md)
}

/// The `merge` numbers: the clock tables
/// ([`merge_shapes`]); then, per seed, the validation heading RMS of the
/// chain (axis fit → back-stepping → swing fit) on merged 50 Hz logs
/// against the single-clock recordings they were cut from.
pub fn merge_clocks() -> (serde_json::Value, String) {
    use host_tools::compute::{self, ChainOptions};
    use host_tools::data::{merge, Clock};
    use magcal_sim::field_test::{self, paper_site, RunKind, RunParams, SensorModel};
    use magcal_sim::logs::{split, LogSplit, NavHeading};
    use magcal_sim::scenario::heading_rms_deg;
    let estimate = Clock::Estimate { center_s: 0.0, max_offset_s: 120.0 };
    let (sensor, site) = (SensorModel::paper_like(), paper_site());
    let (rates, mut md) = merge_shapes();
    // The clocks' tables now: the chain below takes minutes.
    eprintln!("{md}");

    md.push_str("| seed | validation heading RMS, single clock (°) | from merged logs (°) | difference (°) |\n|---|---|---|---|\n");
    let mut headings = Vec::new();
    for seed in MERGE_SEEDS {
        let opts = ChainOptions::default();
        let sims = (
            field_test::swing(&sensor, &site, seed + 100, 50.0),
            field_test::run(&sensor, &site, &RunParams::paper_like(), seed + 200, 25.0, RunKind::Run),
            field_test::run(&sensor, &site, &RunParams::validation(), seed + 300, 2.0, RunKind::Validation),
        );
        let (Ok(swing), Ok(run), Ok(validation)) = sims else { continue };
        let (sb, sn) = split(&swing, &LogSplit { offset_s: 41.3, drift_ppm: 80.0, nav_every: 5, trim_s: (10.0, 10.0), seed, nav_heading: NavHeading::Ahrs });
        let (rb, rn) = split(&run, &LogSplit { offset_s: -23.9, drift_ppm: -60.0, nav_every: 5, trim_s: (10.0, 10.0), seed, nav_heading: NavHeading::Ahrs });
        let result = (|| -> Result<(f64, f64), String> {
            let single = compute::calibrate(&swing.recording, &run.recording, &site, &opts).map_err(|e| e.to_string())?;
            let ms = merge(&sb, &sn, estimate).map_err(|e| e.to_string())?;
            let mr = merge(&rb, &rn, estimate).map_err(|e| e.to_string())?;
            let merged = compute::calibrate(&ms.recording, &mr.recording, &site, &opts).map_err(|e| e.to_string())?;
            Ok((heading_rms_deg(&single.final_doc, &validation), heading_rms_deg(&merged.final_doc, &validation)))
        })();
        match result {
            Ok((h1, h2)) => {
                let _ = writeln!(md, "| {seed} | {h1:.4} | {h2:.4} | {:+.4} |", h2 - h1);
                headings.push(json!({"seed": seed, "single_clock_deg": h1, "merged_deg": h2, "difference_deg": h2 - h1}));
            }
            Err(e) => {
                let _ = writeln!(md, "| {seed} | refused: {e} | | |");
                headings.push(json!({"seed": seed, "error": e}));
            }
        }
    }
    (json!({"rates": rates, "validation_heading_rms": headings}), md)
}

/// The `results.md` section "Logs on two clocks: `magcal merge`".
pub fn markdown(merge_md: &str) -> String {
    format!("## Logs on two clocks: `magcal merge`\n\nSwing tests at 50 Hz (board) and 10 Hz (navigation), swing tests with both logs at 5 Hz (with the AHRS heading, and without a heading column), out-and-back runs with both at 1 Hz, and runs of surface circles then legs with dives at 1 Hz whose only heading is the GPS course at the surface, cut into two logs whose clocks differ by ±60 s and ±100 ppm; the offset searched within ±120 s; the stated σ against the error over the cases. Then the chain on merged logs vs on the single-clock recordings, heading RMS on a separate validation run.\n\n{merge_md}\n")
}
