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
        "| effects | chain | seed | heading RMS (°) | with the anomaly's declination taken out (°) | of which white noise (°) | floor (true calibration: noise ⊕ the anomaly's declination beyond the run's mean) (°) (the declination part) | \\|F\\| error vs true field (nT) | \\|F\\| − IGRF (nT) | current vector error (%) | gain error (%/°C) | predicted heading RMS (°) (covariance, run's noise) | observed / predicted | GPS delay (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut full_all: Vec<EffectsOutcome> = Vec::new();
    let mut floor_rows: Vec<FloorRow> = Vec::new();
    let scenarios = effects_scenarios();
    for (name, effects) in scenarios.iter().filter(|(n, _)| *n != "none" && (other_chains || *n == "all")) {
        let variants: &[Variant] = if *name == "all" && other_chains { &Variant::ALL } else { &[Variant::Full] };
        for &seed in seeds {
            let data = match effects_data(&SensorModel::paper_like(), seed, effects) {
                Ok(d) => d,
                Err(e) => {
                    let _ = writeln!(md, "| {name} | – | {seed} | simulation failed: {e} |");
                    rows.push(json!({"effects": name, "seed": seed, "error": e.to_string()}));
                    if *name == "all" {
                        floor_rows.push(FloorRow { seed, heading_rms_deg: None, floor: None });
                    }
                    continue;
                }
            };
            let floor = data.floor();
            for &v in variants {
                match evaluate_variant(&data, v) {
                    Ok(o) => {
                        let _ = writeln!(
                            md,
                            "| {name} | {} | {seed} | {:.3} | {} | {:.3} | {:.3} ({:.3}) | {} | {:.0} | {} | {} | {} ({}, {}) | {} | {:.2} |",
                            v.label(),
                            o.heading_rms_deg,
                            opt(o.heading_rms_local_declination_deg, 3),
                            o.heading_noise_deg,
                            floor.floor_deg,
                            floor.declination_deg,
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
                            floor_rows.push(FloorRow { seed, heading_rms_deg: Some(o.heading_rms_deg), floor: Some(floor) });
                        }
                        rows.push(json!({"effects": name, "chain": v, "seed": seed, "outcome": o, "floor": floor}));
                    }
                    Err(e) => {
                        let _ = writeln!(md, "| {name} | {} | {seed} | refused: {e} |", v.label());
                        rows.push(json!({"effects": name, "chain": v, "seed": seed, "error": e.to_string(), "floor": floor}));
                        if *name == "all" && v == Variant::Full {
                            floor_rows.push(FloorRow { seed, heading_rms_deg: None, floor: Some(floor) });
                        }
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
    let (floor_target, floor_md) = floor_summary(SITE_57N, &floor_rows);
    let targets = json!({
        "seeds": full_all.len(),
        "floor_target": floor_target,
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
    let _ = write!(md, "{floor_md}\n\n");
    (json!({"rows": rows, "targets": targets}), md)
}

/// The `results.md` section "Real-vehicle effects".
pub fn markdown(effects_md: &str) -> String {
    format!("## Real-vehicle effects\n\nThe simulator with thruster interference, temperature drift, a crustal anomaly, an AHRS misalignment and a water current (`magcal_sim::effects`); a survey AUV at 0.9–1.3 m/s. With all five on: our chain with every model, the same chain with each effect's model switched off in turn, and the paper's method (its back-stepping, the swing fit against raw GPS course); then each effect alone with the full chain. True-heading RMS and \\|F\\| errors on a separate validation run; the per-ampere vector and the temperature gains against the simulator's truth; the predicted heading RMS is the joint back-stepping's covariance and the calibration run's white heading noise (second differences) in quadrature; the white-noise column is the validation error's own (from truth), for scale; the floor is what the true calibration scores on the validation run, from the simulator's truth alone (`magcal_sim::scenario::heading_floor`): its white heading noise in quadrature with the crustal anomaly's declination along the validation track beyond its mean along the calibration run, which no magnetometer sees and the swing fit against the run's GPS course takes into the heading offset (GPS delay truth: 2 s).\n\n{effects_md}\n")
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
    .into_iter()
    .chain(floor_target("effects", &t["floor_target"]))
    .collect()
}

/// The name of paper 000's site in the floor target (all five effects on).
const SITE_57N: &str = "57° N (paper 000), all five effects";

/// A seed's floor allows the target when it is at most this, °: the chain's
/// own error adds to the floor in quadrature, so a floor of 0.2° leaves
/// √(0.25² − 0.2²) = 0.15° for the calibration's error (as much as the
/// floor's white noise at 57° N, 0.22°, leaves below 0.3°), and a floor just
/// under 0.25° would leave nothing.
pub const FLOOR_ALLOWS_DEG: f64 = 0.2;

/// The validation heading RMS of the chain with every model (the default
/// chain) where the floor allows it, °.
pub const FLOOR_TARGET_DEG: f64 = 0.25;

/// One seed of a site: the default chain's validation heading RMS (`None`:
/// refused) and the validation run's floor (`None`: not simulated).
pub struct FloorRow {
    /// The seed.
    pub seed: u64,
    /// The chain with every model: validation true-heading RMS, °.
    pub heading_rms_deg: Option<f64>,
    /// The true-heading floor ([`magcal_sim::scenario::heading_floor`]).
    pub floor: Option<magcal_sim::scenario::HeadingFloor>,
}

/// One site's floor target: every seed with its floor and whether the
/// target applies (floor ≤ [`FLOOR_ALLOWS_DEG`]; a seed whose floor is
/// unknown counts as applying) and is met (heading RMS ≤
/// [`FLOOR_TARGET_DEG`]); the worst heading RMS over the seeds it applies
/// to (NaN when one of them was refused). JSON and a Markdown sentence.
pub fn floor_summary(site: &str, rows: &[FloorRow]) -> (serde_json::Value, String) {
    let applies = |r: &FloorRow| r.floor.is_none_or(|f| f.floor_deg <= FLOOR_ALLOWS_DEG);
    let seeds: Vec<serde_json::Value> = rows
        .iter()
        .map(|r| {
            let met = applies(r).then(|| r.heading_rms_deg.is_some_and(|h| h <= FLOOR_TARGET_DEG));
            json!({"seed": r.seed, "heading_rms_deg": r.heading_rms_deg, "floor_deg": r.floor.map(|f| f.floor_deg), "floor_white_noise_deg": r.floor.map(|f| f.white_noise_deg), "floor_declination_deg": r.floor.map(|f| f.declination_deg), "applies": applies(r), "met": met})
        })
        .collect();
    let applicable: Vec<&FloorRow> = rows.iter().filter(|r| applies(r)).collect();
    let worst = applicable.iter().map(|r| r.heading_rms_deg.unwrap_or(f64::NAN)).fold(f64::NEG_INFINITY, |a, b| if a.is_nan() || b.is_nan() { f64::NAN } else { a.max(b) });
    let worst = (!applicable.is_empty()).then_some(worst);
    let met = worst.is_some_and(|w| w <= FLOOR_TARGET_DEG);
    let f3 = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.3}"));
    let each: Vec<String> = rows
        .iter()
        .map(|r| {
            let verdict = match (applies(r), r.heading_rms_deg) {
                (false, _) => "floor above it".to_string(),
                (true, Some(h)) if h <= FLOOR_TARGET_DEG => "met".to_string(),
                (true, _) => "**missed**".to_string(),
            };
            format!("seed {} {}° (floor {}°, declination {}°: {verdict})", r.seed, f3(r.heading_rms_deg), f3(r.floor.map(|f| f.floor_deg)), f3(r.floor.map(|f| f.declination_deg)))
        })
        .collect();
    let verdict = match worst {
        None => format!("does not apply on any seed: every floor is above {FLOOR_ALLOWS_DEG}°"),
        Some(w) => format!("worst {w:.3}° on the {} seed(s) whose floor allows it: {}", applicable.len(), if met { "met" } else { "**not met**" }),
    };
    let md = format!(
        "**{site}**, the chain with every model where the floor (the true calibration: white noise ⊕ the anomaly's declination beyond the run's mean) is ≤ {FLOOR_ALLOWS_DEG}°, validation heading RMS ≤ {FLOOR_TARGET_DEG}°: {verdict}. {}.",
        each.join("; ")
    );
    let v = json!({"site": site, "allows_deg": FLOOR_ALLOWS_DEG, "target_deg": FLOOR_TARGET_DEG, "seeds": seeds, "applicable": applicable.len(), "worst_applicable_deg": worst, "met": met});
    (v, md)
}

/// The floor target of one site ([`floor_summary`]'s JSON): none when the
/// floor allows it on no seed (the seeds are reported with their floors).
pub fn floor_target(section: &'static str, v: &serde_json::Value) -> Option<super::targets::Target> {
    use super::targets::{Bound, Target};
    let applicable = v["applicable"].as_u64().unwrap_or(0);
    if applicable == 0 && v["seeds"].as_array().is_some_and(|s| !s.is_empty()) {
        return None;
    }
    let seeds: Vec<String> = v["seeds"].as_array().into_iter().flatten().filter(|s| s["applies"] == true).filter_map(|s| s["seed"].as_u64()).map(|s| s.to_string()).collect();
    let all = v["seeds"].as_array().map_or(0, Vec::len);
    let what = format!(
        "{}: validation heading RMS of the chain with every model, worst of the seeds whose floor ≤ {FLOOR_ALLOWS_DEG}° ({} of {all}: {}), °",
        v["site"].as_str().unwrap_or("?"),
        applicable,
        seeds.join(", ")
    );
    Some(Target::new(section, what, v["worst_applicable_deg"].as_f64(), Bound::AtMost(FLOOR_TARGET_DEG)))
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

#[cfg(test)]
mod tests {
    use super::*;
    use magcal_sim::scenario::HeadingFloor;

    fn row(seed: u64, heading: Option<f64>, floor: Option<f64>) -> FloorRow {
        FloorRow { seed, heading_rms_deg: heading, floor: floor.map(|f| HeadingFloor { floor_deg: f, white_noise_deg: f, declination_deg: 0.0 }) }
    }

    /// Only the seeds whose floor is ≤ 0.2° are judged; the others are
    /// reported, not judged; a refused chain where the floor allows it fails.
    #[test]
    fn the_floor_target_judges_only_the_seeds_whose_floor_allows_it() {
        let (v, md) = floor_summary("s", &[row(1, Some(0.24), Some(0.15)), row(2, Some(0.6), Some(0.5)), row(3, Some(0.1), Some(0.2))]);
        assert_eq!(v["applicable"], 2);
        assert_eq!(v["worst_applicable_deg"].as_f64(), Some(0.24));
        assert_eq!(v["seeds"][1]["applies"], false);
        assert!(v["seeds"][1]["met"].is_null());
        assert!(md.contains("seed 2 0.600° (floor 0.500°, declination 0.000°: floor above it)"), "{md}");
        let t = floor_target("varied", &v).expect("two seeds judged");
        assert!(t.miss().is_none() && t.what.contains("(2 of 3: 1, 3)"), "{t:?}");
        // The floor allows it nowhere: no target, the seeds still in the text.
        let (v, md) = floor_summary("s", &[row(1, Some(0.3), Some(0.21))]);
        assert!(floor_target("varied", &v).is_none() && md.contains("does not apply on any seed"), "{md}");
        // Refused where the floor allows it; a seed not simulated: fails.
        for rows in [[row(1, None, Some(0.1))], [row(1, None, None)]] {
            let (v, _) = floor_summary("s", &rows);
            assert!(floor_target("varied", &v).expect("judged").miss().is_some(), "{v}");
        }
        assert!(floor_target("varied", &floor_summary("s", &[]).0).expect("no seed: not measured").miss().is_some());
    }
}
