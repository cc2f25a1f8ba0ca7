//! The five effects at other sites and with drawn magnitudes: the chain's validation heading RMS per site and seed, with the
//! white-noise part, the true-heading floor ([`magcal_sim::scenario::heading_floor`]), the prediction and |F| against the
//! true local field.
//!
//! `cargo run --release -p magcal-sim --example varied_sites [site|all] [seeds…]`
//! (`VARIANTS=all`: every chain variant of [`Variant::ALL`]; `EFFECTS=`
//! a list of effects to keep from the draw, e.g. `thrusters,temperature`)

use magcal_sim::scenario::{effects_data_at, evaluate_variant, Variant};
use magcal_sim::varied::{varied_effects, varied_sites};
use magcal_sim::Effect;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let which = args.next().unwrap_or_else(|| "all".into());
    let seeds: Vec<u64> = args.map(|a| a.parse()).collect::<Result<_, _>>()?;
    let seeds = if seeds.is_empty() { vec![1, 2, 3] } else { seeds };
    let variants: Vec<Variant> = match std::env::var("VARIANTS").ok().as_deref() {
        Some("all") => Variant::ALL.to_vec(),
        Some("cmp") => vec![Variant::Full, Variant::NoFieldGradient],
        _ => vec![Variant::Full],
    };
    let keep: Option<Vec<Effect>> = std::env::var("EFFECTS").ok().map(|l| {
        let e = magcal_sim::Effects::parse(&l).unwrap_or_default();
        e.list()
    });
    let f = |v: Option<f64>, p: usize| v.map_or("–".to_string(), |x| format!("{x:.p$}"));
    println!("| site | variant | seed | heading RMS ° | local decl. ° | noise ° | floor ° (decl.) | predicted ° | obs/pred | |F| err true nT | current err % | gain err %/°C | delay s |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for named in varied_sites().iter().filter(|s| which == "all" || s.name == which) {
        for &seed in &seeds {
            let mut effects = varied_effects(&named.site, seed)?;
            if let Some(keep) = &keep {
                let on = effects.list();
                for e in on.into_iter().filter(|e| !keep.contains(e)) {
                    match e {
                        Effect::Thrusters => effects.thrusters = None,
                        Effect::Temperature => effects.temperature = None,
                        Effect::Anomaly => effects.anomaly = None,
                        Effect::Ahrs => effects.ahrs = None,
                        Effect::Current => effects.water_current = None,
                        _ => {}
                    }
                }
            }
            let data = effects_data_at(&named.sensor(), &named.site, seed, &effects)?;
            if std::env::var("DESCRIBE").is_ok() {
                if let Some(t) = data.run.truth.effects.as_ref() {
                    let th = t.thrusters.as_ref().map(|x| (x.field_nt_per_a.clone(), x.bus_current_a_range));
                    let te = t.temperature.as_ref().map(|x| (x.sensor_c_range, x.gain_per_c));
                    let an = t.anomaly.as_ref().map(|x| x.intensity_anomaly_nt_range);
                    let cu = t.current.as_ref().map(|x| (x.north_mps, x.east_mps, x.crab_deg_range));
                    eprintln!(
                        "{} {seed}: thrusters {th:?}\n  temp {te:?}\n  anomaly {an:?} validation {:?}\n  current {cu:?} ahrs {:?}",
                        named.name,
                        data.validation.truth.effects.as_ref().and_then(|v| v.anomaly.as_ref()).map(|x| x.intensity_anomaly_nt_range),
                        t.ahrs_misalignment_deg
                    );
                }
            }
            let floor = data.floor();
            for &v in &variants {
                match evaluate_variant(&data, v) {
                    Ok(o) => println!(
                        "| {} | {} | {seed} | {:.3} | {} | {:.3} | {:.3} ({:.3}) | {} | {} | {} | {} | {} | {:.2} |",
                        named.name,
                        v.label(),
                        o.heading_rms_deg,
                        f(o.heading_rms_local_declination_deg, 3),
                        o.heading_noise_deg,
                        floor.floor_deg,
                        floor.declination_deg,
                        f(o.predicted_heading_rms_deg, 3),
                        f(o.observed_over_predicted, 2),
                        f(o.field_error_true_nt, 1),
                        f(o.current_vector_error_pct, 1),
                        f(o.gain_error_pct_per_c, 4),
                        o.gps_delay_s
                    ),
                    Err(e) => println!("| {} | {} | {seed} | refused: {e} |", named.name, v.label()),
                }
            }
        }
    }
    Ok(())
}
