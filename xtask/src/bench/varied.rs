//! The five effects on varied sites: the chain with the
//! local field's gradient along the track against the chain without it, at
//! four sites unlike paper 000's and with every effect's magnitudes drawn
//! by seed ([`magcal_sim::varied`]); and the gradient prior chosen
//! leave-one-site-out.

use std::fmt::Write as _;

use calib_core::backstep::joint::GRADIENT_PRIOR_NT_PER_M;
use host_tools::compute::ChainOptions;
use magcal_sim::scenario::{evaluate_options, varied_effects_data, EffectsData, EffectsOutcome, Variant};
use magcal_sim::varied::{varied_sites, NamedSite};
use serde_json::json;

use super::effects::{floor_summary, floor_target, FloorRow};

/// Seeds of the varied-sites section.
pub const VARIED_SEEDS: [u64; 5] = [1, 2, 3, 4, 5];

/// The target for the validation heading RMS, °.
pub const TARGET_HEADING_RMS_DEG: f64 = 0.25;

/// Gradient priors (nT/m) the leave-one-site-out choice picks from.
pub const GRADIENT_PRIORS_NT_PER_M: [f64; 4] = [0.02, 0.1, 0.5, 2.0];

/// Seeds the leave-one-site-out choice uses (fewer: every prior is run on each).
const LOO_SEEDS: [u64; 3] = [1, 2, 3];

/// The chain with every model and a given gradient prior.
fn with_prior(prior_nt_per_m: f64) -> ChainOptions {
    let mut o = Variant::Full.options();
    o.joint.gradient_prior_nt_per_m = prior_nt_per_m;
    o
}

/// A short description of the drawn magnitudes (from the simulator's truth).
fn describe(data: &EffectsData) -> String {
    let Some(t) = data.run.truth.effects.as_ref() else { return String::new() };
    let mut parts = vec![];
    if let Some(th) = &t.thrusters {
        let per_a: Vec<String> = th.field_nt_per_a.iter().map(|f| format!("{:.0}", (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt())).collect();
        parts.push(format!("thrusters {} nT/A, bus {:.0}–{:.0} A", per_a.join("/"), th.bus_current_a_range[0], th.bus_current_a_range[1]));
    }
    if let Some(te) = &t.temperature {
        parts.push(format!("sensor {:.1}–{:.1} °C", te.sensor_c_range[0], te.sensor_c_range[1]));
    }
    if let Some(a) = &t.anomaly {
        parts.push(format!("anomaly {:.0}…{:.0} nT", a.intensity_anomaly_nt_range[0], a.intensity_anomaly_nt_range[1]));
    }
    if let Some(m) = t.ahrs_misalignment_deg {
        parts.push(format!("AHRS {:.2}°/{:.2}°", m[0], m[1]));
    }
    if let Some(c) = &t.current {
        parts.push(format!("current {:.2} m/s to {:.0}°", c.north_mps.hypot(c.east_mps), c.east_mps.atan2(c.north_mps).to_degrees().rem_euclid(360.0)));
    }
    parts.join("; ")
}

/// Runs one chain; the error as text.
fn run(data: &EffectsData, options: &ChainOptions) -> Result<EffectsOutcome, String> {
    evaluate_options(data, options).map_err(|e| e.to_string())
}

/// The simulated data of every site and seed (failures as text).
fn simulate(sites: &[NamedSite], seeds: &[u64]) -> Vec<(NamedSite, u64, Result<EffectsData, String>)> {
    let mut out = vec![];
    for s in sites {
        for &seed in seeds {
            out.push((*s, seed, varied_effects_data(&s.sensor(), &s.site, seed).map_err(|e| e.to_string())));
        }
    }
    out
}

/// Mean squared systematic heading error (RMS² − white noise²) of a chain
/// over data; NaN when any run failed.
fn mean_systematic_sq(data: &[&EffectsData], options: &ChainOptions) -> f64 {
    let mut sum = 0.0;
    for d in data {
        match run(d, options) {
            Ok(o) => sum += o.heading_systematic_deg.powi(2),
            Err(_) => return f64::NAN,
        }
    }
    sum / data.len().max(1) as f64
}

/// The section: JSON and Markdown.
pub fn varied_sites_section() -> (serde_json::Value, String) {
    varied_sites_with(&VARIED_SEEDS, true)
}

/// [`varied_sites_section`] over `seeds`; with `choice` false without the
/// chain before the gradient and the leave-one-site-out choice of its prior
/// (the targets are about the chain with the gradient).
pub fn varied_sites_with(seeds: &[u64], choice: bool) -> (serde_json::Value, String) {
    let sites = varied_sites();
    let f = |v: Option<f64>, p: usize| v.map_or("–".to_string(), |x| format!("{x:.p$}"));
    let mut md = String::from(
        "| site | seed | drawn magnitudes | chain | heading RMS (°) | with the anomaly's declination taken out (°) | of which white noise (°) | floor (true calibration: noise ⊕ the anomaly's declination beyond the run's mean) (°) (the declination part) | systematic (°) | predicted (°) | observed / predicted | \\|F\\| error vs true field (nT) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut rows = vec![];
    let data = simulate(&sites, seeds);
    // The chain with the gradient (the default chain) beside each seed's floor, per site.
    let mut floor_rows: Vec<(&str, Vec<FloorRow>)> = sites.iter().map(|s| (s.name, vec![])).collect();
    let mut floor_row = |site: &str, row: FloorRow| {
        if let Some(f) = floor_rows.iter_mut().find(|f| f.0 == site) {
            f.1.push(row);
        }
    };
    // Worst heading RMS, white noise and systematic part per site, new chain and without the gradient.
    let mut worst: Vec<(String, [f64; 3], [f64; 3], f64, f64, usize)> =
        sites.iter().map(|s| (s.name.to_string(), [0.0; 3], [0.0; 3], f64::INFINITY, 0.0, 0)).collect();
    for (site, seed, d) in &data {
        let d = match d {
            Ok(d) => d,
            Err(e) => {
                let _ = writeln!(md, "| {} | {seed} | simulation failed: {e} |", site.name);
                rows.push(json!({"site": site.name, "seed": seed, "error": e}));
                floor_row(site.name, FloorRow { seed: *seed, heading_rms_deg: None, floor: None });
                continue;
            }
        };
        let floor = d.floor();
        let w = worst.iter_mut().find(|w| w.0 == site.name);
        let described = describe(d);
        let mut slot = w;
        let chains = [("with the field gradient", Variant::Full.options(), 1usize), ("without it (before)", Variant::NoFieldGradient.options(), 2)];
        for (label, options, k) in chains.into_iter().filter(|c| choice || c.2 == 1) {
            match run(d, &options) {
                Ok(o) => {
                    let _ = writeln!(
                        md,
                        "| {} | {seed} | {} | {label} | {:.3} | {} | {:.3} | {:.3} ({:.3}) | {:.3} | {} | {} | {} |",
                        site.name,
                        if k == 1 { described.as_str() } else { "″" },
                        o.heading_rms_deg,
                        f(o.heading_rms_local_declination_deg, 3),
                        o.heading_noise_deg,
                        floor.floor_deg,
                        floor.declination_deg,
                        o.heading_systematic_deg,
                        f(o.predicted_heading_rms_deg, 3),
                        f(o.observed_over_predicted, 2),
                        f(o.field_error_true_nt, 0)
                    );
                    if let Some(w) = slot.as_mut() {
                        let target = if k == 1 { &mut w.1 } else { &mut w.2 };
                        target[0] = target[0].max(o.heading_rms_deg);
                        target[1] = target[1].max(o.heading_noise_deg);
                        target[2] = target[2].max(o.heading_systematic_deg);
                        if k == 1 {
                            let r = o.observed_over_predicted.unwrap_or(f64::NAN);
                            w.3 = w.3.min(r);
                            w.4 = w.4.max(r);
                            w.5 += 1;
                        }
                    }
                    if k == 1 {
                        floor_row(site.name, FloorRow { seed: *seed, heading_rms_deg: Some(o.heading_rms_deg), floor: Some(floor) });
                    }
                    rows.push(json!({"site": site.name, "seed": seed, "chain": label, "outcome": o, "floor": floor, "magnitudes": described}));
                }
                Err(e) => {
                    let _ = writeln!(md, "| {} | {seed} | {} | {label} | refused: {e} |", site.name, if k == 1 { described.as_str() } else { "″" });
                    if k == 1 {
                        floor_row(site.name, FloorRow { seed: *seed, heading_rms_deg: None, floor: Some(floor) });
                    }
                    rows.push(json!({"site": site.name, "seed": seed, "chain": label, "error": e, "floor": floor}));
                }
            }
        }
    }
    let _ = writeln!(md);
    let mut summary = vec![];
    for (name, new, old, lo, hi, n) in &worst {
        let met = *n == seeds.len() && new[0] <= TARGET_HEADING_RMS_DEG;
        let _ = writeln!(
            md,
            "- **{name}**, worst of {n} seeds: heading RMS {:.3}° with the gradient, {:.3}° without (target ≤ {TARGET_HEADING_RMS_DEG}°: {}); white noise up to {:.3}° (no calibration removes it: the AHRS's roll/pitch noise times tan I); systematic part {:.3}° with, {:.3}° without; observed/predicted {lo:.2}…{hi:.2}.",
            new[0],
            old[0],
            if met { "met" } else { "**not met**" },
            new[1],
            new[2],
            old[2]
        );
        summary.push(json!({"site": name, "seeds": n, "worst_heading_rms_deg": new[0], "worst_heading_rms_without_gradient_deg": old[0], "worst_white_noise_deg": new[1], "worst_systematic_deg": new[2], "worst_systematic_without_gradient_deg": old[2], "observed_over_predicted": [lo, hi], "target_deg": TARGET_HEADING_RMS_DEG, "met": met}));
    }
    let _ = writeln!(md);
    let mut floor_targets = vec![];
    for (site, rows) in &floor_rows {
        let (v, floor_md) = floor_summary(site, rows);
        let _ = writeln!(md, "- {floor_md}");
        floor_targets.push(v);
    }
    if !choice {
        return (json!({"rows": rows, "summary": summary, "floor_targets": floor_targets}), md);
    }
    // Leave one site out: the prior that does best (mean systematic²) on
    // the other sites, reported on the one left out.
    let _ = writeln!(md, "\nThe gradient prior (σ of ∂H/∂s and ∂Z/∂s; default {GRADIENT_PRIOR_NT_PER_M} nT/m) chosen leave-one-site-out from {GRADIENT_PRIORS_NT_PER_M:?} nT/m on seeds {LOO_SEEDS:?}: the prior with the smallest mean systematic² on the other sites, reported on the site left out.\n\n| left out | chosen prior (nT/m) | systematic RMS on the left-out site with it (°) | with the default (°) |\n|---|---|---|---|");
    let loo_data = simulate(&sites, &LOO_SEEDS);
    let mut loo = vec![];
    for left in &sites {
        let others: Vec<&EffectsData> = loo_data.iter().filter(|(s, _, _)| s.name != left.name).filter_map(|(_, _, d)| d.as_ref().ok()).collect();
        let mine: Vec<&EffectsData> = loo_data.iter().filter(|(s, _, _)| s.name == left.name).filter_map(|(_, _, d)| d.as_ref().ok()).collect();
        let scores: Vec<f64> = GRADIENT_PRIORS_NT_PER_M.iter().map(|&p| mean_systematic_sq(&others, &with_prior(p))).collect();
        let best = scores.iter().enumerate().filter(|(_, s)| s.is_finite()).min_by(|a, b| a.1.total_cmp(b.1)).map(|(i, _)| GRADIENT_PRIORS_NT_PER_M[i]);
        let on_left = best.map_or(f64::NAN, |p| mean_systematic_sq(&mine, &with_prior(p)).sqrt());
        let default = mean_systematic_sq(&mine, &with_prior(GRADIENT_PRIOR_NT_PER_M)).sqrt();
        let _ = writeln!(md, "| {} | {} | {on_left:.3} | {default:.3} |", left.name, best.map_or("–".into(), |p| format!("{p}")));
        loo.push(json!({"left_out": left.name, "scores_on_others": scores, "chosen_nt_per_m": best, "systematic_rms_on_left_out_deg": on_left, "with_default_deg": default}));
    }
    let _ = writeln!(md);
    (json!({"rows": rows, "summary": summary, "floor_targets": floor_targets, "leave_one_site_out": loo}), md)
}

/// The `results.md` section "The five effects on varied sites".
pub fn markdown(varied_md: &str) -> String {
    format!("\n## The five effects on varied sites\n\nThe five effects at four sites unlike paper 000's — high latitude (Trondheimsfjord, inclination 75°), low latitude (off Goa, 19.5°), southern (off Fiji, −40°, declination 13°), and high latitude again with an AHRS of 0.05° roll/pitch noise instead of 0.15° — with every effect's magnitudes drawn by seed from the ranges of `magcal_sim::varied::MagnitudeRanges` (thruster places and moments, thermocline, sensor lag and gains, the crustal bodies' strength, depth and place, magnetised by the site's field, the AHRS misalignment, the current's speed and direction). Our chain with the local field's gradient along the track in the joint back-stepping (the chain with every model, the default), and without it (the chain before). The floor is what the true calibration scores on each validation run, from the simulator's truth alone (`magcal_sim::scenario::heading_floor`): its white heading noise in quadrature with the crustal anomaly's declination along the validation track beyond its mean along the calibration run, which no magnetometer sees. `cargo test --release -p xtask bench::tests::varied_sites_section -- --ignored --nocapture`.\n\n{varied_md}\n")
}

/// The section's targets: per site, the worst validation heading RMS of
/// the chain with the gradient ≤ 0.25°; high latitude is held at what was
/// measured (the AHRS's 0.15° roll/pitch noise × tan 75° alone is 0.55°:
/// no calibration meets it there). Then per site, the same ≤ 0.25° on the
/// seeds whose true-heading floor allows it ([`super::effects::floor_target`]).
/// `v` is [`varied_sites_section`]'s JSON.
pub fn targets(v: &serde_json::Value) -> Vec<super::targets::Target> {
    use super::targets::{Bound, Target};
    let sites = varied_sites();
    let floors = sites.iter().filter_map(|site| match v["floor_targets"].as_array().into_iter().flatten().find(|f| f["site"] == site.name) {
        Some(f) => floor_target("varied", f),
        None => Some(floor_target_missing(site.name)),
    });
    sites
        .iter()
        .map(|site| {
            let s = v["summary"].as_array().into_iter().flatten().find(|s| s["site"] == site.name);
            let seeds = s.and_then(|s| s["seeds"].as_u64()).unwrap_or(0);
            let worst = s.and_then(|s| s["worst_heading_rms_deg"].as_f64()).filter(|_| seeds > 0);
            let t = Target::new("varied", format!("{}: validation heading RMS with the gradient, worst of {seeds} seeds, °", site.name), worst, Bound::AtMost(TARGET_HEADING_RMS_DEG));
            match site.name {
                "high-latitude" => t.held(Bound::AtMost(HELD_HIGH_LATITUDE_DEG), "the AHRS's roll/pitch noise × tan I alone is above it"),
                "high-latitude-quiet-ahrs" => t.held(Bound::AtMost(HELD_HIGH_LATITUDE_QUIET_AHRS_DEG), "the per-ampere vector is corrupted by the crustal anomaly (seed 1: 42 %)"),
                _ => t,
            }
        })
        .collect::<Vec<_>>()
        .into_iter()
        .chain(floors)
        .collect()
}

/// A site's floor target that the section did not produce (fails as not measured).
fn floor_target_missing(site: &str) -> super::targets::Target {
    super::targets::Target::new("varied", format!("{site}: validation heading RMS of the chain with every model where the floor allows it, °"), None, super::targets::Bound::AtMost(TARGET_HEADING_RMS_DEG))
}

/// The worst high-latitude heading RMS over [`VARIED_SEEDS`], °: measured
/// 0.643 (`cargo xtask bench --ci`, 2026-11-27), rounded up by about 3 %.
const HELD_HIGH_LATITUDE_DEG: f64 = 0.66;

/// The worst heading RMS at the high-latitude site with the 0.05° AHRS
/// over [`VARIED_SEEDS`], °: measured 0.378 (seed 1; the example
/// `varied_sites`, release, 2026-11-27), rounded up by about 3 %.
const HELD_HIGH_LATITUDE_QUIET_AHRS_DEG: f64 = 0.39;
