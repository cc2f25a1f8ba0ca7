//! The comparison on the effects scenarios: each chain variant
//! ([`magcal_sim::scenario::Variant`]) on the given scenario (`all`,
//! `none` or one effect's name) and seeds; heading RMS, |F| error against
//! the true local field, current-vector and gain errors, predicted heading
//! RMS and the observed/predicted ratio.
//!
//! `cargo run --release -p magcal-sim --example effects_variants [scenario|effect+effect…] [seeds…]`
//! (`VARIANTS=full`: the full chain only; `VARIANTS=cmp`: beside it the
//! current term off). The "local decl." column is the validation RMS with
//! the crustal anomaly's declination taken out (the calibration's own
//! error, [`magcal_sim::scenario::heading_rms_local_declination_deg`]).
//! The "floor" column is what the true calibration scores there, with
//! its declination part ([`magcal_sim::scenario::heading_floor`]).

use magcal_sim::scenario::{effects_data, effects_scenarios, evaluate_variant, Variant};
use magcal_sim::SensorModel;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let scenario = args.next().unwrap_or_else(|| "all".into());
    let seeds: Vec<u64> = args.map(|a| a.parse()).collect::<Result<_, _>>()?;
    let seeds = if seeds.is_empty() { vec![1, 2, 3, 4, 5] } else { seeds };
    let variants: Vec<Variant> = match std::env::var("VARIANTS").ok().as_deref() {
        Some("full") => vec![Variant::Full],
        Some("cmp") => vec![Variant::Full, Variant::NoCurrentTerm],
        _ => Variant::ALL.to_vec(),
    };
    // A scenario's name, or effects joined by `+` (`thrusters+temperature`).
    let effects = match effects_scenarios().into_iter().find(|(n, _)| *n == scenario) {
        Some((_, e)) => e,
        None => magcal_sim::Effects::parse(&scenario.replace('+', ","))?,
    };
    println!("| scenario | variant | seed | heading RMS ° | local decl. ° | noise ° | floor ° (decl.) | systematic ° | |F| err true nT | |F| err IGRF nT | current vec err % | gain err %/°C | predicted ° (cal, run noise) | obs/pred | delay s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let f = |v: Option<f64>, p: usize| v.map_or("–".to_string(), |x| format!("{x:.p$}"));
    for &seed in &seeds {
        let data = effects_data(&SensorModel::paper_like(), seed, &effects)?;
        let floor = data.floor();
        for &v in &variants {
            match evaluate_variant(&data, v) {
                Ok(o) => {
                    let predicted = format!("{} ({}, {})", f(o.predicted_heading_rms_deg, 3), f(o.predicted_calibration_deg, 3), f(o.run_heading_noise_deg, 3));
                    println!(
                    "| {scenario} | {} | {seed} | {:.3} | {} | {:.3} | {:.3} ({:.3}) | {:.3} | {} | {:.1} | {} | {} | {} | {} | {:.2} |",
                    v.label(),
                    o.heading_rms_deg,
                    f(o.heading_rms_local_declination_deg, 3),
                    o.heading_noise_deg,
                    floor.floor_deg,
                    floor.declination_deg,
                    o.heading_systematic_deg,
                    f(o.field_error_true_nt, 1),
                    o.field_error_igrf_nt,
                    f(o.current_vector_error_pct, 1),
                    f(o.gain_error_pct_per_c, 4),
                    predicted,
                    f(o.observed_over_predicted, 2),
                    o.gps_delay_s
                    )
                }
                Err(e) => println!("| {scenario} | {} | {seed} | refused: {e} |", v.label()),
            }
        }
    }
    Ok(())
}
