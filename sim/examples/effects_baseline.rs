//! Today's chain on the effects scenarios: the validation true-heading RMS
//! with no effect, each of the five alone and all together (the baseline
//! the estimators of the effects must beat).
//!
//! `cargo run --release -p magcal-sim --example effects_baseline [seeds…]`

use magcal_sim::scenario::{effects_runs, effects_scenarios, evaluate_effects};
use magcal_sim::field_test::RunKind;
use magcal_sim::{field_test, paper_site, SensorModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: Vec<u64> = std::env::args().skip(1).map(|a| a.parse()).collect::<Result<_, _>>()?;
    let seeds = if seeds.is_empty() { vec![1, 2, 3] } else { seeds };
    // What each effect does to the validation run, from its truth.
    let (_, validation) = effects_runs();
    let all = magcal_sim::Effects::all();
    let v = field_test::run_with(&SensorModel::paper_like(), &paper_site(), &validation, 201, 2.0, RunKind::Validation, &all)?;
    if let Some(e) = &v.truth.effects {
        if let Some(t) = &e.thrusters {
            println!("thrusters: bus current {:.1}…{:.1} A, raw per A {:?}", t.bus_current_a_range[0], t.bus_current_a_range[1], t.raw_per_a);
        }
        if let Some(t) = &e.temperature {
            println!("temperature: sensor {:.1}…{:.1} °C", t.sensor_c_range[0], t.sensor_c_range[1]);
        }
        if let Some(a) = &e.anomaly {
            println!("anomaly: |F| − IGRF {:.0}…{:.0} nT", a.intensity_anomaly_nt_range[0], a.intensity_anomaly_nt_range[1]);
        }
        if let Some([lo, hi]) = e.current.as_ref().and_then(|c| c.crab_deg_range) {
            println!("current: crab {lo:.1}…{hi:.1}°");
        }
    }
    println!("| effects | seed | heading RMS axis fit ° | paper ° | ours ° | field error ours nT |");
    println!("|---|---|---|---|---|---|");
    for (name, effects) in effects_scenarios() {
        for &seed in &seeds {
            match evaluate_effects(name, SensorModel::paper_like(), seed, &effects) {
                Ok(o) => println!("| {name} | {seed} | {:.2} | {:.2} | {:.2} | {:.1} |", o.heading_rms_axis_fit_deg, o.heading_rms_paper_deg, o.heading_rms_ours_deg, o.field_error_ours_nt),
                Err(e) => println!("| {name} | {seed} | refused: {e} | | | |"),
            }
        }
    }
    Ok(())
}
