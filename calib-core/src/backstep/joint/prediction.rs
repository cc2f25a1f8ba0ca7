//! The heading error the solution's covariance predicts, and what more
//! coverage (hypothetical samples) would make of it.

use super::model::{Model, B0, BR0, C0, K0, MP, MR};
use super::solve::{spd_cov, Normal};
use super::{JointSolution, HEADING_STEPS, NP};
use crate::backstep::{Leg, RunSample};
use crate::heading::Vec3;
use crate::linalg::{inverse3, mul_mat_vec};
use crate::Real;

impl<T: Real> JointSolution<T> {
    /// The raw reading, at the typical conditions of the run, of a level
    /// vehicle at `heading_rad` in the estimated local field.
    fn raw_at(&self, heading_rad: T) -> Option<Vec3<T>> {
        let p = &self.params;
        let h = self.reference_hz_nt[0] + self.local_offset_hz_nt[0];
        let z = self.reference_hz_nt[1] + self.local_offset_hz_nt[1];
        let body = [h * heading_rad.cos(), -h * heading_rad.sin(), z];
        let inv = inverse3(&Model::matrix(p))?;
        let d = mul_mat_vec(&inv, body);
        let current = if self.model.active[C0] { self.typical_current_a } else { T::ZERO };
        let dt = if self.model.active[K0] { self.typical_temp_c - self.model.ref_c } else { T::ZERO };
        let running = if self.model.active[BR0] { T::ONE } else { T::ZERO };
        Some(core::array::from_fn(|k| (T::ONE + p[K0 + k] * dt) * (d[k] + p[B0 + k] + running * p[BR0 + k] + p[C0 + k] * current)))
    }

    /// The level heading that parameters `p` give a raw reading.
    fn heading_of(&self, p: &[T; NP], raw: Vec3<T>) -> T {
        let s = RunSample {
            raw,
            roll_rad: T::ZERO,
            pitch_rad: T::ZERO,
            h_ref_nt: T::ZERO,
            z_ref_nt: T::ZERO,
            leg: Leg::Other,
            current_a: self.typical_current_a,
            temp_c: self.typical_temp_c,
            position_m: [T::ZERO; 2],
        };
        let row = self.model.run_row(&s);
        let (d, _) = self.model.corrected(p, &row);
        let h = mul_mat_vec(&Model::matrix(p), d);
        // The AHRS reads −δ̂ on a level vehicle; `p`'s δ is added to it.
        let l = crate::heading::level(h, p[MR] - self.params[MR], p[MP] - self.params[MP]);
        (-l[1]).atan2(l[0])
    }

    pub(super) fn heading_sigmas(&self, cov: &[[T; NP]; NP]) -> ([T; HEADING_STEPS], T) {
        let mut per = [T::NAN; HEADING_STEPS];
        let mut total = T::ZERO;
        for (i, out) in per.iter_mut().enumerate() {
            let psi = T::from_f64((i as f64 * 15.0).to_radians());
            let Some(raw) = self.raw_at(psi) else { return ([T::NAN; HEADING_STEPS], T::NAN) };
            *out = crate::uncertainty::angle_sigma(&self.params, cov, |p| self.heading_of(p, raw));
            total += *out * *out;
        }
        (per, (total / T::from_f64(HEADING_STEPS as f64)).sqrt())
    }

    /// The predicted heading error (per 15° and RMS, rad) if the samples
    /// `extra` were added to the data (same noise as the fit's residuals):
    /// what more coverage would buy.
    pub fn predicted_with(&self, extra: impl Iterator<Item = RunSample<T>>) -> Option<([T; HEADING_STEPS], T)> {
        let mut n = Normal::new(self.information);
        let active = self.model.active;
        for s in extra {
            let k = self.correlation_inflation.sqrt();
            self.model.run_residuals(&self.params, &s, &mut |r, w, j| n.add(&active, r, w / k, j));
        }
        n.lin.symmetrise();
        let cov = spd_cov(&n, &self.model).ok()?;
        Some(self.heading_sigmas(&cov))
    }

    /// `samples` run samples of one level 360° turn at the run's typical
    /// current and temperature, read through the estimated model (a
    /// hypothetical surface circle for [`Self::predicted_with`]).
    pub fn level_turn(&self, samples: usize) -> impl Iterator<Item = RunSample<T>> + '_ {
        let n = samples.max(1);
        (0..n).filter_map(move |i| {
            let psi = T::from_f64(i as f64 * core::f64::consts::TAU / n as f64);
            let raw = self.raw_at(psi)?;
            Some(RunSample {
                raw,
                roll_rad: -self.params[MR],
                pitch_rad: -self.params[MP],
                h_ref_nt: self.reference_hz_nt[0],
                z_ref_nt: self.reference_hz_nt[1],
                leg: Leg::Other,
                current_a: self.typical_current_a,
                temp_c: self.typical_temp_c,
                position_m: [T::ZERO; 2],
            })
        })
    }
}
