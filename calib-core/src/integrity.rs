//! Run-time integrity of the heading: is this sample's heading trustworthy,
//! and how good is it?
//!
//! Per sample, three checks against what the sample carries independently
//! of the calibration under test, each a normalised residual compared with
//! a gate (`Tuning::gate_sigma` for the field with a gyro,
//! `Tuning::no_gyro_gate_sigma` without, `Tuning::gyro_gate_sigma`; chosen
//! leave-one-trial-out on every real trial, `xtask/src/bench/integrity.rs`):
//!
//! - the calibrated field's **magnitude** against the reference intensity
//!   `F`: `z_F = (|h| − F) / σ_F`, with `σ_F` the scatter of `|h|` the
//!   calibration itself left (its fit residual);
//! - the **dip**: `z_I = (sin I_meas − sin I_ref) / cos I_ref · F / σ_F`
//!   (the field's noise perpendicular to it moves the dip by `σ_F / F`
//!   radians); `I_ref` is learned from the samples judged ok, within
//!   `Tuning::inclination_allowance_rad` of the document's reference
//!   inclination (the world model at the site: the local field differs from
//!   it, but a wrong calibration must not teach the monitor a dip of its
//!   own), freely when there is none;
//! - the field's **rotation against the gyro**: a two-state Kalman filter
//!   (heading, gyro yaw-rate bias) propagated with the yaw rate
//!   `ψ̇ = (sin φ ω_y + cos φ ω_z) / cos θ` and updated only with the samples
//!   judged ok; the innovation `ν = ψ_mag − ψ_pred` over its predicted
//!   `√(P + σ_ψ²)` is the third test. The magnitude and dip cannot see a
//!   disturbance perpendicular to the magnetic meridian, the one that moves
//!   the heading most; the gyro does.
//!
//! Over the recent samples, a fourth: the **horizontal intensity's
//! two-cycle variation** with heading. A soft-iron error (a wrong gain or
//! cross term in the horizontal plane) makes `H_h` vary as `cos 2ψ`,
//! `sin 2ψ`, its amplitude over the mean the heading error's amplitude;
//! |F| and the dip move too little on a level recording, and the gyro's
//! allowance for its own scale error over a turn is wider. A least-squares
//! fit of `H_h` on `1, cos 2ψ, sin 2ψ` (sums kept per sample, judged every
//! [`TWO_CYCLE_BLOCK`] samples, the older sums kept at [`TWO_CYCLE_KEEP`]
//! a block) judges the calibration invalid while the amplitude is above
//! [`TWO_CYCLE_LIMIT_DEG`] by [`TWO_CYCLE_Z`] standard errors, valid again
//! once below by as many; in between, or before the headings seen spread
//! enough, the last finding stands. A field fixed in the room moves `H_h`
//! by where the vehicle is, a new hard iron by one cycle: neither is
//! taken for it. A soft-iron error depends on the heading alone and
//! repeats every half turn, so a finding also needs that no half-circle of
//! headings (two adjacent quadrants of `ψ`, each keeping its own sums)
//! judges the amplitude below the limit: a field held in the body for a
//! while, which raises `H_h` over the arc turned meanwhile as a gain error
//! would there, is not taken for one once the vehicle has pointed the
//! other way; and a new finding waits until two adjacent quadrants hold
//! samples, so one met within the first quadrant turned through is not
//! taken for one either (unless it lasts until the second). Its samples are `cal_invalid`
//! ([`Monitor::two_cycle_found`]); the on-line hard iron neither runs for
//! it nor answers it, and restarts it when applied or withdrawn.
//!
//! Time: a failing sample starts a disturbance, which ends after
//! `Tuning::exit_s` of passing samples (hysteresis). When the field passes
//! but the gyro prediction keeps disagreeing for `Tuning::reanchor_s` while
//! the vehicle turns at least `Tuning::reanchor_turn_rad`, the prediction,
//! not the field, is taken as wrong (the gyro's scale error) and the filter
//! is re-anchored on the field; without the turn the disagreement is a
//! disturbance across the meridian and stays one. A **sustained**
//! misfit of the field (an exponentially weighted fraction of failing
//! samples, time constant `Tuning::misfit_tau_s`, above
//! `Tuning::misfit_enter`) means the stored calibration no longer fits the
//! vehicle: [`IntegrityState::CalInvalid`], until the fraction falls below
//! `Tuning::misfit_exit` or, for a calibration judged invalid at start-up
//! (before one time constant was averaged: a magnet passed as the
//! recording starts weighs as a sustained misfit then), until the fraction
//! is no longer above the entry and every sample has passed with the gyro
//! agreeing for [`STARTUP_HOLD_S`] — also while an on-line hard iron is applied: the
//! stored field is still checked, and takes over again once its own misfit
//! fraction is below the exit and its headings have agreed with the gyro
//! for `Tuning::recover_s` (`crate::online`).
//!
//! The heading's 1σ of a sample is `√(σ_cal² + (σ_n / H_h)²)` when ok (the
//! calibration's own heading error and the field's noise `σ_n` across the
//! measured horizontal intensity `H_h`; `σ_n` is `σ_F` unless the
//! calibration knows better, [`Reference::noise_nt`]); a sample not ok adds
//! its innovation and the size of its field misfit across `H_h`.
//!
//! No allocation; the state is about 400 bytes in `f32`
//! (`size_of::<Monitor<f32>>()`, tested); the levelled field is the
//! heading's (`OnlineIntegrity::process` levels once), so with
//! `OnlineIntegrity`'s bookkeeping the integrity adds about 435 Cortex-M4F
//! instructions to a usual sample's heading (`cargo xtask bench`; 349
//! before the two-cycle test: its gate and sums about 55 a sample, its fit
//! about 110 every eighth, the rest the registers they hold; the
//! quadrants' sums about 5 a sample, their half-circles fitted only while
//! the error is found).
//!
//! The module's rooms: `verdict` holds the vocabulary (the states,
//! the judgement of a sample), `tuning` what the monitor judges against and
//! how strictly, `gyro_heading` the gyro heading's Kalman filter,
//! `inclination` the dip's learner, `two_cycle` the horizontal intensity's
//! fit, `monitor` the tests and their time logic. Everything public is
//! re-exported here.

mod gyro_heading;
mod inclination;
mod monitor;
mod tuning;
mod two_cycle;
mod verdict;

pub(crate) use inclination::cos_of_sin;
pub use inclination::INCLINATION_BLOCK;
pub(crate) use monitor::positive_dt;
pub use monitor::{
    IntegrityError, Monitor, CONFIRM_GATE_REL, CONFIRM_VAR_REL,
};
pub use tuning::{
    Reference, Tuning, DEFAULT_FIELD_SIGMA_REL, INCLINATION_ALLOWANCE_DEG, MAX_MISFIT_STEP,
    REANCHOR_TURN_DEG, RECOVER_S, STARTUP_HOLD_S,
};
pub use two_cycle::{
    TWO_CYCLE_BLOCK, TWO_CYCLE_GATE_SIGMA, TWO_CYCLE_KEEP, TWO_CYCLE_LIMIT_DEG, TWO_CYCLE_Z,
};
pub(crate) use monitor::Judgement;
pub use verdict::{decide, Evidence, HardIronEvidence, IntegrityState, Verdict};

#[cfg(test)]
mod tests;
