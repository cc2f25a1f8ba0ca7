//! The model of the joint problem: the parameters' layout, a sample's
//! residuals and their Jacobians.
//!
//! The parameter vector (`NP` = 26 slots; a held term keeps its slots, at
//! its neutral value):
//!
//! | Slots | Constant | Term | Unit |
//! |---|---|---|---|
//! | 0–8 | [`M0`] | Matrix `M`, row major | nT per count |
//! | 9–11 | [`B0`] | Resting bias `b` | counts |
//! | 12–14 | [`BR0`] | Running-only bias `b_run` (when the current term is not estimated) | counts |
//! | 15–17 | [`C0`] | Per-ampere vector `c` | counts per A |
//! | 18–20 | [`K0`] | Per-axis gain change `k` | per °C |
//! | 21 | [`DI`] | Local inclination's offset `δI` to the reference's | rad |
//! | 22 | [`MR`] | AHRS roll misalignment | rad |
//! | 23 | [`MP`] | AHRS pitch misalignment | rad |
//! | 24 | [`GH`] | Local field's gradient along the track, `∂H/∂s` | nT/m |
//! | 25 | [`GZ`] | Local field's gradient along the track, `∂Z/∂s` | nT/m |

use super::{SwingSample, NP};
use crate::backstep::{level_matrix, RunSample};
use crate::heading::Vec3;
use crate::linalg::{mul_mat_vec, Mat3};
use crate::Real;

/// First of the matrix's 9 entries (row major), nT per count.
pub(super) const M0: usize = 0;
/// First of the resting bias's 3 components, counts.
pub(super) const B0: usize = 9;
/// First of the running-only bias's 3 components, counts.
pub(super) const BR0: usize = 12;
/// First of the per-ampere vector's 3 components, counts per A.
pub(super) const C0: usize = 15;
/// First of the 3 per-axis gain changes, per °C.
pub(super) const K0: usize = 18;
/// The local inclination's offset to the reference's, rad.
pub(super) const DI: usize = 21;
/// The AHRS roll misalignment, rad.
pub(super) const MR: usize = 22;
/// The AHRS pitch misalignment, rad.
pub(super) const MP: usize = 23;
/// The local field's gradient along the track: `∂H/∂s`, `∂Z/∂s`, nT/m.
pub(super) const GH: usize = 24;
/// See [`GH`].
pub(super) const GZ: usize = 25;

/// Which terms are in, and the conditions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Model<T> {
    pub(super) active: [bool; NP],
    pub(super) ref_c: T,
    pub(super) w_run: T,
    pub(super) w_swing: T,
    pub(super) swing_field_nt: T,
    /// The track's direction (north, east; unit).
    pub(super) track: [T; 2],
}

/// What a residual looks at, and its context.
pub(super) struct Row<T> {
    raw: Vec3<T>,
    current_a: T,
    dt_c: T,
    running: bool,
}

impl<T: Real> Model<T> {
    pub(super) fn matrix(p: &[T; NP]) -> Mat3<T> {
        [[p[0], p[1], p[2]], [p[3], p[4], p[5]], [p[6], p[7], p[8]]]
    }

    /// `d` of the model and the gain factors.
    pub(super) fn corrected(&self, p: &[T; NP], row: &Row<T>) -> (Vec3<T>, Vec3<T>) {
        let mut d = [T::ZERO; 3];
        let mut g = [T::ONE; 3];
        for k in 0..3 {
            g[k] = T::ONE + p[K0 + k] * row.dt_c;
            d[k] = row.raw[k] / g[k] - p[B0 + k] - p[C0 + k] * row.current_a;
            if row.running {
                d[k] -= p[BR0 + k];
            }
        }
        (d, g)
    }

    /// The Jacobian row of a residual that depends on `h = M d` through `v·h`.
    fn jacobian(&self, p: &[T; NP], row: &Row<T>, d: Vec3<T>, g: Vec3<T>, v: Vec3<T>) -> [T; NP] {
        let m = Self::matrix(p);
        let mut j = [T::ZERO; NP];
        for i in 0..3 {
            for k in 0..3 {
                j[M0 + 3 * i + k] = v[i] * d[k];
            }
        }
        for k in 0..3 {
            let gk = v[0] * m[0][k] + v[1] * m[1][k] + v[2] * m[2][k];
            j[B0 + k] = -gk;
            if row.running {
                j[BR0 + k] = -gk;
            }
            j[C0 + k] = -gk * row.current_a;
            j[K0 + k] = -gk * row.raw[k] * row.dt_c / (g[k] * g[k]);
        }
        j
    }

    pub(super) fn run_row(&self, s: &RunSample<T>) -> Row<T> {
        let current_a = if self.active[C0] { s.current_a } else { T::ZERO };
        let dt_c = if self.active[K0] && s.temp_c.is_finite() { s.temp_c - self.ref_c } else { T::ZERO };
        Row { raw: s.raw, current_a, dt_c, running: self.active[BR0] }
    }

    fn swing_row(&self, s: &SwingSample<T>) -> Row<T> {
        let current_a = if self.active[C0] && s.current_a.is_finite() { s.current_a } else { T::ZERO };
        let dt_c = if self.active[K0] && s.temp_c.is_finite() { s.temp_c - self.ref_c } else { T::ZERO };
        Row { raw: s.raw, current_a, dt_c, running: false }
    }

    /// A sample's distance from the site along the track, m (0 where its
    /// position is unknown: the site).
    fn along_track_m(&self, s: &RunSample<T>) -> T {
        let [n, e] = s.position_m;
        if n.is_finite() && e.is_finite() {
            n * self.track[0] + e * self.track[1]
        } else {
            T::ZERO
        }
    }

    /// Calls `out(residual, weight, jacobian)` for each residual of a run sample.
    pub(super) fn run_residuals(&self, p: &[T; NP], s: &RunSample<T>, out: &mut impl FnMut(T, T, &[T; NP])) {
        if self.active[C0] && !s.current_a.is_finite() {
            return;
        }
        let row = self.run_row(s);
        let (d, g) = self.corrected(p, &row);
        let m = Self::matrix(p);
        let h = mul_mat_vec(&m, d);
        let (roll, pitch) = (s.roll_rad + p[MR], s.pitch_rad + p[MP]);
        let lm = level_matrix(roll, pitch);
        let l = mul_mat_vec(&lm, h);
        let (sr, cr, sp, cp) = (roll.sin(), roll.cos(), pitch.sin(), pitch.cos());
        let z = T::ZERO;
        let dl_dr: Mat3<T> = [[z, sp * cr, -sp * sr], [z, -sr, -cr], [z, cp * cr, -cp * sr]];
        let dl_dp: Mat3<T> = [[-sp, cp * sr, cp * cr], [z, z, z], [-cp, -sp * sr, -sp * cr]];
        let dot = |a: &Vec3<T>, b: &Vec3<T>| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        // The local field: the reference turned by δI in the vertical plane
        // of the magnetic meridian, its intensity kept.
        let (si, ci) = (p[DI].sin(), p[DI].cos());
        let (h_loc, z_loc) = (s.h_ref_nt * ci - s.z_ref_nt * si, s.z_ref_nt * ci + s.h_ref_nt * si);
        // Plus the linear gradient from the site to where the sample was,
        // along the track.
        let along_m = if self.active[GH] { self.along_track_m(s) } else { T::ZERO };
        let (h_grad, z_grad) = (p[GH] * along_m, p[GZ] * along_m);
        // Vertical: l_z − Z_local.
        let mut j = self.jacobian(p, &row, d, g, lm[2]);
        j[DI] = -h_loc;
        j[MR] = dot(&dl_dr[2], &h);
        j[MP] = dot(&dl_dp[2], &h);
        j[GZ] = -along_m;
        out(l[2] - z_loc - z_grad, self.w_run, &j);
        // Horizontal intensity: |(l_x, l_y)| − H_local.
        let hh = (l[0] * l[0] + l[1] * l[1]).sqrt();
        if hh > T::ZERO {
            let (ux, uy) = (l[0] / hh, l[1] / hh);
            let v = [ux * lm[0][0] + uy * lm[1][0], ux * lm[0][1] + uy * lm[1][1], ux * lm[0][2] + uy * lm[1][2]];
            let mut j = self.jacobian(p, &row, d, g, v);
            j[DI] = z_loc;
            j[MR] = ux * dot(&dl_dr[0], &h) + uy * dot(&dl_dr[1], &h);
            j[MP] = ux * dot(&dl_dp[0], &h) + uy * dot(&dl_dp[1], &h);
            j[GH] = -along_m;
            out(hh - h_loc - h_grad, self.w_run, &j);
        }
    }

    /// The magnitude residual of a swing sample.
    pub(super) fn swing_residual(&self, p: &[T; NP], s: &SwingSample<T>, out: &mut impl FnMut(T, T, &[T; NP])) {
        let row = self.swing_row(s);
        let (d, g) = self.corrected(p, &row);
        let h = mul_mat_vec(&Self::matrix(p), d);
        let mag = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        if !(mag > T::ZERO) {
            return;
        }
        let j = self.jacobian(p, &row, d, g, [h[0] / mag, h[1] / mag, h[2] / mag]);
        out(mag - self.swing_field_nt, self.w_swing, &j);
    }
}
