//! Paper 001's non-orthogonality and gain identification on a recording.

use calib_core::fit::{fit_batch, Full};
use calib_core::ortho::{self, Triangular};

use super::error::ComputeError;
use crate::data::Recording;

/// Which paper-001 solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OrthoSolver {
    /// The paper's pairwise-norm Levenberg–Marquardt on q1…q5.
    Pairwise,
    /// Linear fit of the metric, then upper-triangular factorisation.
    Linear,
    /// The paper's objective over every pair of samples (linear, then
    /// Cholesky), not N disjoint pairs.
    AllSamples,
    /// Every sample, then the maximum-likelihood refinement (distances of
    /// the measured samples to the fitted surface): best where noise is
    /// strong.
    Ml,
}

/// Identifies the non-orthogonality and gains. `bias`: the hard iron to
/// remove first (`None`: estimated with a full-ellipsoid fit).
pub fn ortho_recording(rec: &Recording, solver: OrthoSolver, bias: Option<[f64; 3]>) -> Result<(Triangular<f64>, [f64; 3]), ComputeError> {
    let (_, samples) = rec.complete_mag();
    if samples.is_empty() {
        return Err(ComputeError::NoSamples);
    }
    let bias = match bias {
        Some(b) => b,
        // The bias does not depend on the reference intensity: use 1.
        None => fit_batch::<Full, 9, f64>(&samples, 1.0)?.bias,
    };
    let tri = match solver {
        OrthoSolver::Pairwise => ortho::identify_pairwise(&samples, bias)?,
        OrthoSolver::Linear => ortho::identify_linear(&samples, bias)?,
        OrthoSolver::AllSamples => ortho::identify_all_samples(&samples, bias)?,
        OrthoSolver::Ml => ortho::identify_ml(&samples, bias)?.tri,
    };
    Ok((tri, bias))
}

