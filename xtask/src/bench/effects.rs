//! The five real-vehicle effects: the chain with every model, each model off in turn, the paper's method.

use std::fmt::Write as _;

use serde_json::json;

/// Seeds of the effects section (at least five, so a range is reported, not a lucky seed).
pub const EFFECTS_SEEDS: [u64; 5] = [1, 2, 3, 4, 5];

/// The simulator with the five real-vehicle effects. With all
/// five on, over [`EFFECTS_SEEDS`]: our chain with every new model, the
/// same chain with each effect's model switched off in turn, and the
/// paper's method; then each effect alone with the full chain. Scored
/// against the simulator's truth: validation true-heading RMS, |F| error
/// against the true local field, the thrusters' per-ampere vector and the
/// temperature gains, the predicted heading RMS and observed/predicted.
pub fn effects() -> (serde_json::Value, String) {
    effects_with(&EFFECTS_SEEDS, true)
}

/// [`effects`] over `seeds`; with `other_chains` false only the chain with
/// every model on all five effects (what the targets are about).
pub fn effects_with(seeds: &[u64], other_chains: bool) -> (serde_json::Value, String) {
    use magcal_sim::scenario::{effects_data, effects_scenarios, evaluate_variant, EffectsOutcome, Variant};
    use magcal_sim::SensorModel;
    let opt = |v: Option<f64>, digits: usize| v.map_or("–".to_string(), |x| format!("{x:.digits$}"));
    let mut rows = Vec::new();
    let mut md = String::from(
        "| effects | chain | seed | heading RMS (°) | with the anomaly's declination taken out (°) | of which white noise (°) | \\|F\\| error vs true field (nT) | \\|F\\| − IGRF (nT) | current vector error (%) | gain error (%/°C) | predicted heading RMS (°) (covariance, run's noise) | observed / predicted | GPS delay (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut full_all: Vec<EffectsOutcome> = Vec::new();
    let scenarios = effects_scenarios();
    for (name, effects) in scenarios.iter().filter(|(n, _)| *n != "none" && (other_chains || *n == "all")) {
        let variants: &[Variant] = if *name == "all" && other_chains { &Variant::ALL } else { &[Variant::Full] };
        for &seed in seeds {
            let data = match effects_data(&SensorModel::paper_like(), seed, effects) {
                Ok(d) => d,
                Err(e) => {
                    let _ = writeln!(md, "| {name} | – | {seed} | simulation failed: {e} |");
                    rows.push(json!({"effects": name, "seed": seed, "error": e.to_string()}));
                    continue;
                }
            };
            for &v in variants {
                match evaluate_variant(&data, v) {
                    Ok(o) => {
                        let _ = writeln!(
                            md,
                            "| {name} | {} | {seed} | {:.3} | {} | {:.3} | {} | {:.0} | {} | {} | {} ({}, {}) | {} | {:.2} |",
                            v.label(),
                            o.heading_rms_deg,
                            opt(o.heading_rms_local_declination_deg, 3),
                            o.heading_noise_deg,
                            opt(o.field_error_true_nt, 0),
                            o.field_error_igrf_nt,
                            opt(o.current_vector_error_pct, 1),
                            opt(o.gain_error_pct_per_c, 4),
                            opt(o.predicted_heading_rms_deg, 3),
                            opt(o.predicted_calibration_deg, 3),
                            opt(o.run_heading_noise_deg, 3),
                            opt(o.observed_over_predicted, 2),
                            o.gps_delay_s
                        );
                        if *name == "all" && v == Variant::Full {
                            full_all.push(o);
                        }
                        rows.push(json!({"effects": name, "chain": v, "seed": seed, "outcome": o}));
                    }
                    Err(e) => {
                        let _ = writeln!(md, "| {name} | {} | {seed} | refused: {e} |", v.label());
                        rows.push(json!({"effects": name, "chain": v, "seed": seed, "error": e.to_string()}));
                    }
                }
            }
        }
    }
    // The targets against the worst seed of the full chain, all five on.
    let worst = |f: &dyn Fn(&EffectsOutcome) -> Option<f64>| full_all.iter().map(|o| f(o).unwrap_or(f64::NAN)).fold(f64::NEG_INFINITY, |a, b| if b.is_nan() || a.is_nan() { f64::NAN } else { a.max(b) });
    let ratios: Vec<f64> = full_all.iter().map(|o| o.observed_over_predicted.unwrap_or(f64::NAN)).collect();
    let ratio_lo = ratios.iter().copied().fold(f64::INFINITY, |a, b| if b.is_nan() { f64::NAN } else { a.min(b) });
    let ratio_hi = ratios.iter().copied().fold(f64::NEG_INFINITY, |a, b| if b.is_nan() { f64::NAN } else { a.max(b) });
    let complete = full_all.len() == seeds.len();
    let heading = worst(&|o| Some(o.heading_rms_deg));
    let field = worst(&|o| o.field_error_true_nt);
    let current = worst(&|o| o.current_vector_error_pct);
    let gain = worst(&|o| o.gain_error_pct_per_c);
    let targets = json!({
        "seeds": full_all.len(),
        "heading_rms_deg": {"worst": heading, "target": 0.3, "met": complete && heading <= 0.3},
        "field_error_true_nt": {"worst": field, "target": 20.0, "met": complete && field <= 20.0},
        "current_vector_error_pct": {"worst": current, "target": 10.0, "met": complete && current <= 10.0},
        "gain_error_pct_per_c": {"worst": gain, "target": 0.03, "met": complete && gain <= 0.03},
        "observed_over_predicted": {"min": ratio_lo, "max": ratio_hi, "target": [0.5, 2.0], "met": complete && ratio_lo >= 0.5 && ratio_hi <= 2.0},
    });
    let met = |k: &str| if targets[k]["met"].as_bool() == Some(true) { "met" } else { "**not met**" };
    let _ = write!(
        md,
        "\nAll five effects, our chain with every model, worst of {} seeds: heading RMS {heading:.3}° (target ≤ 0.3°: {}); |F| error vs the true local field {field:.0} nT (≤ 20 nT: {}); current vector {current:.1} % (≤ 10 %: {}); temperature gains {gain:.4} %/°C (≤ 0.03 %/°C: {}); observed/predicted heading RMS {ratio_lo:.2}…{ratio_hi:.2} (0.5…2: {}).\n\n",
        full_all.len(),
        met("heading_rms_deg"),
        met("field_error_true_nt"),
        met("current_vector_error_pct"),
        met("gain_error_pct_per_c"),
        met("observed_over_predicted"),
    );
    (json!({"rows": rows, "targets": targets}), md)
}

/// The `results.md` section "Real-vehicle effects".
pub fn markdown(effects_md: &str) -> String {
    format!("## Real-vehicle effects\n\nThe simulator with thruster interference, temperature drift, a crustal anomaly, an AHRS misalignment and a water current (`magcal_sim::effects`); a survey AUV at 0.9–1.3 m/s. With all five on: our chain with every model, the same chain with each effect's model switched off in turn, and the paper's method (its back-stepping, the swing fit against raw GPS course); then each effect alone with the full chain. True-heading RMS and \\|F\\| errors on a separate validation run; the per-ampere vector and the temperature gains against the simulator's truth; the predicted heading RMS is the joint back-stepping's covariance and the calibration run's white heading noise (second differences) in quadrature; the white-noise column is the validation error's own (from truth), for scale (GPS delay truth: 2 s).\n\n{effects_md}\n")
}

/// The section's targets, on the worst seed of the chain with every model
/// with all five effects on: validation heading RMS ≤ 0.3°, |F| within
/// 20 nT of the true local field, the thrusters' per-ampere vector within
/// 10 %, the temperature gains within 0.03 %/°C, observed/predicted heading
/// RMS within 0.5–2. `v` is [`effects`]'s JSON.
pub fn targets(v: &serde_json::Value) -> Vec<super::targets::Target> {
    use super::targets::{Bound, Target};
    let t = &v["targets"];
    let worst = |k: &str| t[k]["worst"].as_f64();
    let seeds = t["seeds"].as_u64().unwrap_or(0);
    let what = |s: &str| format!("{s}, worst of {seeds} seeds, all five effects");
    vec![
        Target::new("effects", what("validation heading RMS, °"), worst("heading_rms_deg"), Bound::AtMost(0.3))
            .held(Bound::AtMost(HELD_HEADING_RMS_DEG), "0.32° on the worst seed"),
        Target::new("effects", what("|F| error against the true local field, nT"), worst("field_error_true_nt"), Bound::AtMost(20.0))
            .held(Bound::AtMost(HELD_FIELD_ERROR_NT), "the crustal anomaly's intensity is not observable from heading data"),
        Target::new("effects", what("thrusters' per-ampere vector error, %"), worst("current_vector_error_pct"), Bound::AtMost(10.0))
            .held(Bound::AtMost(HELD_CURRENT_VECTOR_ERROR_PCT), "the anomaly corrupts it: the simulated current is constant on each leg"),
        Target::new("effects", what("temperature gain error, %/°C"), worst("gain_error_pct_per_c"), Bound::AtMost(0.03))
            .held(Bound::AtMost(HELD_GAIN_ERROR_PCT_PER_C), "the anomaly along the track is taken for temperature"),
        Target::new("effects", what("observed/predicted heading RMS, least"), t["observed_over_predicted"]["min"].as_f64(), Bound::AtLeast(0.5)),
        Target::new("effects", what("observed/predicted heading RMS, most"), t["observed_over_predicted"]["max"].as_f64(), Bound::AtMost(2.0)),
    ]
}

// The held bounds of the missed targets: the worst over [`EFFECTS_SEEDS`]
// measured (`cargo xtask bench --ci`, 2026-11-27), rounded up by about 3 %.
/// Validation heading RMS, ° (measured 0.3206).
const HELD_HEADING_RMS_DEG: f64 = 0.33;
/// |F| error against the true local field, nT (measured 132.2).
const HELD_FIELD_ERROR_NT: f64 = 136.0;
/// The thrusters' per-ampere vector error, % (measured 55.1).
const HELD_CURRENT_VECTOR_ERROR_PCT: f64 = 57.0;
/// Temperature gain error, %/°C (measured 0.0807).
const HELD_GAIN_ERROR_PCT_PER_C: f64 = 0.083;
