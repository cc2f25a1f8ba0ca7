//! The per-sample path with integrity, as the board runs it and `magcal
//! apply` replays it: the stored calibration applied to the sample, the
//! [`Monitor`]'s verdict, the on-line hard-iron estimate
//! ([`HardIronEstimator`]) and the guard that decides whether to apply it,
//! and the health counters.
//!
//! **The guard.** The estimate is applied only when all of these hold:
//! the stored calibration is judged invalid (its headings are already not
//! `ok`, so applying can only add `ok` samples where there were none); a
//! shadow check of the field corrected by the estimate (the same magnitude
//! and dip gates, the same misfit fraction) has passed below
//! [`SHADOW_MISFIT_MAX`] over at least three misfit time constants; the
//! offset model explains the misfit (normalised magnitude residual RMS ≤ 2);
//! the estimate's own uncertainty moves the heading by no more than the
//! stored calibration's σ does (`max σ_δ / H_h ≤ σ_ψ,stored`); and the offset
//! is below [`MAX_OFFSET_REL`] of `F`. Applied, each
//! sample's σ adds the estimate's, and the corrected field goes through the
//! same monitor: if it misfits for a sustained time the estimate is
//! withdrawn and the stored calibration taken back as invalid (it is valid
//! again only after its own field has fitted for a while). So a heading
//! called `ok` with the estimate has passed every test a heading with the
//! stored calibration must pass, with a σ at least as large.
//!
//! **The recovery.** While applied, the stored calibration is still
//! checked (`OnlineIntegrity::stored_agrees`): once its own field's misfit
//! fraction is below `Tuning::misfit_exit` and its headings have agreed
//! with the gyro for `Tuning::recover_s`, the estimate is withdrawn and the
//! stored calibration is valid again — an estimate a transient left behind
//! (never confirmed by a 90° turn, never refuted by its field) does not
//! keep the vehicle `cal_invalid` for good.
//!
//! While applied, the estimator goes on over the samples judged `ok`, and
//! the offset in use follows its estimate whenever that passes the guard's
//! σ and residual tests.
//!
//! **Cost.** The estimator runs only while the stored calibration is judged
//! invalid or its estimate is applied; a sample the stored calibration fits
//! costs the monitor alone (`cargo xtask bench`,
//! `integrity_ok_turn_instructions`).

use crate::cal::Calibration;
use crate::hardiron::{HardIron, HardIronEstimator};
use crate::heading::{Tilt, Vec3};
use crate::integrity::{
    cos_of_sin, positive_dt, HardIronEvidence, IntegrityError, IntegrityState, Judgement, Monitor,
    Reference, Tuning, Verdict, MAX_MISFIT_STEP,
};
use crate::Real;

/// The largest on-line hard iron the guard applies, as a fraction of `F`.
/// A payload or a magnetised part near the sensor moves the field by a few
/// thousand nT (the simulator's payload: 2 000 nT at the sensor, 0.04 `F`;
/// the tests' steps 0.15–0.18 `F`); an offset above a quarter of the
/// Earth's field is not a change the stored calibration can carry — a part
/// that magnetised moves the soft iron too — but a wrong calibration: it
/// stays `cal_invalid`. On the simulator's validation run an identity
/// matrix on raw counts needs 0.86 `F` (its headings then 53° off) and the
/// README chain's document with its bias zeroed 0.38 `F` (its `ok` rows
/// were 1.4° off for the first 1 000 s against a 0.27° σ).
pub const MAX_OFFSET_REL: f64 = 0.25;

/// Samples per state and the longest disturbance.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health<T> {
    /// Samples judged in each state, indexed by [`IntegrityState::index`].
    pub samples_per_state: [u32; IntegrityState::COUNT],
    /// Longest run of samples not `ok` (disturbed or calibration invalid), s.
    pub longest_disturbance_s: T,
    /// The run in progress, s.
    pub current_disturbance_s: T,
    /// Times the on-line hard iron was applied.
    pub hard_iron_applied: u32,
}

/// One calibrated, judged sample.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Judged<T> {
    /// Calibrated field, body frame, nT (with the on-line hard iron when applied).
    pub field_nt: Vec3<T>,
    /// True heading in [0, 2π), `None` without attitude.
    pub heading_rad: Option<T>,
    /// The integrity verdict (its σ includes the on-line estimate's when applied).
    pub verdict: Verdict<T>,
    /// Whether the on-line hard iron was applied to this sample.
    pub hard_iron_applied: bool,
}

/// The per-sample path with integrity: fixed state, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct OnlineIntegrity<T> {
    monitor: Monitor<T>,
    estimator: HardIronEstimator<T>,
    /// The applied offset, nT (subtracted from the stored calibration's
    /// field), and its heading σ, radians.
    applied_nt: Vec3<T>,
    applied_sigma_rad: T,
    applied: bool,
    /// Misfit fraction of the stored calibration corrected by the estimate
    /// (tracked while the stored calibration is invalid), and how long it
    /// has been tracked, s.
    shadow_misfit: T,
    shadow_seen_s: T,
    /// While estimating (the stored calibration invalid, or the estimate
    /// applied), the estimator runs every `alt_every`-th sample, over the
    /// time accumulated since.
    alt_every: u8,
    alt_count: u8,
    alt_dt_s: T,
    /// The gyro's confirmation of the applied estimate.
    confirm: Confirmation<T>,
    /// While the estimate is applied: the same window over the stored
    /// calibration's own headings, open while its field fits
    /// ([`OnlineIntegrity::stored_agrees`]).
    stored: Confirmation<T>,
    /// How long the stored calibration has fitted and agreed with the
    /// gyro while the estimate is applied, s (gaps pause it); its misfit
    /// fraction meanwhile, and how long that has been tracked, s.
    stored_agree_s: T,
    stored_misfit: T,
    stored_seen_s: T,
    health: Health<T>,
}

/// The gyro's check of the headings the on-line hard iron gives: over a
/// window, the change of the magnetic heading against the gyro's
/// integrated yaw (no magnetic update in between, unlike the monitor's
/// filter, which follows the field). A wrong offset `δ` puts a one-cycle
/// error `δ/H · sin(ψ − ψ₀)` on the heading, which a turn shows against
/// the gyro. Until a window of at least [`CONFIRM_TURN_RAD`] of turning
/// has agreed, no sample with the estimate is `ok`; a window that
/// disagrees withdraws the estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
struct Confirmation<T> {
    /// A window is open: its first magnetic heading, the gyro's yaw
    /// integrated since (bias removed), the absolute turn and the time, rad, s.
    open: bool,
    heading0_rad: T,
    gyro_rad: T,
    turned_rad: T,
    elapsed_s: T,
    /// A window has agreed since the estimate was applied.
    confirmed: bool,
}

impl<T: Real> Confirmation<T> {
    /// A window opened at the magnetic heading `heading_rad`, keeping
    /// whether an earlier window confirmed the estimate.
    fn opened_at(heading_rad: T, confirmed: bool) -> Self {
        Self { open: true, heading0_rad: heading_rad, gyro_rad: T::ZERO, turned_rad: T::ZERO, elapsed_s: T::ZERO, confirmed }
    }

    /// The same, closed: the next sample with a heading and rates opens one.
    fn closed(self) -> Self {
        Self { open: false, ..self }
    }

    /// Carries the window over one sample: the magnetic heading's change
    /// since the window opened against the gyro's integrated yaw (`hh`: the
    /// levelled horizontal intensity). A window not open, after a gap
    /// longer than `Tuning::max_gap_s`, or older than [`CONFIRM_WINDOW_S`]
    /// opens here and agrees; one that disagrees closes.
    #[inline(always)]
    fn step(&mut self, monitor: &Monitor<T>, heading_rad: T, hh: T, t: &Tilt<T>, w: Vec3<T>, dt: T) -> Check {
        let tuning = monitor.tuning();
        if !self.open || dt > tuning.max_gap_s || self.elapsed_s > T::from_f64(CONFIRM_WINDOW_S) {
            *self = Confirmation::opened_at(heading_rad, self.confirmed);
            return Check::Agrees;
        }
        let yaw_rad = (t.yaw_rate(w) - monitor.gyro_bias_rad_s()) * dt;
        self.gyro_rad += yaw_rad;
        self.turned_rad += yaw_rad.abs();
        self.elapsed_s += dt;
        let delta = crate::heading::wrap_pi(heading_rad - self.heading0_rad - self.gyro_rad);
        // Both ends' noise, the gyro's scale error over the turn, its walk
        // and its bias's 1σ over the window.
        let bias = tuning.bias_sigma_rad_s * self.elapsed_s;
        let var = T::from_f64(2.0) * monitor.sample_var(hh)
            + tuning.scale_var_per_rad * self.turned_rad
            + tuning.heading_walk_rad2_s * self.elapsed_s
            + bias * bias;
        let g = tuning.gyro_gate_sigma;
        if delta * delta > g * g * var {
            self.open = false;
            return Check::Disagrees;
        }
        Check::Agrees
    }
}

/// Turning a window must see before it confirms the applied estimate,
/// radians (90°: a wrong offset's heading error then changes by √2 its
/// amplitude).
pub const CONFIRM_TURN_RAD: f64 = core::f64::consts::FRAC_PI_2;

/// The longest confirmation window, s: the gyro's walk and bias make a
/// longer one uninformative; a window this old without the turn restarts.
pub const CONFIRM_WINDOW_S: f64 = 20.0;

/// What a confirmation window says of a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Check {
    /// Nothing against the estimate (the window agrees so far).
    Agrees,
    /// The magnetic heading's change disagrees with the gyro's.
    Disagrees,
}

/// The corrected field's misfit fraction below which the shadow check
/// passes (a tenth: the guard's own strictness, apart from the monitor's
/// exit hysteresis `Tuning::misfit_exit`, which is chosen on real data for
/// the stored calibration's false alarms).
pub const SHADOW_MISFIT_MAX: f64 = 0.1;

/// The on-line hard iron's memory, s.
pub const HARD_IRON_TAU_S: f64 = 60.0;

/// While the stored calibration is invalid or the estimate applied, the
/// board runs the hard-iron estimator every this many output samples
/// ([`OnlineIntegrity::with_estimator_every`]); `magcal apply` uses the
/// same, so for the board's reference it gives the board's bits. Every
/// sample: at the board's default 10 Hz, `n` = 2 joins gyro rows exactly
/// `Tuning::max_gap_s` (0.2 s) apart, the limit, and a larger `n` more, so
/// the estimator would see no rotation (its cost is reported by
/// `cargo xtask bench`, `integrity_cal_invalid_instructions`).
pub const BOARD_ESTIMATOR_EVERY: u8 = 1;

impl<T: Real> OnlineIntegrity<T> {
    /// Integrity for a calibration with this reference.
    pub fn new(reference: Reference<T>, tuning: Tuning<T>) -> Result<Self, IntegrityError> {
        Ok(Self {
            monitor: Monitor::new(reference, tuning)?,
            estimator: HardIronEstimator::new(T::from_f64(HARD_IRON_TAU_S)),
            applied_nt: [T::ZERO; 3],
            applied_sigma_rad: T::ZERO,
            applied: false,
            shadow_misfit: T::ZERO,
            shadow_seen_s: T::ZERO,
            alt_every: 1,
            alt_count: 0,
            alt_dt_s: T::ZERO,
            confirm: Confirmation::opened_at(T::ZERO, false).closed(),
            stored: Confirmation::opened_at(T::ZERO, false).closed(),
            stored_agree_s: T::ZERO,
            stored_misfit: T::ZERO,
            stored_seen_s: T::ZERO,
            health: Health {
                samples_per_state: [0; IntegrityState::COUNT],
                longest_disturbance_s: T::ZERO,
                current_disturbance_s: T::ZERO,
                hard_iron_applied: 0,
            },
        })
    }

    /// The board's integrity for a stored calibration of intensity
    /// `field_nt` ([`Reference::from_field_nt`], [`Tuning::standard`], the
    /// estimator every [`BOARD_ESTIMATOR_EVERY`] samples).
    pub fn for_stored_field(field_nt: T) -> Result<Self, IntegrityError> {
        Self::for_stored(field_nt, None)
    }

    /// The same with the stored reference inclination (radians; `None`:
    /// learned from the samples judged ok), as the board runs it and `magcal
    /// apply` replays a document giving only `field_nt` and an inclination.
    pub fn for_stored(field_nt: T, inclination_rad: Option<T>) -> Result<Self, IntegrityError> {
        let reference = Reference {
            inclination_rad,
            ..Reference::from_field_nt(field_nt)
        };
        Ok(Self::new(reference, Tuning::standard())?.with_estimator_every(BOARD_ESTIMATOR_EVERY))
    }

    /// Runs the hard-iron estimator and its shadow check only every `n`-th
    /// sample (1, the default, every sample; 0 is taken as 1), over the time
    /// accumulated since: the board's way to fit its CPU budget. The gyro
    /// rows need the samples they join at most `Tuning::max_gap_s` apart.
    /// `magcal apply` must use the board's `n` to give the board's bits.
    pub fn with_estimator_every(mut self, n: u8) -> Self {
        self.alt_every = n.max(1);
        self
    }

    /// The monitor.
    pub fn monitor(&self) -> &Monitor<T> {
        &self.monitor
    }

    /// The health counters.
    pub fn health(&self) -> &Health<T> {
        &self.health
    }

    /// The on-line hard-iron estimate (reported whether applied or not):
    /// `None` until the stored calibration is judged invalid, restarted at
    /// each onset and withdrawal, and left as it was when the calibration
    /// fits again (the last estimate formed, not a current one).
    pub fn hard_iron(&self) -> Option<HardIron<T>> {
        self.estimator.estimate()
    }

    /// The offset applied to the samples, nT (`None` when not applied).
    pub fn applied_offset_nt(&self) -> Option<Vec3<T>> {
        self.applied.then_some(self.applied_nt)
    }

    /// Calibrates and judges one sample: `raw` already corrected for the
    /// current and temperature terms (`EnvTerms::correct_raw`), the
    /// attitude and body rates when known, the time since the previous
    /// sample, s.
    ///
    /// The usual sample (the stored calibration fits) costs the field, its
    /// levelling (shared by the heading and the monitor) and the monitor;
    /// the estimator runs only while the stored calibration is judged
    /// invalid (it restarts at each onset, so nothing it would have seen
    /// before is lost) or its estimate is applied.
    pub fn process(
        &mut self,
        cal: &Calibration<T>,
        raw: Vec3<T>,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt_s: T,
    ) -> Judged<T> {
        let stored_nt = cal.field.apply(raw);
        // The field through the stored calibration, less the applied hard
        // iron (an offset of the calibrated field, nT).
        let field_nt = if self.applied {
            [
                stored_nt[0] - self.applied_nt[0],
                stored_nt[1] - self.applied_nt[1],
                stored_nt[2] - self.applied_nt[2],
            ]
        } else {
            stored_nt
        };
        let was_invalid = self.monitor.cal_invalid();
        let dt = positive_dt(dt_s);
        let (heading_rad, hh, mut judgement): (_, _, Judgement<T>) = match tilt {
            Some(t) => {
                let l = t.level(field_nt);
                let hh = (l[0] * l[0] + l[1] * l[1]).sqrt();
                let heading_rad = cal.true_heading_of_levelled(l, hh);
                (
                    Some(heading_rad),
                    hh,
                    self.monitor
                        .judge_levelled(l, hh, heading_rad, t, rate_rad_s, dt),
                )
            }
            None => (
                None,
                T::ZERO,
                self.monitor.judge_without_attitude(field_nt, dt),
            ),
        };
        let applied_here = self.applied;
        if self.applied {
            let sigma = judgement.heading_sigma_rad;
            judgement.heading_sigma_rad =
                (sigma * sigma + self.applied_sigma_rad * self.applied_sigma_rad).sqrt();
            let check = self.confirm_step(heading_rad, hh, tilt, rate_rad_s, dt);
            if check == Check::Disagrees {
                // The gyro says the estimate's headings are wrong.
                self.withdraw();
                judgement.evidence.hard_iron = HardIronEvidence::Refuted;
            } else {
                if self.monitor.cal_invalid() {
                    self.withdraw();
                } else if self.stored_agrees(cal, stored_nt, tilt, rate_rad_s, dt) {
                    // The evidence against the stored calibration has ended.
                    self.restore_stored();
                } else if judgement.evidence.fits() {
                    // Only samples the corrected field passes on teach it: a
                    // structure passed must not pull the offset in use.
                    self.refine_applied(stored_nt, tilt, rate_rad_s, dt);
                }
                // Until the gyro confirms it (never without a gyro) the
                // estimate is unproven.
                judgement.evidence.hard_iron = if self.confirm.confirmed {
                    HardIronEvidence::Confirmed
                } else {
                    HardIronEvidence::Unconfirmed
                };
            }
        } else if self.monitor.cal_invalid() {
            if !was_invalid {
                // The misfit's onset: what the estimator saw before belongs
                // to the old vehicle.
                self.restart_estimate();
            }
            self.track_estimate(stored_nt, tilt, rate_rad_s, dt);
        }
        let verdict = judgement.verdict();
        self.count(verdict.state, dt);
        Judged {
            field_nt,
            heading_rad,
            verdict,
            hard_iron_applied: applied_here,
        }
    }

    /// One sample of the gyro's confirmation of the applied estimate
    /// ([`Confirmation`]): `hh` is the levelled horizontal intensity.
    #[inline(never)]
    fn confirm_step(
        &mut self,
        heading_rad: Option<T>,
        hh: T,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt: T,
    ) -> Check {
        let c = &mut self.confirm;
        let (Some(heading), Some(t), Some(w)) = (heading_rad, tilt, rate_rad_s) else {
            c.open = false;
            return Check::Agrees;
        };
        if c.step(&self.monitor, heading, hh, t, w, dt) == Check::Disagrees {
            c.confirmed = false;
            return Check::Disagrees;
        }
        if c.open && c.turned_rad >= T::from_f64(CONFIRM_TURN_RAD) {
            c.confirmed = true;
            c.open = false;
        }
        Check::Agrees
    }

    /// While the estimate is applied: whether the stored calibration fits
    /// again, by the monitor's own rule for the field it no longer judges —
    /// the stored field's misfit fraction (the same gates, time constant
    /// and step cap, tracked over at least three time constants) below
    /// `Tuning::misfit_exit` — and its headings' change has agreed with
    /// the gyro's integrated yaw, every sample within the monitor's field
    /// gates, for longer than `Tuning::recover_s` without a break (a sample
    /// that opens a window, after a gap, pauses that clock). Without an
    /// attitude or body rates, never.
    #[inline(never)]
    fn stored_agrees(
        &mut self,
        cal: &Calibration<T>,
        stored_nt: Vec3<T>,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt: T,
    ) -> bool {
        let (Some(t), Some(w)) = (tilt, rate_rad_s) else {
            self.stored.open = false;
            return false;
        };
        let r = *self.monitor.reference();
        let tuning = *self.monitor.tuning();
        let l = t.level(stored_nt);
        let hh = (l[0] * l[0] + l[1] * l[1]).sqrt();
        let mag = (hh * hh + l[2] * l[2]).sqrt();
        let g = tuning.field_gate(true);
        let mut fits = (mag - r.field_nt).abs() < g * r.field_sigma_nt;
        if let Some(s) = self.monitor.sin_inclination() {
            let dip_z = (l[2] / mag.max(r.field_sigma_nt) - s) / cos_of_sin(s) * r.field_nt
                / r.field_sigma_nt;
            fits &= dip_z.abs() < g;
        }
        let a = (dt / tuning.misfit_tau_s).min(T::from_f64(MAX_MISFIT_STEP));
        self.stored_misfit += a * (if fits { T::ZERO } else { T::ONE } - self.stored_misfit);
        self.stored_seen_s += dt;
        if !fits {
            self.stored.open = false;
            self.stored_agree_s = T::ZERO;
            return false;
        }
        let heading_rad = cal.true_heading_of_levelled(l, hh);
        if self.stored.step(&self.monitor, heading_rad, hh, t, w, dt) == Check::Disagrees {
            self.stored_agree_s = T::ZERO;
            return false;
        }
        // A window opened here has tested nothing yet.
        if self.stored.elapsed_s > T::ZERO {
            self.stored_agree_s += dt;
        }
        self.stored_agree_s > tuning.recover_s
            && self.stored_seen_s >= T::from_f64(3.0) * tuning.misfit_tau_s
            && self.stored_misfit < tuning.misfit_exit
    }

    /// The stored calibration fits again while the estimate is applied:
    /// the estimate is withdrawn and the monitor goes on with the stored
    /// field's misfit fraction (below `Tuning::misfit_exit`: valid); a new
    /// estimate starts at the next onset.
    #[inline(never)]
    fn restore_stored(&mut self) {
        self.applied = false;
        self.stored.open = false;
        self.stored_agree_s = T::ZERO;
        self.confirm.open = false;
        self.monitor.switch_field(self.stored_misfit);
        self.monitor.set_gyro_vouches(true);
        self.restart_estimate();
    }

    /// Forgets the estimate in progress and its shadow check.
    #[inline(never)]
    fn restart_estimate(&mut self) {
        self.estimator.reset();
        self.shadow_misfit = T::ZERO;
        self.shadow_seen_s = T::ZERO;
        self.alt_count = 0;
        self.alt_dt_s = T::ZERO;
    }

    /// Feeds the estimator the stored calibration's field of this sample,
    /// every `alt_every`-th sample over the time accumulated since; returns
    /// that time step, or `None` when this sample was not fed.
    fn feed_estimator(
        &mut self,
        stored_nt: Vec3<T>,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt: T,
    ) -> Option<T> {
        self.alt_dt_s += dt;
        self.alt_count = self.alt_count.saturating_add(1);
        if self.alt_count < self.alt_every {
            return None;
        }
        let dt = self.alt_dt_s;
        self.alt_count = 0;
        self.alt_dt_s = T::ZERO;
        let r = *self.monitor.reference();
        let sin_incl = self.monitor.sin_inclination();
        self.estimator.update(
            stored_nt,
            tilt,
            rate_rad_s,
            dt,
            r.field_nt,
            r.field_sigma_nt,
            sin_incl,
            self.monitor.tuning().max_gap_s,
        );
        Some(dt)
    }

    /// While the stored calibration is invalid: feeds the estimator (every
    /// `alt_every`-th sample, over the time accumulated since), checks the
    /// field it corrects (the shadow), and applies the estimate when the
    /// shadow has fitted long enough and the guard passes.
    #[inline(never)]
    fn track_estimate(
        &mut self,
        stored_nt: Vec3<T>,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt: T,
    ) {
        let Some(dt) = self.feed_estimator(stored_nt, tilt, rate_rad_s, dt) else {
            return;
        };
        let r = *self.monitor.reference();
        let tuning = *self.monitor.tuning();
        let sin_incl = self.monitor.sin_inclination();
        let Some(e) = self.estimator.estimate() else {
            self.shadow_seen_s = T::ZERO;
            return;
        };
        let alt = [
            stored_nt[0] - e.offset_nt[0],
            stored_nt[1] - e.offset_nt[1],
            stored_nt[2] - e.offset_nt[2],
        ];
        let mag = (alt[0] * alt[0] + alt[1] * alt[1] + alt[2] * alt[2]).sqrt();
        let g = tuning.field_gate(rate_rad_s.is_some());
        let mut misfit = !((mag - r.field_nt).abs() < g * r.field_sigma_nt);
        if let (Some(t), Some(s)) = (tilt, sin_incl) {
            let c = cos_of_sin(s);
            let dip_z = (t.level(alt)[2] / mag.max(r.field_sigma_nt) - s) / c * r.field_nt
                / r.field_sigma_nt;
            misfit |= !(dip_z.abs() < g);
        }
        let a = (dt / tuning.misfit_tau_s).min(T::ONE);
        self.shadow_misfit += a * (if misfit { T::ONE } else { T::ZERO } - self.shadow_misfit);
        self.shadow_seen_s += dt;
        if self.shadow_seen_s >= T::from_f64(3.0) * tuning.misfit_tau_s
            && self.shadow_misfit < T::from_f64(SHADOW_MISFIT_MAX)
        {
            self.try_apply(&e, sin_incl);
        }
    }

    /// The estimate's heading σ, radians, if it passes the guard: its
    /// uncertainty moves the heading by no more than the stored
    /// calibration's σ does, and the offset model explains the misfit.
    fn guard(&self, e: &HardIron<T>, sin_incl: Option<T>) -> Option<T> {
        let r = *self.monitor.reference();
        let cos_incl = sin_incl.map_or(T::ONE, cos_of_sin);
        let hh = (r.field_nt * cos_incl).max(r.noise_nt);
        let sigma_max = e.sigma_nt[0].max(e.sigma_nt[1]).max(e.sigma_nt[2]);
        let stored_sigma_rad = ((r.noise_nt / hh) * (r.noise_nt / hh)
            + r.heading_sigma_rad * r.heading_sigma_rad)
            .sqrt();
        let sigma_rad = sigma_max / hh;
        let o = e.offset_nt;
        let plausible = (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt()
            <= T::from_f64(MAX_OFFSET_REL) * r.field_nt;
        (plausible && sigma_rad <= stored_sigma_rad && e.residual_rms_z <= T::from_f64(2.0))
            .then_some(sigma_rad)
    }

    /// Puts the estimate in use.
    fn use_estimate(&mut self, e: &HardIron<T>, sigma_rad: T) {
        self.applied_nt = e.offset_nt;
        self.applied_sigma_rad = sigma_rad;
    }

    /// Applies the estimate if it passes the guard.
    fn try_apply(&mut self, e: &HardIron<T>, sin_incl: Option<T>) {
        let Some(sigma_rad) = self.guard(e, sin_incl) else {
            return;
        };
        self.use_estimate(e, sigma_rad);
        self.health.hard_iron_applied = self.health.hard_iron_applied.wrapping_add(1);
        self.applied = true;
        self.confirm.open = false;
        self.confirm.confirmed = false;
        self.stored.open = false;
        self.stored_agree_s = T::ZERO;
        // The stored field was judged invalid: its misfit starts whole.
        self.stored_misfit = T::ONE;
        self.stored_seen_s = T::ZERO;
        // The monitor goes on with the corrected field's misfit fraction;
        // that field is on trial, so the gyro vouches for none of its misfits.
        self.monitor.switch_field(self.shadow_misfit);
        self.monitor.set_gyro_vouches(false);
        self.shadow_seen_s = T::ZERO;
    }

    /// While the estimate is applied, on a sample judged `ok`: the
    /// estimator goes on (every `alt_every`-th such sample), and the offset
    /// in use follows its estimate whenever that passes the guard's σ and
    /// residual tests (the monitor judges the corrected field meanwhile, and
    /// withdraws it if it misfits).
    #[inline(never)]
    fn refine_applied(
        &mut self,
        stored_nt: Vec3<T>,
        tilt: Option<&Tilt<T>>,
        rate_rad_s: Option<Vec3<T>>,
        dt: T,
    ) {
        if self
            .feed_estimator(stored_nt, tilt, rate_rad_s, dt)
            .is_none()
        {
            return;
        }
        let sin_incl = self.monitor.sin_inclination();
        if let Some(e) = self.estimator.estimate() {
            if let Some(sigma_rad) = self.guard(&e, sin_incl) {
                self.use_estimate(&e, sigma_rad);
            }
        }
    }

    /// The corrected field misfits for a sustained time: the estimate is
    /// withdrawn and the stored calibration taken back as invalid (its
    /// fit was not checked while the estimate was applied), and a new
    /// estimate starts.
    #[inline(never)]
    fn withdraw(&mut self) {
        self.applied = false;
        self.monitor.switch_field(T::ONE);
        self.monitor.set_gyro_vouches(true);
        self.restart_estimate();
    }

    /// Counts the sample; `dt` already checked ([`positive_dt`]).
    #[inline(always)]
    fn count(&mut self, state: IntegrityState, dt: T) {
        let h = &mut self.health;
        if let Some(c) = h.samples_per_state.get_mut(state.index()) {
            *c = c.saturating_add(1);
        }
        if state.is_disturbance() {
            h.current_disturbance_s += dt;
            h.longest_disturbance_s = h.longest_disturbance_s.max(h.current_disturbance_s);
        } else {
            h.current_disturbance_s = T::ZERO;
        }
    }
}

#[cfg(test)]
mod tests;
