//! What the integrity disturbances (pier, payload) do to a good calibration's heading: the
//! chain (ours, every model) calibrated on the bench's five-effects data,
//! then the validation run again with the pier and the payload added
//! (`all,structure,payload`, the same seed): true-heading error where the
//! disturbance is small and where it is not, and the share of rows off by
//! more than 5° — what a run-time integrity check has to catch.
//!
//! `cargo run --release -p magcal-sim --example disturbances [seeds…]`

use host_tools::compute::true_headings_rad;
use magcal_sim::effects::Effects;
use magcal_sim::field_test::{self, RunKind};
use magcal_sim::scenario::{effects_data, effects_runs, Variant};
use magcal_sim::{paper_site, SensorModel};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seeds: Vec<u64> = std::env::args().skip(1).map(|a| a.parse()).collect::<Result<_, _>>()?;
    let seeds = if seeds.is_empty() { vec![1, 2, 3] } else { seeds };
    let disturbed = Effects::parse("all,structure,payload")?;
    println!("| seed | rows | disturbance < 50 nT: rows, heading RMS ° | pier (> 50 nT, payload off): rows, RMS °, max ° | payload on: rows, RMS ° | rows off by > 5° |");
    println!("|---|---|---|---|---|---|");
    for seed in seeds {
        let data = effects_data(&SensorModel::paper_like(), seed, &Effects::all())?;
        let chain = host_tools::compute::calibrate(&data.swing.recording, &data.run.recording, &paper_site(), &Variant::Full.options())?;
        let (_, validation) = effects_runs();
        let sim = field_test::run_with(&SensorModel::paper_like(), &paper_site(), &validation, seed + 200, 2.0, RunKind::Validation, &disturbed)?;
        let headings = true_headings_rad(&chain.final_doc, &sim.recording);
        let errors: Vec<f64> = headings.iter().zip(&sim.true_heading_deg).map(|(h, t)| calib_core::heading::wrap_pi(h - t.to_radians()).to_degrees()).collect();
        let disturbance = sim.effect_column("truth_disturbance_nt").ok_or("no disturbance column")?;
        let on = sim.effect_column("payload_on").ok_or("no payload column")?;
        let stats = |keep: &dyn Fn(usize) -> bool| {
            let e: Vec<f64> = (0..errors.len()).filter(|&i| keep(i) && errors[i].is_finite()).map(|i| errors[i]).collect();
            let rms = (e.iter().map(|x| x * x).sum::<f64>() / e.len().max(1) as f64).sqrt();
            (e.len(), rms, e.iter().fold(0.0_f64, |m, x| m.max(x.abs())))
        };
        let quiet = stats(&|i| disturbance[i] < 50.0);
        let pier = stats(&|i| disturbance[i] >= 50.0 && on[i] == 0.0);
        let payload = stats(&|i| on[i] == 1.0);
        let off = errors.iter().filter(|e| e.abs() > 5.0).count();
        println!(
            "| {seed} | {} | {}, {:.2} | {}, {:.2}, {:.2} | {}, {:.2} | {off} ({:.1} %) |",
            errors.len(),
            quiet.0,
            quiet.1,
            pier.0,
            pier.1,
            pier.2,
            payload.0,
            payload.1,
            100.0 * off as f64 / errors.len() as f64
        );
    }
    Ok(())
}
