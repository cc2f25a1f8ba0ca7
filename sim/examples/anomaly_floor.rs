//! What the crustal anomaly alone costs a magnetometer heading, from the
//! simulator's truth only (no estimator): the local declination's departure
//! from IGRF's along the validation run (less its mean along the
//! calibration run, which the swing fit's constant A takes), and the
//! anomaly's intensity at the swing test (the intensity every calibration
//! scaled to IGRF there inherits).
//!
//! `cargo run --release -p magcal-sim --example anomaly_floor [seeds…]`

use host_tools::geomag;
use magcal_sim::scenario::{effects_data, effects_scenarios};
use magcal_sim::{paper_site, SensorModel, Simulation};

/// Local declination − IGRF declination (°) and |F| − IGRF |F| (nT) at
/// every tenth row.
fn departures(sim: &Simulation, year: f64) -> Option<Vec<(f64, f64)>> {
    let (n, e, d) = (sim.effect_column("true_field_n_nt")?, sim.effect_column("true_field_e_nt")?, sim.effect_column("true_field_d_nt")?);
    // True positions (logged with the current effect), else the logged ones.
    let lat = sim.effect_column("true_lat_deg").or(sim.recording.lat_deg.as_deref())?;
    let lon = sim.effect_column("true_lon_deg").or(sim.recording.lon_deg.as_deref())?;
    Some(
        (0..n.len())
            .step_by(10)
            .filter(|&i| lat[i].is_finite() && lon[i].is_finite())
            .filter_map(|i| {
                let igrf = geomag::igrf14(lat[i], lon[i], 0.0, year).ok()?;
                let decl = e[i].atan2(n[i]).to_degrees() - igrf.declination_deg();
                let f = (n[i] * n[i] + e[i] * e[i] + d[i] * d[i]).sqrt() - igrf.total_nt();
                Some((decl, f))
            })
            .collect(),
    )
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: Vec<u64> = std::env::args().skip(1).map(|a| a.parse()).collect::<Result<_, _>>()?;
    let seeds = if seeds.is_empty() { vec![1, 2, 3, 4, 5] } else { seeds };
    let year = paper_site().decimal_year;
    let anomaly = effects_scenarios().into_iter().find(|(n, _)| *n == "anomaly").ok_or("no anomaly scenario")?.1;
    println!("| seed | swing test |F| − IGRF (nT) | run: mean declination departure (°) | validation: declination departure RMS about the run's mean (°) | validation |F| − IGRF mean, RMS (nT) |");
    println!("|---|---|---|---|---|");
    for seed in seeds {
        let data = effects_data(&SensorModel::paper_like(), seed, &anomaly)?;
        let (Some(run), Some(val)) = (departures(&data.run, year), departures(&data.validation, year)) else {
            return Err("no true-field columns".into());
        };
        // The swing test is at the site (north = east = 0, the surface).
        let site = paper_site();
        let igrf = geomag::igrf14(site.lat_deg, site.lon_deg, 0.0, year)?;
        let a = anomaly.anomaly.as_ref().ok_or("no anomaly model")?.field_nt(0.0, 0.0, 0.0);
        let swing_df = (igrf.north_nt + a[0]).hypot(igrf.east_nt + a[1]).hypot(igrf.down_nt + a[2]) - igrf.total_nt();
        let mean = |v: &[(f64, f64)], k: usize| v.iter().map(|p| if k == 0 { p.0 } else { p.1 }).sum::<f64>() / v.len() as f64;
        let run_decl = mean(&run, 0);
        let val_rms = (val.iter().map(|p| (p.0 - run_decl).powi(2)).sum::<f64>() / val.len() as f64).sqrt();
        let f_rms = (val.iter().map(|p| p.1 * p.1).sum::<f64>() / val.len() as f64).sqrt();
        println!("| {seed} | {swing_df:.0} | {run_decl:.3} | {val_rms:.3} | {:.0}, {f_rms:.0} |", mean(&val, 1));
    }
    Ok(())
}
