//! `magcal session`: a field calibration session over the serial link, with
//! the simulated vehicle (QEMU board) or a real one (navigation streams).

use std::io::BufReader;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::ValueEnum;
use host_tools::board::{BoardClient, FeedWriter};
use host_tools::session::{self, NavVehicle, SessionConfig, Vehicle};
use magcal_sim::{Effects, SimPlan, SimVehicle};

use super::Place;

/// Length of the simulated field tests.
#[derive(Clone, Copy, ValueEnum)]
pub enum Plan {
    /// The demo's field tests (3 km legs).
    Demo,
    /// Shortened (the test suite's).
    Short,
}

/// Arguments of `magcal session`.
#[derive(clap::Args)]
pub struct Args {
    /// The board's link (USART1), e.g. /dev/ttyUSB0 or QEMU's first pty.
    #[arg(long)]
    port: String,
    /// The QEMU board's sensor feed (USART2): the simulator plays the vehicle.
    #[arg(long, conflicts_with_all = ["nav_swing", "nav_run", "nav_validation"])]
    sim_feed: Option<String>,
    /// Real vehicle: navigation CSV (t, roll_deg, pitch_deg, ...) during the swing test.
    #[arg(long, requires = "nav_run")]
    nav_swing: Option<PathBuf>,
    /// Real vehicle: navigation CSV (t, roll_deg, pitch_deg, ref_heading_deg, lat_deg, lon_deg; optional gx, gy, gz, motor_current_a — sent to the board with the attitude) during the run.
    #[arg(long, requires = "nav_swing")]
    nav_run: Option<PathBuf>,
    /// Real vehicle, optional: navigation CSV of a validation run with a reference heading (`true_heading_deg`).
    #[arg(long, requires = "nav_swing")]
    nav_validation: Option<PathBuf>,
    #[command(flatten)]
    place: Place,
    /// Session directory (recordings, calibrations, report).
    #[arg(long)]
    out: PathBuf,
    /// Length of the simulated field tests.
    #[arg(long, value_enum, default_value = "demo")]
    plan: Plan,
    /// Random seed of the simulated vehicle.
    #[arg(long)]
    seed: Option<u64>,
    /// Real-vehicle effects of the simulated vehicle: `all`, `none`, or a
    /// comma-separated list of thrusters, temperature, anomaly, ahrs,
    /// current (only with --sim-feed).
    #[arg(long, default_value = "none", value_parser = parse_effects)]
    effects: Effects,
    /// Print the summary as JSON on stdout.
    #[arg(long)]
    json: bool,
}

fn parse_effects(text: &str) -> Result<Effects, String> {
    Effects::parse(text).map_err(|e| e.to_string())
}

/// Runs `magcal session`.
pub fn run(a: Args) -> Result<()> {
    use std::io::IsTerminal;
    let site = a.place.site()?;
    let cfg = SessionConfig { site, out_dir: a.out.clone(), interactive: std::io::stderr().is_terminal() };
    // The session's files against its navigation streams, before any work.
    let streams: Vec<&std::path::Path> = [&a.nav_swing, &a.nav_run, &a.nav_validation].into_iter().flatten().map(PathBuf::as_path).collect();
    session::check_outputs(&a.out, &streams).map_err(|e| anyhow::anyhow!("--out {e}"))?;
    let open = |p: &PathBuf| std::fs::File::open(p).map(BufReader::new).with_context(|| format!("navigation stream {}", p.display()));
    let mut vehicle: Box<dyn Vehicle> = match (&a.sim_feed, &a.nav_swing, &a.nav_run) {
        (Some(feed), None, None) => {
            let mut plan = match a.plan {
                Plan::Demo => SimPlan::demo(),
                Plan::Short => SimPlan::short(),
            };
            if let Some(s) = a.seed {
                plan.seed = s;
            }
            let plan = plan.with_effects(a.effects.clone());
            Box::new(SimVehicle::new(plan, &site, FeedWriter::open(feed)?)?)
        }
        (None, Some(_), Some(_)) if !a.effects.is_none() => bail!("--effects is for the simulated vehicle (--sim-feed): a real vehicle has its own"),
        (None, Some(swing), Some(run)) => Box::new(NavVehicle::new(open(swing)?, open(run)?, a.nav_validation.as_ref().map(open).transpose()?)),
        _ => bail!("give the vehicle: --sim-feed PORT (simulated, QEMU board) or --nav-swing FILE --nav-run FILE (real vehicle)"),
    };
    let port = a.port.clone();
    let summary = session::run(vehicle.as_mut(), &mut || BoardClient::open(&port), &cfg)?;
    if a.json {
        println!("{}", serde_json::to_string(&summary)?);
    } else {
        match &summary.validation {
            Some(v) => println!(
                "session done: true heading RMS {:.2}° → {:.2}° on the validation run (predicted {}), |F| − {} {:.1} nT; coefficients verified on the board",
                v.heading_rms_deg_before,
                v.heading_rms_deg_after,
                summary.predicted_heading_rms_deg.map_or("—".to_string(), |p| format!("{p:.2}°")),
                if v.field_against_truth { "true field" } else { "IGRF" },
                v.field_error_nt_after
            ),
            None => println!(
                "session done: coefficients #{} verified on the board; turnaround step {:.1} nT after back-stepping",
                summary.coefficient_seq, summary.backstep.after.step_nt
            ),
        }
    }
    Ok(())
}
