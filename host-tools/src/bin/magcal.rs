//! `magcal`: the command-line front end. See `docs/INTERFACES.md` for the
//! contract: every subcommand takes `--json` and then prints one JSON document
//! on stdout and nothing else there; progress and warnings go to stderr; on
//! failure the exit status is non-zero with a one-line reason on stderr.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use calib_core::cal::ModelKind;
use clap::{Parser, Subcommand, ValueEnum};
use host_tools::caldoc::CalDoc;
use host_tools::igrf;
use host_tools::link::Link;
use host_tools::pipeline::{self, Delay, FitOptions, OrthoSolver};
use host_tools::recording::Recording;
use magcal_protocol::Platform;
use serde_json::json;

#[derive(Parser)]
#[command(name = "magcal", version, about = "AUV magnetometer calibration tools")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Clone, Copy, ValueEnum)]
enum Model {
    /// Bias and one scale.
    Sphere,
    /// Bias and three axis scales (paper 000, eqs 12–17).
    Axis,
    /// Bias and a symmetric soft-iron matrix.
    Full,
    /// Bias and paper 001's upper-triangular non-orthogonality and gains.
    Triangular,
}

impl From<Model> for ModelKind {
    fn from(m: Model) -> Self {
        match m {
            Model::Sphere => ModelKind::Sphere,
            Model::Axis => ModelKind::Axis,
            Model::Full => ModelKind::Full,
            Model::Triangular => ModelKind::Triangular,
        }
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum Solver {
    /// The paper's pairwise-norm solver (Levenberg–Marquardt on q1…q5).
    Pairwise,
    /// Linear fit of Γ⁻ᵀΓ⁻¹, then upper-triangular factorisation.
    Linear,
}

/// Where and when, for the IGRF reference (all three or none).
#[derive(clap::Args, Clone)]
struct SiteArgs {
    /// Latitude, degrees (IGRF reference; with --lon and --date).
    #[arg(long, allow_hyphen_values = true)]
    lat: Option<f64>,
    /// Longitude, degrees.
    #[arg(long, allow_hyphen_values = true)]
    lon: Option<f64>,
    /// Date, YYYY-MM-DD or decimal year.
    #[arg(long)]
    date: Option<String>,
}

/// Where and when, required.
#[derive(clap::Args, Clone)]
struct Place {
    /// Geodetic latitude, degrees.
    #[arg(long, allow_hyphen_values = true)]
    lat: f64,
    /// Longitude, degrees.
    #[arg(long, allow_hyphen_values = true)]
    lon: f64,
    /// Date: YYYY-MM-DD or decimal year.
    #[arg(long)]
    date: String,
}

#[derive(Clone, Copy, ValueEnum)]
enum FieldModel {
    /// IGRF-14 from the official coefficients.
    Igrf14,
    /// WMM2025 (world_magnetic_model crate).
    Wmm2025,
}

#[derive(Clone, Copy, ValueEnum)]
enum Scenario {
    /// The swing test: a diver turns the vehicle (thrusters off).
    Swing,
    /// The out-and-back run (62° / −117°) with the dolphin profile.
    Run,
    /// A second out-and-back run (150° / 330°) for validation.
    Validation,
}

#[derive(Clone, Copy, ValueEnum)]
enum Vehicle {
    /// Thrusters add a mostly horizontal bias while running (paper-like).
    PaperLike,
    /// The hull couples the vertical channel to the horizontal ones.
    HullCoupled,
}

#[derive(Clone, Copy, ValueEnum)]
enum Plan {
    /// The demo's field tests (3 km legs).
    Demo,
    /// Shortened (the test suite's).
    Short,
}

#[derive(Clone, Copy, ValueEnum)]
enum Method {
    /// Our joint least-squares refinement.
    Joint,
    /// Paper 000's corrections (axis model).
    Paper,
}

#[derive(Subcommand)]
enum Cmd {
    /// Simulate a field test (writes FILE.csv and FILE.truth.json).
    Simulate {
        /// Which test.
        #[arg(value_enum)]
        scenario: Scenario,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output CSV.
        #[arg(long)]
        out: PathBuf,
        /// Sample rate, Hz.
        #[arg(long, default_value_t = 5.0)]
        rate_hz: f64,
        /// The vehicle's error model.
        #[arg(long, value_enum, default_value = "paper-like")]
        vehicle: Vehicle,
        /// Runs: speed of the current, m/s.
        #[arg(long)]
        current_mps: Option<f64>,
        /// Runs: direction the current flows towards, degrees true.
        #[arg(long, allow_hyphen_values = true)]
        current_to_deg: Option<f64>,
        /// Runs: GPS course delay, seconds.
        #[arg(long)]
        gps_delay_s: Option<f64>,
        /// Runs: length of each leg, metres.
        #[arg(long)]
        leg_m: Option<f64>,
        /// Print a JSON summary on stdout.
        #[arg(long)]
        json: bool,
    },
    /// A field calibration session over the serial link: swing test,
    /// out-and-back run, back-stepping and swing fits, verified upload.
    /// The vehicle is either the simulator, played into the QEMU board's
    /// sensor feed (`--sim-feed`), or a real one whose navigation arrives as
    /// CSV streams (`--nav-swing`, `--nav-run`: files or FIFOs).
    Session {
        /// The board's link (USART1), e.g. /dev/ttyUSB0 or QEMU's first pty.
        #[arg(long)]
        port: String,
        /// The QEMU board's sensor feed (USART2): the simulator plays the vehicle.
        #[arg(long, conflicts_with_all = ["nav_swing", "nav_run"])]
        sim_feed: Option<String>,
        /// Real vehicle: navigation CSV (t, roll_deg, pitch_deg, ...) during the swing test.
        #[arg(long, requires = "nav_run")]
        nav_swing: Option<PathBuf>,
        /// Real vehicle: navigation CSV (t, roll_deg, pitch_deg, ref_heading_deg, lat_deg, lon_deg) during the run.
        #[arg(long, requires = "nav_swing")]
        nav_run: Option<PathBuf>,
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
        /// Print the summary as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Figures (SVG) and an HTML page comparing calibrations on recordings.
    Report {
        /// The out-and-back run.
        #[arg(long)]
        run: Option<PathBuf>,
        /// The swing test.
        #[arg(long)]
        swing_input: Option<PathBuf>,
        /// Calibration documents to compare (repeat the flag); labelled by file name.
        #[arg(long)]
        cal: Vec<PathBuf>,
        /// Reference intensity to draw, nT.
        #[arg(long)]
        field_nt: Option<f64>,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Print a JSON list of the files written.
        #[arg(long)]
        json: bool,
    },
    /// Back-stepping refinement on an out-and-back run.
    Backstep {
        /// The run (t, mx, my, mz, roll_deg, pitch_deg; lat_deg/lon_deg used when present).
        #[arg(long)]
        input: PathBuf,
        /// The calibration to refine (step 1).
        #[arg(long)]
        cal: PathBuf,
        #[command(flatten)]
        site: SiteArgs,
        /// Reference horizontal intensity, nT (instead of IGRF).
        #[arg(long)]
        field_h_nt: Option<f64>,
        /// Reference down component, nT (instead of IGRF).
        #[arg(long, allow_hyphen_values = true)]
        field_z_nt: Option<f64>,
        /// Solver: ours (joint) or the paper's.
        #[arg(long, value_enum, default_value = "joint")]
        method: Method,
        /// Time of the turnaround, seconds (default: found from the headings).
        #[arg(long)]
        turnaround_s: Option<f64>,
        /// The swing-test recording (thrusters off), to let the joint solver separate the running-only bias.
        #[arg(long)]
        swing_input: Option<PathBuf>,
        /// Write the calibration document here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print the calibration document (with its trace) on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Reference field (IGRF-14 or WMM2025) at a place and date.
    Igrf {
        #[command(flatten)]
        place: Place,
        /// Height above the WGS-84 ellipsoid, metres (negative below).
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        height_m: f64,
        /// Model.
        #[arg(long, value_enum, default_value = "igrf14")]
        model: FieldModel,
        /// Print one JSON document on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Ask the board (or the QEMU board) who it is.
    Identify {
        /// Serial port of the board, e.g. /dev/ttyUSB0 or QEMU's /dev/pts/N.
        #[arg(long)]
        port: String,
        /// Print one JSON document on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Field (ellipsoid) calibration from a recording.
    Fit {
        /// Recording (CSV with mx, my, mz).
        #[arg(long)]
        input: PathBuf,
        /// Calibration model.
        #[arg(long, value_enum)]
        model: Model,
        /// Reference field intensity, nT.
        #[arg(long)]
        field_nt: Option<f64>,
        #[command(flatten)]
        site: SiteArgs,
        /// Raw magnitude at which the sensor saturates (per axis).
        #[arg(long)]
        saturation: Option<f64>,
        /// Return coefficients even when the quality gates fail.
        #[arg(long)]
        allow_weak: bool,
        /// Write the calibration document here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print the calibration document on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Fourier (swinging) heading calibration against a reference heading.
    Swing {
        /// Recording with t, mx, my, mz, roll_deg, pitch_deg, ref_heading_deg.
        #[arg(long)]
        input: PathBuf,
        /// The field calibration to start from.
        #[arg(long)]
        cal: PathBuf,
        /// Known delay of the reference behind the magnetometer, seconds.
        #[arg(long, conflicts_with = "estimate_delay")]
        delay_s: Option<f64>,
        /// Estimate the delay from the data.
        #[arg(long)]
        estimate_delay: bool,
        /// Upper bound of the delay search, seconds.
        #[arg(long, default_value_t = 5.0)]
        max_delay_s: f64,
        /// Write the calibration document here.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Print the calibration document on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Non-orthogonality and gain identification (paper 001).
    Ortho {
        /// Recording (CSV with mx, my, mz), the sensor turned in a constant field.
        #[arg(long)]
        input: PathBuf,
        /// Solver.
        #[arg(long, value_enum, default_value = "pairwise")]
        solver: Solver,
        /// Take the hard-iron bias from this calibration document.
        #[arg(long, conflicts_with = "zero_bias")]
        cal: Option<PathBuf>,
        /// The data have no bias (e.g. paper 001's simulation).
        #[arg(long)]
        zero_bias: bool,
        /// Print one JSON document on stdout.
        #[arg(long)]
        json: bool,
    },
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        // One line: the chain of causes, each said once.
        let mut msg = String::new();
        for cause in e.chain() {
            let text = cause.to_string();
            if !msg.contains(&text) {
                if !msg.is_empty() {
                    msg.push_str(": ");
                }
                msg.push_str(&text);
            }
        }
        eprintln!("magcal: {}", msg.replace('\n', " "));
        std::process::exit(1);
    }
}

fn emit(doc: &CalDoc, out: Option<&PathBuf>, json: bool, summary: &str) -> Result<()> {
    if let Some(path) = out {
        doc.save(path)?;
        eprintln!("wrote {}", path.display());
    }
    if json {
        println!("{}", serde_json::to_string_pretty(doc)?);
    } else {
        println!("{summary}");
    }
    Ok(())
}

fn warn_all(doc_quality: &serde_json::Value) {
    let mut stack = vec![doc_quality];
    while let Some(v) = stack.pop() {
        if let Some(ws) = v.get("warnings").and_then(|w| w.as_array()) {
            for w in ws {
                if let Some(s) = w.as_str() {
                    eprintln!("warning: {s}");
                }
            }
        }
        if let Some(obj) = v.as_object() {
            stack.extend(obj.values().filter(|x| x.is_object()));
        }
    }
}

/// The reference intensity from --field-nt or --lat/--lon/--date (IGRF-14).
fn reference_field(field_nt: Option<f64>, lat: Option<f64>, lon: Option<f64>, date: Option<&str>) -> Result<igrf::Field> {
    match (field_nt, lat, lon, date) {
        (Some(f), None, None, None) => {
            if !(f > 0.0 && f.is_finite()) {
                bail!("--field-nt must be a positive number of nT, not {f}");
            }
            // Only the intensity is known: put it all on one axis.
            Ok(igrf::Field { north_nt: f, east_nt: 0.0, down_nt: 0.0 })
        }
        (Some(_), ..) => bail!("give either --field-nt or --lat/--lon/--date, not both"),
        (None, Some(lat), Some(lon), Some(date)) => {
            let year = igrf::parse_date(date)?;
            Ok(igrf::igrf14(lat, lon, 0.0, year)?)
        }
        (None, ..) => bail!("give the reference field intensity with --field-nt (nT) or all of --lat/--lon/--date"),
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Simulate { scenario, seed, out, rate_hz, vehicle, current_mps, current_to_deg, gps_delay_s, leg_m, json } => {
            use host_tools::sim::{self, RunParams, SensorModel, Site};
            let sensor = match vehicle {
                Vehicle::PaperLike => SensorModel::paper_like(),
                Vehicle::HullCoupled => SensorModel::hull_coupled(),
            };
            let site = Site::paper_like();
            let tune = |mut p: RunParams| {
                p.current_mps = current_mps.unwrap_or(p.current_mps);
                p.current_to_deg = current_to_deg.unwrap_or(p.current_to_deg);
                p.gps_delay_s = gps_delay_s.unwrap_or(p.gps_delay_s);
                p.leg_m = leg_m.unwrap_or(p.leg_m);
                p
            };
            let simulation = match scenario {
                Scenario::Swing => sim::swing(&sensor, &site, seed, rate_hz)?,
                Scenario::Run => sim::run(&sensor, &site, &tune(RunParams::paper_like()), seed, rate_hz, "run")?,
                Scenario::Validation => sim::run(&sensor, &site, &tune(RunParams::validation()), seed, rate_hz, "validation")?,
            };
            simulation.write(&out)?;
            let truth = sim::truth_path(&out);
            eprintln!("wrote {} ({} rows) and {}", out.display(), simulation.recording.len(), truth.display());
            if json {
                println!("{}", json!({"csv": out, "truth": truth, "rows": simulation.recording.len(), "site": simulation.truth.site}));
            }
            Ok(())
        }
        Cmd::Session { port, sim_feed, nav_swing, nav_run, place: Place { lat, lon, date }, out, plan, seed, json } => {
            use host_tools::session::{run_nav_session, run_simulated_session, SessionConfig, SimPlan};
            use std::io::IsTerminal;
            let year = igrf::parse_date(&date)?;
            let mut plan = match plan {
                Plan::Demo => SimPlan::demo(),
                Plan::Short => SimPlan::short(),
            };
            if let Some(s) = seed {
                plan.seed = s;
            }
            let cfg = SessionConfig { lat_deg: lat, lon_deg: lon, year, out_dir: out, interactive: std::io::stderr().is_terminal() };
            let summary = match (sim_feed, nav_swing, nav_run) {
                (Some(feed), None, None) => run_simulated_session(&port, &feed, &cfg, &plan)?,
                (None, Some(swing), Some(run)) => {
                    let open = |p: &PathBuf| std::fs::File::open(p).map(std::io::BufReader::new).with_context(|| format!("navigation stream {}", p.display()));
                    run_nav_session(&port, open(&swing)?, open(&run)?, &cfg)?
                }
                _ => bail!("give the vehicle: --sim-feed PORT (simulated, QEMU board) or --nav-swing FILE --nav-run FILE (real vehicle)"),
            };
            if json {
                println!("{summary}");
            } else if summary.get("heading_rms_deg_after").is_none() {
                println!("session done: coefficients #{} verified on the board; turnaround step {} nT after back-stepping", summary["coefficient_seq"], summary["backstep"]["after"]["step_nt"]);
            } else {
                println!(
                    "session done: true heading RMS {:.2}° → {:.2}° on the validation run, |F| − IGRF {:.1} nT; coefficients verified on the board",
                    summary["heading_rms_deg_before"].as_f64().unwrap_or(f64::NAN),
                    summary["heading_rms_deg_after"].as_f64().unwrap_or(f64::NAN),
                    summary["field_error_nt_after"].as_f64().unwrap_or(f64::NAN)
                );
            }
            Ok(())
        }
        Cmd::Report { run, swing_input, cal, field_nt, out, json } => {
            let run = run.map(|p| Recording::read(&p)).transpose()?;
            let swing = swing_input.map(|p| Recording::read(&p)).transpose()?;
            let docs = cal.iter().map(|p| CalDoc::load(p)).collect::<Result<Vec<_>, _>>()?;
            let labels = cal.iter().map(|p| p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default());
            let inputs = host_tools::report::ReportInputs {
                run: run.as_ref(),
                swing: swing.as_ref(),
                cals: labels.zip(docs.iter()).collect(),
                field_nt: field_nt.or_else(|| docs.first().map(|d| d.field_nt)),
            };
            let files = host_tools::report::write_report(&out, &inputs)?;
            eprintln!("wrote {} with {} figures", out.join("index.html").display(), files.len());
            if json {
                println!("{}", json!({"index": out.join("index.html"), "figures": files}));
            }
            Ok(())
        }
        Cmd::Backstep { input, cal, site, field_h_nt, field_z_nt, method, turnaround_s, swing_input, out, json } => {
            let SiteArgs { lat, lon, date } = site;
            let reference = match (lat, lon, date, field_h_nt, field_z_nt) {
                (Some(lat_deg), Some(lon_deg), Some(d), None, None) => pipeline::RunReference::Igrf { lat_deg, lon_deg, year: igrf::parse_date(&d)? },
                (None, None, None, Some(h_nt), Some(z_nt)) => pipeline::RunReference::Given { h_nt, z_nt },
                _ => bail!("give the reference as --lat/--lon/--date or as --field-h-nt/--field-z-nt"),
            };
            let doc = CalDoc::load(&cal)?;
            let rec = Recording::read(&input)?;
            let mut opts = pipeline::BackstepOptions::new(reference);
            opts.method = match method {
                Method::Joint => pipeline::BackstepMethod::Joint,
                Method::Paper => pipeline::BackstepMethod::Paper,
            };
            opts.turnaround_s = turnaround_s;
            if let Some(p) = swing_input {
                let swing = Recording::read(&p)?;
                opts.swing = Some((swing.complete_mag().1, doc.field_nt));
            }
            let (out_doc, report) = pipeline::backstep_recording(&rec, &doc, &opts).with_context(|| format!("{}: back-stepping", input.display()))?;
            if !json {
                if let Some(trace) = out_doc.trace.as_ref().and_then(|t| t.as_array()) {
                    for e in trace {
                        eprintln!(
                            "  iter {} {:<28} step {:>8.1} nT  Hh {:>8.1}  Hz {:>8.1}  F {:>8.1}",
                            e["iteration"], e["correction"].as_str().unwrap_or(""), e["step_nt"].as_f64().unwrap_or(f64::NAN),
                            e["hh_nt"].as_f64().unwrap_or(f64::NAN), e["hz_nt"].as_f64().unwrap_or(f64::NAN), e["f_nt"].as_f64().unwrap_or(f64::NAN)
                        );
                    }
                }
            }
            let summary = format!(
                "back-stepping ({}) around the turnaround at {:.0} s: step {:.1} → {:.1} nT, |F − IGRF| RMS {:.1} → {:.1} nT",
                match method { Method::Joint => "joint", Method::Paper => "paper" },
                report.turnaround_s, report.before.step_nt, report.after.step_nt, report.before.f_error_rms_nt, report.after.f_error_rms_nt
            );
            emit(&out_doc, out.as_ref(), json, &summary)
        }
        Cmd::Igrf { place: Place { lat, lon, date }, height_m, model, json } => {
            let year = igrf::parse_date(&date)?;
            let model = match model {
                FieldModel::Igrf14 => igrf::Model::Igrf14,
                FieldModel::Wmm2025 => igrf::Model::Wmm2025,
            };
            let f = igrf::field(model, lat, lon, height_m, year)?;
            if json {
                println!(
                    "{}",
                    json!({
                        "model": model.name(), "north_nt": f.north_nt, "east_nt": f.east_nt, "down_nt": f.down_nt,
                        "horizontal_nt": f.horizontal_nt(), "total_nt": f.total_nt(),
                        "inclination_deg": f.inclination_deg(), "declination_deg": f.declination_deg(),
                        "lat_deg": lat, "lon_deg": lon, "height_m": height_m, "decimal_year": year,
                    })
                );
            } else {
                println!(
                    "{} at {lat}°, {lon}°, {height_m} m, {year:.4}: X {:.1} Y {:.1} Z {:.1} H {:.1} F {:.1} nT, I {:.3}°, D {:.3}°",
                    model.name(), f.north_nt, f.east_nt, f.down_nt, f.horizontal_nt(), f.total_nt(), f.inclination_deg(), f.declination_deg()
                );
            }
            Ok(())
        }
        Cmd::Identify { port, json } => {
            let mut link = Link::open(&port)?;
            let id = link.identify().with_context(|| format!("identify on {port}"))?;
            let platform = match id.platform {
                Platform::Qemu => "qemu",
                Platform::Silicon => "silicon",
            };
            if json {
                let doc = json!({
                    "name": id.name.as_str(),
                    "firmware_version": id.firmware_version.as_str(),
                    "protocol_version": id.protocol_version,
                    "platform": platform,
                    "uptime_ms": id.uptime_ms,
                });
                println!("{doc}");
            } else {
                println!(
                    "{} {} (protocol {}) on {}, up {} ms",
                    id.name, id.firmware_version, id.protocol_version, platform, id.uptime_ms
                );
            }
            Ok(())
        }
        Cmd::Fit { input, model, field_nt, site, saturation, allow_weak, out, json } => {
            let SiteArgs { lat, lon, date } = site;
            let reference = reference_field(field_nt, lat, lon, date.as_deref())?;
            let rec = Recording::read(&input)?;
            let opts = FitOptions { model: model.into(), field_nt: reference.total_nt(), saturation, allow_weak };
            let mut doc = pipeline::fit_recording(&rec, &opts).with_context(|| format!("{}: {} fit", input.display(), ModelKind::from(model).name()))?;
            if lat.is_some() {
                doc.declination_deg = Some(reference.declination_deg());
            }
            warn_all(&doc.quality);
            let q = &doc.quality;
            let summary = format!(
                "{} fit of {} samples: bias {:?}, residual {:.1} nT RMS ({:.2} %), coverage {} %",
                doc.model, q["samples"], doc.bias, q["residual_rms_nt"].as_f64().unwrap_or(f64::NAN),
                q["residual_rms_pct"].as_f64().unwrap_or(f64::NAN), q["coverage_pct"]
            );
            emit(&doc, out.as_ref(), json, &summary)
        }
        Cmd::Swing { input, cal, delay_s, estimate_delay, max_delay_s, out, json } => {
            let delay = match (delay_s, estimate_delay) {
                (Some(s), false) if s.is_finite() && s >= 0.0 => Delay::Given(s),
                (Some(s), false) => bail!("--delay-s must be a non-negative number of seconds, not {s}"),
                (None, true) => Delay::Estimate { max_s: max_delay_s },
                _ => bail!("give the reference delay with --delay-s S, or --estimate-delay"),
            };
            let doc = CalDoc::load(&cal)?;
            let rec = Recording::read(&input)?;
            let (doc, fit, delay_s) = pipeline::swing_recording(&rec, &doc, delay).with_context(|| format!("{}: swing fit", input.display()))?;
            warn_all(&doc.quality);
            let s = fit.swing;
            let summary = format!(
                "swing fit of {} pairs at delay {:.2} s: A={:.5} B={:.5} C={:.5} D={:.5} E={:.5} rad; heading error {:.2}° → {:.2}° RMS",
                fit.samples, delay_s, s.a, s.b, s.c, s.d, s.e, fit.before_rms_rad.to_degrees(), fit.residual_rms_rad.to_degrees()
            );
            emit(&doc, out.as_ref(), json, &summary)
        }
        Cmd::Ortho { input, solver, cal, zero_bias, json } => {
            let rec = Recording::read(&input)?;
            let bias = match (cal, zero_bias) {
                (Some(p), _) => Some(CalDoc::load(&p)?.bias),
                (None, true) => Some([0.0; 3]),
                (None, false) => None,
            };
            let solver_kind = match solver {
                Solver::Pairwise => OrthoSolver::Pairwise,
                Solver::Linear => OrthoSolver::Linear,
            };
            let (tri, bias) = pipeline::ortho_recording(&rec, solver_kind, bias).with_context(|| format!("{}: ortho", input.display()))?;
            let a = tri.angles().context("the identified corrector is singular")?;
            if json {
                println!(
                    "{}",
                    json!({
                        "theta_rad": a.theta_rad, "phi_rad": a.phi_rad, "psi_rad": a.psi_rad,
                        "k_xz": a.k_xz, "k_yz": a.k_yz, "q": tri.q, "bias": bias,
                        "solver": match solver { Solver::Pairwise => "pairwise", Solver::Linear => "linear" },
                    })
                );
            } else {
                println!(
                    "θ = {:.6} rad, φ = {:.6} rad, ψ = {:.6} rad, k'XZ = {:.6}, k'YZ = {:.6}; q = {:?}",
                    a.theta_rad, a.phi_rad, a.psi_rad, a.k_xz, a.k_yz, tri.q
                );
            }
            Ok(())
        }
    }
}
