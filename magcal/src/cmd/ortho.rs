//! `magcal ortho`: paper 001's non-orthogonality and gain identification.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use calib_core::cal::ModelKind;
use calib_core::fit::{fit_batch, Full};
use calib_core::quality::{assess, Quality};
use clap::ValueEnum;
use host_tools::compute::{self, OrthoSolver};
use serde_json::json;

/// The solver, as the command line names it.
#[derive(Clone, Copy, ValueEnum)]
pub enum Solver {
    /// The paper's pairwise-norm solver (Levenberg–Marquardt on q1…q5).
    Pairwise,
    /// Linear fit of Γ⁻ᵀΓ⁻¹, then upper-triangular factorisation.
    Linear,
    /// The paper's objective over every pair of samples, not N disjoint ones.
    All,
    /// Every sample, then the maximum-likelihood refinement (distance of each
    /// measured sample to the fitted surface); best where noise is strong.
    Ml,
}

/// Arguments of `magcal ortho`.
#[derive(clap::Args)]
pub struct Args {
    /// The recordings' own column names and units.
    #[command(flatten)]
    pub columns: super::InputColumns,
    /// Recording (CSV with mx, my, mz), the sensor turned in a constant field.
    #[arg(long)]
    input: PathBuf,
    /// Solver (`pairwise` is the paper's; `ml` gives the lowest J, e.g. mean
    /// J 0.013 against the paper's 0.018 at σ = 0.01 on 1 440 samples).
    #[arg(long, value_enum, default_value = "pairwise")]
    solver: Solver,
    /// Take the hard-iron bias from this calibration document.
    #[arg(long, conflicts_with = "zero_bias")]
    cal: Option<PathBuf>,
    /// The data have no bias (e.g. paper 001's simulation).
    #[arg(long)]
    zero_bias: bool,
    /// Print the result even when the quality gates (the triangular model's
    /// coverage and residual) fail.
    #[arg(long)]
    allow_weak: bool,
    /// Print one JSON document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal ortho`.
pub fn run(a: Args) -> Result<()> {
    let rec = a.columns.read(&a.input)?;
    let bias = match (&a.cal, a.zero_bias) {
        (Some(p), _) => Some(super::load_field_doc(p, a.allow_weak)?.bias),
        (None, true) => Some([0.0; 3]),
        (None, false) => None,
    };
    let (solver, name) = match a.solver {
        Solver::Pairwise => (OrthoSolver::Pairwise, "pairwise"),
        Solver::Linear => (OrthoSolver::Linear, "linear"),
        Solver::All => (OrthoSolver::AllSamples, "all"),
        Solver::Ml => (OrthoSolver::Ml, "ml"),
    };
    let (tri, bias) = compute::ortho_recording(&rec, solver, bias).with_context(|| format!("{}: ortho", a.input.display()))?;
    let angles = tri.angles().context("the identified corrector is singular")?;
    let (_, samples) = rec.complete_mag();
    if a.zero_bias {
        warn_if_biased(&samples);
    }
    let q = quality(&tri, bias, &samples);
    if !a.allow_weak {
        if let Err(e) = compute::gates(ModelKind::Triangular).check(&q) {
            bail!("{}: ortho: {e} (give --allow-weak to see the result anyway)", a.input.display());
        }
    }
    let quality_json = json!({"samples": q.samples, "coverage_pct": q.coverage_pct, "residual_rms_pct": q.residual_rms_pct});
    if a.json {
        println!(
            "{}",
            json!({
                "theta_rad": angles.theta_rad, "phi_rad": angles.phi_rad, "psi_rad": angles.psi_rad,
                "k_xz": angles.k_xz, "k_yz": angles.k_yz, "q": tri.q, "bias": bias, "solver": name, "quality": quality_json,
            })
        );
    } else {
        println!(
            "θ = {:.6} rad, φ = {:.6} rad, ψ = {:.6} rad, k'XZ = {:.6}, k'YZ = {:.6}; q = {:?}; {} samples, coverage {} %, corrected magnitude {:.2} % RMS about its mean",
            angles.theta_rad, angles.phi_rad, angles.psi_rad, angles.k_xz, angles.k_yz, tri.q, q.samples, q.coverage_pct, q.residual_rms_pct
        );
    }
    Ok(())
}

/// The corrector's quality (calib-core's, as the field fits'): coverage of
/// the corrected directions and the spread of the corrected magnitudes about
/// their mean (the corrector's scale is the data's, not a field in nT).
fn quality(tri: &calib_core::ortho::Triangular<f64>, bias: [f64; 3], samples: &[[f64; 3]]) -> Quality<f64> {
    let cal = calib_core::ortho::to_field_cal(tri, 1.0, bias);
    let norms: Vec<f64> = samples.iter().map(|s| cal.apply(*s)).map(|h| (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()).filter(|m| m.is_finite()).collect();
    let mean = norms.iter().sum::<f64>() / norms.len().max(1) as f64;
    assess(&cal, samples, mean)
}

/// Largest centre of a full-ellipsoid fit, as a fraction of the data's mean
/// radius, that `--zero-bias` passes without a warning (paper 001's
/// unbiased simulation at σ = 10⁻² fits a centre of ~0.1 % of the radius).
const ZERO_BIAS_WARN_FRACTION: f64 = 0.05;

/// `--zero-bias` on data whose centre is evidently not zero: says so.
fn warn_if_biased(samples: &[[f64; 3]]) {
    let Ok(full) = fit_batch::<Full, 9, f64>(samples, 1.0) else { return };
    let b = full.bias;
    let radius = samples.iter().map(|s| (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()).sum::<f64>() / samples.len().max(1) as f64;
    let off = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
    if off > ZERO_BIAS_WARN_FRACTION * radius {
        eprintln!(
            "warning: --zero-bias, but the data's centre (a full-ellipsoid fit) is at [{:.4}, {:.4}, {:.4}], {:.0} % of their mean radius: the angles are wrong by the bias; give --cal or leave both out to estimate it",
            b[0], b[1], b[2], off / radius * 100.0
        );
    }
}
