//! Paper 001 (J vs N pairs and noise σ, both solvers), the f32 recursive fit against the f64 batch, and the figures.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use calib_core::conformance::{paper001_sample, tumble_sample, SplitMix64, PAPER001_TRUTH, TUMBLE_FIELD_NT};
use calib_core::fit::{fit_batch, Full, FullRls, Normalization};
use calib_core::ortho::{identify_all_samples, identify_linear, identify_ml, identify_pairwise, j_index};
use serde_json::json;

pub const PAIRS: [usize; 7] = [30, 60, 120, 240, 480, 720, 1440];
pub const SIGMAS: [f64; 5] = [0.0, 1e-4, 1e-3, 1e-2, 3e-2];
pub const SEEDS: u64 = 20;

/// Paper 001 §5.1: mean J over seeds for each N (pairs) and σ, both solvers.
pub fn paper001() -> (serde_json::Value, String) {
    let mut rows = Vec::new();
    let mut md = String::from("| σ | solver | ");
    for n in PAIRS {
        let _ = write!(md, "N={n} | ");
    }
    md.push_str("\n|---|---|");
    md.push_str(&"---|".repeat(PAIRS.len()));
    md.push('\n');
    for sigma in SIGMAS {
        for (name, solver) in [
            ("pairwise (paper)", identify_pairwise::<f64> as fn(&[[f64; 3]], [f64; 3]) -> _),
            ("linear + Cholesky", identify_linear::<f64>),
        ] {
            let _ = write!(md, "| {sigma:e} | {name} | ");
            for n in PAIRS {
                let mut js = Vec::new();
                for seed in 0..SEEDS {
                    let mut rng = SplitMix64::new(1000 * seed + n as u64);
                    let data: Vec<[f64; 3]> = (0..2 * n).map(|_| paper001_sample(&mut rng, sigma)).collect();
                    if let Ok(Some(a)) = solver(&data, [0.0; 3]).map(|t| t.angles()) {
                        js.push(j_index(&PAPER001_TRUTH, &a));
                    }
                }
                let mean = js.iter().sum::<f64>() / js.len().max(1) as f64;
                let failed = SEEDS as usize - js.len();
                rows.push(json!({"sigma": sigma, "solver": name, "pairs": n, "mean_j": mean, "failures": failed}));
                let _ = write!(md, "{mean:.2e}{} | ", if failed > 0 { format!(" ({failed} failed)") } else { String::new() });
            }
            md.push('\n');
        }
    }
    same_data(&mut rows, &mut md);
    (json!(rows), md)
}

/// Noise levels of the same-data comparison.
pub const SAME_DATA_SIGMAS: [f64; 5] = [1e-3, 1e-2, 3e-2, 0.1, 0.2];

/// Paper 001 beaten on its own terms: on the same 1 440 samples, the paper's
/// pairing (720 disjoint pairs, its solver), our objective over every sample,
/// and the maximum-likelihood (distance) refinement; mean J over the seeds.
pub fn same_data(rows: &mut Vec<serde_json::Value>, md: &mut String) {
    const SAMPLES: usize = 1440;
    let _ = write!(
        md,
        "\n**Same data, {SAMPLES} samples** (mean J over {SEEDS} seeds; the paper pairs them into 720 disjoint pairs):\n\n| σ | pairing (paper) | every sample | every sample + ML |\n|---|---|---|---|\n"
    );
    type Solve = fn(&[[f64; 3]], [f64; 3]) -> Option<calib_core::ortho::OrthoAngles<f64>>;
    let solvers: [(&str, Solve); 3] = [
        ("same data: pairing (paper)", |d, b| identify_pairwise(d, b).ok()?.angles()),
        ("same data: every sample", |d, b| identify_all_samples(d, b).ok()?.angles()),
        ("same data: every sample + ML", |d, b| identify_ml(d, b).ok()?.tri.angles()),
    ];
    for sigma in SAME_DATA_SIGMAS {
        let _ = write!(md, "| {sigma:e} | ");
        for (name, solve) in solvers {
            let js: Vec<f64> = (0..SEEDS)
                .filter_map(|seed| {
                    let mut rng = SplitMix64::new(7000 + seed);
                    let data: Vec<[f64; 3]> = (0..SAMPLES).map(|_| paper001_sample(&mut rng, sigma)).collect();
                    solve(&data, [0.0; 3]).map(|a| j_index(&PAPER001_TRUTH, &a))
                })
                .collect();
            let mean = js.iter().sum::<f64>() / js.len().max(1) as f64;
            let failed = SEEDS as usize - js.len();
            rows.push(json!({"sigma": sigma, "solver": name, "samples": SAMPLES, "mean_j": mean, "failures": failed}));
            let _ = write!(md, "{mean:.4}{} | ", if failed > 0 { format!(" ({failed} failed)") } else { String::new() });
        }
        md.push('\n');
    }
}

/// The f32 check (the board's fit must match the host's), measured: the recursive full fit in f32 (bit-identical
/// to the MCU's) against the f64 batch fit of the same tumble.
pub fn f32_vs_f64() -> serde_json::Value {
    let mut rng = SplitMix64::new(2024);
    let samples: Vec<[f64; 3]> = (0..2400).map(|_| tumble_sample(&mut rng)).collect();
    let batch = fit_batch::<Full, 9, f64>(&samples, TUMBLE_FIELD_NT).ok();
    let mut rls = FullRls::<f32>::new(Normalization { centre: [0.0; 3], scale: TUMBLE_FIELD_NT as f32 });
    for s in &samples {
        rls.push(s.map(|v| v as f32));
    }
    match (batch, rls.estimate(TUMBLE_FIELD_NT as f32)) {
        (Some(b), Ok(r)) => {
            let bias_err = (0..3).map(|k| (f64::from(r.bias[k]) - b.bias[k]).abs()).fold(0.0, f64::max);
            let num: f64 = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| (f64::from(r.matrix[i][j]) - b.matrix[i][j]).powi(2)).sum();
            let den: f64 = b.matrix.iter().flatten().map(|v| v * v).sum();
            json!({"samples": 2400, "bias_max_abs_diff": bias_err, "matrix_rel_diff": (num / den).sqrt()})
        }
        _ => json!({"error": "fit failed"}),
    }
}

/// SVG figures of the results (paper 001 Figs 3–4: J vs N per σ).
pub fn figures(out_dir: &Path, p1: &serde_json::Value) -> Result<Vec<String>> {
    use host_tools::report::{line_plot, Series};
    let mut files = Vec::new();
    for solver in ["pairwise (paper)", "linear + Cholesky"] {
        let mut series = Vec::new();
        for sigma in SIGMAS.iter().filter(|s| **s > 0.0) {
            let points = p1
                .as_array()
                .into_iter()
                .flatten()
                .filter(|r| r["solver"] == solver && r["sigma"].as_f64() == Some(*sigma))
                .filter_map(|r| Some(((r["pairs"].as_f64()?).log10(), r["mean_j"].as_f64()?.log10())))
                .collect();
            series.push(Series { name: format!("σ = {sigma:e}"), points, dots: false });
        }
        let name = if solver.starts_with("pairwise") { "fig_paper001_j_pairwise.svg" } else { "fig_paper001_j_linear.svg" };
        std::fs::write(out_dir.join(name), line_plot(&format!("Paper 001: log10 J vs log10 N — {solver}"), "log10 N (pairs)", "log10 J", &series))?;
        files.push(name.to_string());
    }
    Ok(files)
}

/// The `results.md` section "Paper 001: J (eq 16) vs N pairs and noise σ".
pub fn markdown(p1_md: &str) -> String {
    format!("## Paper 001: J (eq 16) vs N pairs and noise σ\n\nMean over {SEEDS} seeds; field norm 2; σ per axis.\n\n{p1_md}\n![J, paper's solver](fig_paper001_j_pairwise.svg)\n![J, linear solver](fig_paper001_j_linear.svg)\n\n")
}

/// The `results.md` section "f32 recursive full fit vs f64 batch".
pub fn f32_markdown(f32_check: &serde_json::Value) -> String {
    format!("## f32 recursive full fit vs f64 batch\n\n`{f32_check}`\n\n")
}
