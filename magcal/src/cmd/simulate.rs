//! `magcal simulate`: a simulated field test with its truth (`magcal-sim`).

use std::path::PathBuf;

use anyhow::{Context, Result};
use host_tools::files;
use clap::ValueEnum;
use magcal_sim::effects::Effects;
use magcal_sim::field_test::{self, paper_site, truth_path, GyroModel, RunKind, RunParams, SensorModel, Simulation};
use magcal_sim::scenario::effects_runs;
use serde_json::json;

/// Which field test.
#[derive(Clone, Copy, ValueEnum)]
pub enum Scenario {
    /// The swing test: a diver turns the vehicle (thrusters off).
    Swing,
    /// The out-and-back run (62° / −117°) with the dolphin profile.
    Run,
    /// A second out-and-back run (150° / 330°) for validation.
    Validation,
}

/// The simulated vehicle's error model (a hull, not a source of steps).
#[derive(Clone, Copy, ValueEnum)]
pub enum Hull {
    /// Thrusters add a mostly horizontal bias while running (paper-like).
    PaperLike,
    /// The hull couples the vertical channel to the horizontal ones.
    HullCoupled,
}

/// The runs' base parameters, before the flags that change them.
#[derive(Clone, Copy, ValueEnum)]
pub enum Runs {
    /// Paper 000's: 7 km (run) / 4 km (validation) legs at 2 m/s, a
    /// 0.1 m/s current.
    Paper,
    /// The bench's effects runs (`cargo xtask bench`, the README's
    /// five-effects table): run 5 km legs at 1.2 / 0.9 m/s, validation 4 km
    /// at 1.0 / 1.3 m/s, no current of their own (the `current` effect
    /// brings one).
    Effects,
}

/// Arguments of `magcal simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Which test.
    #[arg(value_enum)]
    scenario: Scenario,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output CSV.
    #[arg(long)]
    out: PathBuf,
    /// Sample rate, Hz (0.1 to 1000).
    #[arg(long, default_value_t = 5.0, value_parser = super::number_in(0.1..=1000.0, "Hz"))]
    rate_hz: f64,
    /// The vehicle's error model.
    #[arg(long, value_enum, default_value = "paper-like")]
    vehicle: Hull,
    /// Runs: speed of the current, m/s (0 to 10, slower than the vehicle).
    #[arg(long, value_parser = super::number_in(0.0..=10.0, "m/s"))]
    current_mps: Option<f64>,
    /// Runs: direction the current flows towards, degrees true (−360 to 360).
    #[arg(long, allow_hyphen_values = true, value_parser = super::number_in(-360.0..=360.0, "degrees"))]
    current_to_deg: Option<f64>,
    /// Runs: GPS course delay, seconds (0 to 60).
    #[arg(long, value_parser = super::number_in(0.0..=60.0, "s"))]
    gps_delay_s: Option<f64>,
    /// Runs: the base parameters (`paper`, or `effects`: the bench's effects
    /// runs); the flags below change them.
    #[arg(long, value_enum, default_value = "paper")]
    runs: Runs,
    /// Runs: length of each leg, metres (1 to 100 000).
    #[arg(long, value_parser = super::number_in(1.0..=100_000.0, "m"))]
    leg_m: Option<f64>,
    /// Runs: speed through water on the outbound leg, m/s (0.01 to 10).
    #[arg(long, value_parser = super::number_in(0.01..=10.0, "m/s"))]
    speed_mps: Option<f64>,
    /// Swing test: roll amplitude, degrees (0 to 90; paper: 55).
    #[arg(long, default_value_t = 55.0, value_parser = super::number_in(0.0..=90.0, "degrees"))]
    roll_amp_deg: f64,
    /// Swing test: pitch amplitude, degrees (0 to 90; paper: 10).
    #[arg(long, default_value_t = 10.0, value_parser = super::number_in(0.0..=90.0, "degrees"))]
    pitch_amp_deg: f64,
    /// Record a MEMS gyro too (`gx, gy, gz`: bias, noise, a small misalignment).
    #[arg(long)]
    gyro: bool,
    /// Real-vehicle effects: `all`, `none`, or a comma-separated list of
    /// `thrusters` (dipoles scaling with motor current), `temperature`
    /// (thermal lag, bridge gain −0.3 %/°C), `anomaly` (crustal field, IGRF
    /// wrong by 100–300 nT), `ahrs` (AHRS misaligned by tenths of a degree),
    /// `current` (water current, speed log, kinematically consistent GPS);
    /// `all` is these five. Two disturbances for integrity checks, not in
    /// `all`: `structure` (a steel pier passed at ~2.6 m on the validation
    /// run), `payload` (a motor switched on 1 800 s into the validation
    /// run). Their true values go into the truth JSON.
    #[arg(long, default_value = "none", value_parser = parse_effects)]
    effects: Box<Effects>,
    /// Swing test with the thrusters effect: hold the heading after the
    /// yaw segment and step the thrusters (0, 2, 5, 10, 5, 0 A).
    #[arg(long)]
    thrust_test: bool,
    /// Runs: speed through water on the return leg, m/s (0.01 to 10;
    /// default: the outbound speed).
    #[arg(long, value_parser = super::number_in(0.01..=10.0, "m/s"))]
    speed_back_mps: Option<f64>,
    /// Print a JSON summary on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal simulate`.
pub fn run(a: Args) -> Result<()> {
    // Both targets checked before the work; both written, then both
    // renamed: a truth that cannot be written leaves the old recording (it
    // was replaced, then the truth failed).
    let truth = truth_path(&a.out);
    super::check_out("--out", &a.out, &[])?;
    super::check_out("--out's truth", &truth, &[&a.out])?;
    let simulation = simulate(&a)?;
    files::write_together(&[&a.out, &truth], |temps: &[PathBuf]| -> Result<()> {
        // The simulation names its truth after its CSV, as the temporaries are named.
        simulation.write(&temps[0])?;
        let written = truth_path(&temps[0]);
        if !files::same_file(&written, &temps[1]) {
            // (The CSV is a link into another folder.)
            let moved = std::fs::rename(&written, &temps[1]);
            let _ = std::fs::remove_file(&written);
            moved.with_context(|| format!("{}: writing the truth", truth.display()))?;
        }
        Ok(())
    })?;
    eprintln!("wrote {} ({} rows) and {}", a.out.display(), simulation.recording.len(), truth.display());
    if a.json {
        println!("{}", json!({"csv": a.out, "truth": truth, "rows": simulation.recording.len(), "site": simulation.truth.site, "effects": a.effects.list()}));
    }
    Ok(())
}

/// The simulation the arguments ask for.
fn simulate(a: &Args) -> Result<Simulation> {
    let sensor = match a.vehicle {
        Hull::PaperLike => SensorModel::paper_like(),
        Hull::HullCoupled => SensorModel::hull_coupled(),
    };
    let site = paper_site();
    let effects = effects(a)?;
    let (run, validation) = match a.runs {
        Runs::Paper => (RunParams::paper_like(), RunParams::validation()),
        Runs::Effects => effects_runs(),
    };
    let simulation = match a.scenario {
        Scenario::Swing => field_test::swing_with(&sensor, &site, a.seed, a.rate_hz, a.roll_amp_deg, a.pitch_amp_deg, &effects)?,
        Scenario::Run => field_test::run_with(&sensor, &site, &tune(a, run), a.seed, a.rate_hz, RunKind::Run, &effects)?,
        Scenario::Validation => field_test::run_with(&sensor, &site, &tune(a, validation), a.seed, a.rate_hz, RunKind::Validation, &effects)?,
    };
    Ok(if a.gyro { simulation.with_gyro(&GyroModel::mems(), a.seed) } else { simulation })
}

/// The run's parameters with the flags applied.
fn tune(a: &Args, mut p: RunParams) -> RunParams {
    p.current_mps = a.current_mps.unwrap_or(p.current_mps);
    p.current_to_deg = a.current_to_deg.unwrap_or(p.current_to_deg);
    p.gps_delay_s = a.gps_delay_s.unwrap_or(p.gps_delay_s);
    p.leg_m = a.leg_m.unwrap_or(p.leg_m);
    p.speed_mps = a.speed_mps.unwrap_or(p.speed_mps);
    p.speed_back_mps = a.speed_back_mps.or(p.speed_back_mps);
    p
}

/// The effects with the flags applied.
fn effects(a: &Args) -> Result<Effects> {
    let mut effects = *a.effects.clone();
    // With the current effect, --current-mps/--current-to-deg set its current.
    if let Some(water) = effects.water_current.as_mut() {
        water.current_mps = a.current_mps.unwrap_or(water.current_mps);
        water.current_to_deg = a.current_to_deg.unwrap_or(water.current_to_deg);
    }
    if a.thrust_test {
        let thrusters = effects.thrusters.take().ok_or_else(|| anyhow::anyhow!("--thrust-test needs the thrusters effect (--effects thrusters,…)"))?;
        effects.thrusters = Some(thrusters.with_thrust_test());
    }
    Ok(effects)
}

fn parse_effects(text: &str) -> Result<Box<Effects>, String> {
    Effects::parse(text).map(Box::new).map_err(|e| e.to_string())
}
