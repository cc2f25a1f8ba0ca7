//! The real recordings in `tests/data`: magnitude spread before and after the fit.

use std::path::Path;

use calib_core::fit::{fit_batch, Full};
use serde_json::json;

/// The real recordings in `tests/data`: magnitude spread before and after
/// the full-ellipsoid fit (the agreement with an independent Li & Griffiths
/// fit is asserted by `cargo test -p host-tools --test real real_data`).
pub fn real_recordings(root: &Path) -> serde_json::Value {
    // CSV through the product's reader under a column mapping; bazhin's
    // file is bare `x y z` lines without a header (not a table).
    let load = |rel: &str, cols: [&str; 3]| -> Vec<[f64; 3]> {
        let path = root.join("tests/data").join(rel);
        if cols[0].is_empty() {
            let Ok(text) = std::fs::read_to_string(&path) else { return vec![] };
            return text.lines().filter_map(|l| {
                let v: Vec<f64> = l.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                (v.len() == 3).then(|| [v[0], v[1], v[2]])
            }).collect();
        }
        let map = format!("mx={},my={},mz={}", cols[0], cols[1], cols[2]);
        let rec = map.parse().ok().and_then(|map| host_tools::data::Recording::read_mapped(&path, &map).ok());
        rec.map(|r| r.complete_mag().1).unwrap_or_default()
    };
    let spread = |samples: &[[f64; 3]], cal: &calib_core::cal::FieldCal<f64>| {
        let m: Vec<f64> = samples.iter().map(|s| { let h = cal.apply(*s); (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() }).collect();
        let mean = m.iter().sum::<f64>() / m.len().max(1) as f64;
        100.0 * (m.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m.len().max(1) as f64).sqrt() / mean
    };
    let mut out = Vec::new();
    for (name, rel, cols) in [
        ("sunsided-full-sphere", "sunsided-full-sphere/hmc5883l_compass.csv", ["mag_x_gauss", "mag_y_gauss", "mag_z_gauss"]),
        ("ck-explorer", "ck-explorer/acc_mag_log.csv", ["mx", "my", "mz"]),
        ("bazhin", "bazhin/mag_out.txt", ["", "", ""]),
    ] {
        let s = load(rel, cols);
        let fitted = fit_batch::<Full, 9, f64>(&s, 1.0);
        out.push(json!({
            "recording": name,
            "samples": s.len(),
            "spread_before_pct": spread(&s, &calib_core::cal::FieldCal::identity()),
            "spread_after_pct": fitted.as_ref().map(|c| spread(&s, c)).ok(),
        }));
    }
    json!(out)
}

/// The section's Markdown: one row a recording, from its numbers.
pub fn markdown(real: &serde_json::Value) -> String {
    let mut md = String::from("## Real recordings: magnitude spread before and after the full fit\n\nThe 1σ spread of |F| over each recording in `tests/data`, raw and through the full-ellipsoid fit of the same samples (its agreement with an independent Li & Griffiths fit: `cargo test -p host-tools --test real real_data`).\n\n| recording | samples | spread before (%) | after (%) |\n|---|---|---|---|\n");
    for r in real.as_array().into_iter().flatten() {
        let pct = |v: &serde_json::Value| v.as_f64().map_or("—".to_string(), |p| format!("{p:.2}"));
        md += &format!("| {} | {} | {} | {} |\n", r["recording"].as_str().unwrap_or("?"), r["samples"], pct(&r["spread_before_pct"]), pct(&r["spread_after_pct"]));
    }
    md
}
