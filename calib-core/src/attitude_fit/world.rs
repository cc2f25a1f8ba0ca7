//! The world model's dip as a measurement in the attitude-aided fit,
//! weighted against what the data can tell.
//!
//! The data rows are weighted by their robust residual scale as if every
//! residual were independent. Along a real path they are not (a glider's
//! residuals follow its dives, a hull's its headings), so the formal
//! information on the dip overstates what the data hold, and a prior at the
//! world model's stated σ barely moves the dip even where the data cannot
//! tell it from the vertical scale. Here the data's own scatter decides:
//! the recording is cut into contiguous blocks, each block's pull on the
//! dip (its rows' score through the dip's row of the covariance) is
//! summed, and the variance of those block pulls against the variance the
//! formal weighting predicts for them is the inflation `κ ≥ 1` — the
//! cluster-robust ("sandwich") variance of the dip over its formal one.
//! The prior's row is then weighted `√κ/σ`: against the data's formal
//! information that is the world model's σ against the data's real one. A
//! thin or self-contradicting recording (large `κ`) ends near the world
//! model; a rich, consistent one (`κ` near 1) where its data say.

use super::{dip_sin_cos, huber, level_matrix, rows, AttitudeConfig, AttitudeEstimate, Prepared, DIP, UNKNOWNS};
use crate::Real;

/// Largest number of blocks the data's dip information is checked over.
pub const MAX_DIP_BLOCKS: u32 = 64;

/// The prior's row for the solver: gradient and residual of the dip prior
/// `(inclination_rad, sigma_rad)` at `x`, its weight raised by `√inflation`.
pub(super) fn dip_prior_row<T: Real>(x: &[T; UNKNOWNS], (dip, sigma): (T, T), inflation: T) -> ([T; UNKNOWNS], T) {
    let w = inflation.max(T::ONE).sqrt() / sigma;
    let mut phi = [T::ZERO; UNKNOWNS];
    phi[DIP] = w;
    (phi, (dip - x[DIP]) * w)
}

/// The variance of the dip's block pulls over what the formal weighting
/// predicts for them (at least 1): `blocks` contiguous blocks of the usable
/// samples, robust weights at scale `sigma`, `dip_row` the dip's row of the
/// covariance at `x`. 1 when it cannot be told (fewer than two blocks, no
/// information).
pub(super) fn dip_inflation<T: Real>(x: &[T; UNKNOWNS], data: &Prepared<'_, T>, cfg: &AttitudeConfig<T>, sigma: T, dip_row: &[T; UNKNOWNS], blocks: u32) -> T {
    let blocks = blocks.min(MAX_DIP_BLOCKS) as usize;
    let used = data.usable().count();
    if blocks < 2 || used < blocks {
        return T::ONE;
    }
    let k = cfg.huber_k * sigma;
    let s2 = sigma * sigma;
    let mut pulls = [T::ZERO; MAX_DIP_BLOCKS as usize];
    let mut formal = T::ZERO;
    let dip = dip_sin_cos(x);
    for (n, s) in data.usable().enumerate() {
        let Some(rs) = rows(x, dip, data.norm.apply(s.raw), &level_matrix(&s.tilt)) else { continue };
        let b = (n * blocks / used).min(blocks - 1);
        for (j, r) in rs {
            let w = huber(r, k);
            let g: T = dip_row.iter().zip(j.iter()).fold(T::ZERO, |acc, (c, v)| acc + *c * *v);
            if let Some(p) = pulls.get_mut(b) {
                *p += g * w * r / s2;
            }
            formal += g * g * w / s2;
        }
    }
    block_inflation(pulls.get(..blocks).unwrap_or(&[]), formal)
}

/// The variance of contiguous blocks' pulls on a fitted quantity over the
/// variance the formal weighting predicts for their sum (`formal`), at
/// least 1: the cluster-robust ("sandwich") variance over the formal one,
/// `Σ_b (p_b − p̄)² · B/(B − 1) / formal` for `B` blocks. Each block's pull
/// is `Σ gᵢ·wᵢ·rᵢ` over its rows (`g` the quantity's sensitivity to the
/// row, `w` its weight, `r` its residual) and `formal = Σ gᵢ²·wᵢ·σ²`. 1
/// when it cannot be told (fewer than two blocks, no formal information,
/// a non-finite spread). Any levelled fit's prior on the world model's dip
/// is weighted with it (this module, and the host's gyro-aided fit).
pub fn block_inflation<T: Real>(pulls: &[T], formal: T) -> T {
    if pulls.len() < 2 {
        return T::ONE;
    }
    let nb = T::from_f64(pulls.len() as f64);
    let mean = pulls.iter().fold(T::ZERO, |a, p| a + *p) / nb;
    let spread = pulls.iter().fold(T::ZERO, |a, p| a + (*p - mean) * (*p - mean)) * nb / (nb - T::ONE);
    if !(formal > T::ZERO) || !spread.is_finite() {
        return T::ONE;
    }
    (spread / formal).max(T::ONE)
}

/// Where the data alone put the dip, and its 1σ with their block scatter
/// counted, from a fit that weighed the dip prior at `inclination_rad`
/// ([`AttitudeEstimate::dip_prior_share`], `dip_data_inflation`): the prior
/// adds `κ/σ²` to the dip's information and nothing else, so the data's own
/// information is the fitted one less it, `(1 − share)/σ_dip²`, and the
/// fitted dip is the two estimates weighted, `dip = (1 − share)·data +
/// share·inclination`. The data's 1σ is their formal one raised by `√κ`.
/// `None` where the prior set all of the dip (the data tell nothing of it)
/// or a value is not finite.
pub fn data_alone_dip<T: Real>(est: &AttitudeEstimate<T>, inclination_rad: T) -> Option<(T, T)> {
    let rest = T::ONE - est.dip_prior_share;
    if !(rest > T::from_f64(1e-9)) {
        return None;
    }
    let dip = (est.dip_rad - est.dip_prior_share * inclination_rad) / rest;
    let sigma = (est.dip_sigma_rad * est.dip_sigma_rad * est.dip_data_inflation.max(T::ONE) / rest).sqrt();
    (dip.is_finite() && sigma.is_finite()).then_some((dip, sigma))
}

#[cfg(test)]
mod tests {
    use super::{block_inflation, data_alone_dip};
    use crate::attitude_fit::AttitudeEstimate;
    use crate::cal::FieldCal;

    /// By hand: a dip of 0.5 rad at 1σ 0.1 of which the prior at 1.0 set
    /// 20 %: the data's share 0.8 of 0.5 − 0.2·1.0 gives 0.375; their formal
    /// variance 0.01/0.8, raised 4× by the blocks' scatter, 0.05. A prior
    /// that set all of it leaves nothing to say.
    #[test]
    fn the_data_alone_dip_is_the_fitted_one_without_the_priors_share() {
        let est = |share: f64| AttitudeEstimate {
            cal: FieldCal::identity(),
            dip_rad: 0.5,
            dip_sigma_rad: 0.1,
            residual_sigma_nt: 0.0,
            samples: 0,
            downweighted: 0,
            bias_sigma_raw: [0.0; 3],
            matrix_sigma_rel: [0.0; 9],
            predicted_heading_rms_rad: 0.0,
            dip_prior_share: share,
            dip_data_inflation: 4.0,
        };
        let (dip, sigma) = data_alone_dip(&est(0.2), 1.0).unwrap();
        assert!((dip - 0.375).abs() < 1e-12 && (sigma - 0.05f64.sqrt()).abs() < 1e-12, "{dip} {sigma}");
        let (dip, sigma) = data_alone_dip(&est(0.0), 1.0).unwrap();
        assert!((dip - 0.5).abs() < 1e-12 && (sigma - 0.2).abs() < 1e-12, "{dip} {sigma}");
        assert_eq!(data_alone_dip(&est(1.0), 1.0), None);
    }

    /// By hand: pulls 1, −1, 1, −1 have mean 0 and Σ(p − p̄)² = 4, so the
    /// cluster variance is 4·4/3 = 16/3; over a formal variance of 1 that is
    /// the inflation. Pulls that agree have no spread: never below 1.
    #[test]
    fn the_block_inflation_is_the_blocks_spread_over_the_formal_variance() {
        assert!((block_inflation::<f64>(&[1.0, -1.0, 1.0, -1.0], 1.0) - 16.0 / 3.0).abs() < 1e-12);
        assert!((block_inflation::<f64>(&[1.0, -1.0, 1.0, -1.0], 2.0) - 8.0 / 3.0).abs() < 1e-12);
        assert_eq!(block_inflation::<f64>(&[0.5, 0.5, 0.5], 1.0), 1.0);
        assert_eq!(block_inflation::<f64>(&[3.0], 1.0), 1.0);
        assert_eq!(block_inflation::<f64>(&[1.0, -1.0], 0.0), 1.0);
        assert_eq!(block_inflation::<f64>(&[1.0, f64::NAN], 1.0), 1.0);
    }
}
