//! Host throughput: batch and recursive fits, IGRF, numpy for scale.

use std::path::Path;

use calib_core::fit::{fit_batch, Full, FullRls, Normalization};
use anyhow::Result;
use serde_json::json;

/// Host throughput: batch and recursive full fits over 10⁶ samples, IGRF
/// evaluations per second, and numpy doing the same batch fit (when numpy is
/// installed) as a ratio.
pub fn host_throughput(root: &Path) -> serde_json::Value {
    use calib_core::conformance::{tumble_sample, SplitMix64, TUMBLE_FIELD_NT};
    use std::time::Instant;
    const N: usize = 1_000_000;
    let mut rng = SplitMix64::new(3);
    let samples: Vec<[f64; 3]> = (0..N).map(|_| tumble_sample(&mut rng)).collect();
    let t = Instant::now();
    let batch = fit_batch::<Full, 9, f64>(&samples, TUMBLE_FIELD_NT);
    let batch_s = t.elapsed().as_secs_f64();
    let mut rls = FullRls::<f64>::new(Normalization { centre: [0.0; 3], scale: TUMBLE_FIELD_NT });
    let t = Instant::now();
    for s in &samples {
        rls.push(*s);
    }
    let rls_s = t.elapsed().as_secs_f64();
    let mut rls32 = FullRls::<f32>::new(Normalization { centre: [0.0; 3], scale: TUMBLE_FIELD_NT as f32 });
    let t = Instant::now();
    for s in &samples {
        rls32.push(s.map(|v| v as f32));
    }
    let rls32_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut acc = 0.0;
    let evals = 20_000;
    for k in 0..evals {
        let lat = -80.0 + 160.0 * (k as f64 / evals as f64);
        if let Ok(f) = host_tools::geomag::igrf14(lat, (k % 360) as f64 - 180.0, 0.0, 2026.5) {
            acc += f.total_nt();
        }
    }
    let igrf_s = t.elapsed().as_secs_f64();
    let numpy = std::process::Command::new("python3")
        .arg(root.join("xtask/python/numpy_fit.py"))
        .arg(N.to_string())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| serde_json::from_slice::<serde_json::Value>(&o.stdout).ok());
    let ratio = numpy.as_ref().and_then(|v| v["numpy_full_fit_s"].as_f64()).map(|np| batch_s / np);
    json!({
        "samples": N,
        "batch_full_fit_s": batch_s,
        "batch_full_fit_ok": batch.is_ok(),
        "recursive_full_f64_s": rls_s,
        "recursive_full_f32_s": rls32_s,
        "igrf_evaluations_per_s": evals as f64 / igrf_s,
        "igrf_checksum": acc,
        "numpy": numpy,
        "batch_time_over_numpy": ratio,
    })
}

/// The `results.md` section "Host throughput".
pub fn markdown(host: &serde_json::Value) -> Result<String> {
    Ok(format!("## Host throughput\n\n```\n{}\n```\n", serde_json::to_string_pretty(host)?))
}
