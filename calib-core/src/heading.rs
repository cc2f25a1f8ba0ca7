//! Frames and heading: ALGORITHMS.md §1 (paper 000, eqs 1–8) and the levelled
//! channels of §4 (eqs 23–24).
//!
//! Navigation frame NED; body frame x forward, y right (starboard), z down.
//! Z-Y-X Euler angles: roll φ, pitch θ, yaw ψ, with
//! `H_body = C1(φ) · C2(θ) · C3(ψ) · H_ned` (eqs 2–3).

use crate::linalg::Mat3;
use crate::Real;

/// A 3-vector `[x, y, z]`.
pub type Vec3<T> = [T; 3];

/// Wraps an angle to (−π, π].
pub fn wrap_pi<T: Real>(angle_rad: T) -> T {
    let w = angle_rad - T::TAU * ((angle_rad + T::PI) / T::TAU).floor();
    // `w` is in [−π, π); move −π to +π so the range is (−π, π].
    if w <= -T::PI { w + T::TAU } else { w }
}

/// Wraps an angle to [0, 2π) (eq 8).
pub fn wrap_two_pi<T: Real>(angle_rad: T) -> T {
    let w = angle_rad - T::TAU * (angle_rad / T::TAU).floor();
    if w >= T::TAU { w - T::TAU } else { w }
}

/// Earth field in NED from intensity, inclination (dip, positive down) and
/// declination (positive east) — eq 1.
pub fn ned_field<T: Real>(intensity_nt: T, inclination_rad: T, declination_rad: T) -> Vec3<T> {
    let h = intensity_nt * inclination_rad.cos();
    [h * declination_rad.cos(), h * declination_rad.sin(), intensity_nt * inclination_rad.sin()]
}

/// Rotates a NED vector into the body frame, `C1(φ) C2(θ) C3(ψ) v` (eqs 2–3).
pub fn ned_to_body<T: Real>(v_ned: Vec3<T>, roll_rad: T, pitch_rad: T, yaw_rad: T) -> Vec3<T> {
    let [x, y, z] = v_ned;
    // C3(ψ): yaw about down.
    let (sy, cy) = (yaw_rad.sin(), yaw_rad.cos());
    let (x, y) = (cy * x + sy * y, -sy * x + cy * y);
    // C2(θ): pitch about the new y.
    let (sp, cp) = (pitch_rad.sin(), pitch_rad.cos());
    let (x, z) = (cp * x - sp * z, sp * x + cp * z);
    // C1(φ): roll about the new x.
    let (sr, cr) = (roll_rad.sin(), roll_rad.cos());
    let (y, z) = (cr * y + sr * z, -sr * y + cr * z);
    [x, y, z]
}

/// The NED → body rotation matrix `C1(φ) C2(θ) C3(ψ)` (eqs 2–3), the
/// matrix form of [`ned_to_body`]; its transpose carries body to NED.
pub fn ned_to_body_matrix<T: Real>(roll_rad: T, pitch_rad: T, yaw_rad: T) -> Mat3<T> {
    let (sr, cr) = (roll_rad.sin(), roll_rad.cos());
    let (sp, cp) = (pitch_rad.sin(), pitch_rad.cos());
    let (sy, cy) = (yaw_rad.sin(), yaw_rad.cos());
    [
        [cp * cy, cp * sy, -sp],
        [sr * sp * cy - cr * sy, sr * sp * sy + cr * cy, sr * cp],
        [cr * sp * cy + sr * sy, cr * sp * sy - sr * cy, cr * cp],
    ]
}

/// Sines and cosines of roll and pitch, computed once per attitude update
/// so that levelling a sample needs no trigonometry (on the Cortex-M4F the
/// `f32` sine costs more than everything else in a sample).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Tilt<T> {
    /// sin φ.
    pub sin_roll: T,
    /// cos φ.
    pub cos_roll: T,
    /// sin θ.
    pub sin_pitch: T,
    /// cos θ.
    pub cos_pitch: T,
}

impl<T: Real> Tilt<T> {
    /// From roll and pitch in radians.
    pub fn new(roll_rad: T, pitch_rad: T) -> Self {
        Self { sin_roll: roll_rad.sin(), cos_roll: roll_rad.cos(), sin_pitch: pitch_rad.sin(), cos_pitch: pitch_rad.cos() }
    }

    /// The levelling matrix `C2ᵀ(θ) C1ᵀ(φ)` (eqs 6 and 23); its third row
    /// is the body-frame direction of down.
    pub fn matrix(&self) -> Mat3<T> {
        let (sr, cr, sp, cp) = (self.sin_roll, self.cos_roll, self.sin_pitch, self.cos_pitch);
        [[cp, sp * sr, sp * cr], [T::ZERO, cr, -sr], [-sp, cp * sr, cp * cr]]
    }

    /// The heading's rate from the body rates (ZYX Euler angles):
    /// `ψ̇ = (sin φ ω_y + cos φ ω_z) / cos θ`, rad/s.
    #[inline(always)]
    pub fn yaw_rate(&self, rate_rad_s: Vec3<T>) -> T {
        (self.sin_roll * rate_rad_s[1] + self.cos_roll * rate_rad_s[2]) / self.cos_pitch
    }

    /// Levels a body-frame vector, `C2ᵀ(θ) C1ᵀ(φ) v` (eqs 6 and 23).
    pub fn level(&self, v_body: Vec3<T>) -> Vec3<T> {
        let [x, y, z] = v_body;
        let (sr, cr, sp, cp) = (self.sin_roll, self.cos_roll, self.sin_pitch, self.cos_pitch);
        let z_rolled = sr * y + cr * z;
        [cp * x + sp * z_rolled, cr * y - sr * z, -sp * x + cp * z_rolled]
    }
}

/// Levels a body-frame vector with roll and pitch, `C2ᵀ(θ) C1ᵀ(φ) v`
/// (eqs 6 and 23). The result is in the heading frame: x along the vehicle's
/// horizontal heading, y to its horizontal right, z down.
pub fn level<T: Real>(v_body: Vec3<T>, roll_rad: T, pitch_rad: T) -> Vec3<T> {
    Tilt::new(roll_rad, pitch_rad).level(v_body)
}

/// Horizontal intensity of a levelled vector, `Hh = √(Hx² + Hy²)` (eq 24).
pub fn horizontal<T: Real>(levelled: Vec3<T>) -> T {
    let [x, y, _] = levelled;
    (x * x + y * y).sqrt()
}

/// Tilt-compensated magnetic heading in [0, 2π) from a calibrated body-frame
/// field and the AHRS roll and pitch (eqs 6–8): `ψ = atan2(−M2, M1)`.
///
/// Any consistent unit of field works: only the direction matters.
pub fn magnetic_heading_rad<T: Real>(field_body: Vec3<T>, roll_rad: T, pitch_rad: T) -> T {
    heading_of_levelled(level(field_body, roll_rad, pitch_rad))
}

/// The heading of a levelled vector, `atan2(−M2, M1)` in [0, 2π) (eqs 7–8).
pub fn heading_of_levelled<T: Real>(levelled: Vec3<T>) -> T {
    let [m1, m2, _] = levelled;
    wrap_two_pi((-m2).atan2(m1))
}

/// True heading in [0, 2π): magnetic heading plus declination (east positive).
pub fn true_heading_rad<T: Real>(magnetic_heading_rad: T, declination_rad: T) -> T {
    wrap_two_pi(magnetic_heading_rad + declination_rad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use core::f64::consts::PI;
    use proptest::prelude::*;

    /// Independent reference for eqs 2–3: the explicit matrices multiplied out.
    fn c_n_b(roll: f64, pitch: f64, yaw: f64) -> [[f64; 3]; 3] {
        let (sr, cr) = roll.sin_cos();
        let (sp, cp) = pitch.sin_cos();
        let (sy, cy) = yaw.sin_cos();
        let c1 = [[1.0, 0.0, 0.0], [0.0, cr, sr], [0.0, -sr, cr]];
        let c2 = [[cp, 0.0, -sp], [0.0, 1.0, 0.0], [sp, 0.0, cp]];
        let c3 = [[cy, sy, 0.0], [-sy, cy, 0.0], [0.0, 0.0, 1.0]];
        let mul = |a: [[f64; 3]; 3], b: [[f64; 3]; 3]| {
            let mut m = [[0.0; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    m[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
                }
            }
            m
        };
        mul(mul(c1, c2), c3)
    }

    #[test]
    fn the_rotation_matrices_match_the_explicit_products() {
        let (roll, pitch, yaw) = (0.3, -0.7, 2.1);
        let c = c_n_b(roll, pitch, yaw);
        let m = ned_to_body_matrix(roll, pitch, yaw);
        let l = Tilt::new(roll, pitch).matrix();
        let c12 = c_n_b(roll, pitch, 0.0);
        for i in 0..3 {
            for j in 0..3 {
                assert_abs_diff_eq!(m[i][j], c[i][j], epsilon = 1e-15);
                // Levelling is (C1 C2)ᵀ.
                assert_abs_diff_eq!(l[i][j], c12[j][i], epsilon = 1e-15);
            }
        }
    }

    #[test]
    fn wrapping_ranges() {
        assert_abs_diff_eq!(wrap_pi(3.0 * PI), PI, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap_pi(-PI), PI, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap_pi(-3.5 * PI), 0.5 * PI, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap_two_pi(-0.25 * PI), 1.75 * PI, epsilon = 1e-12);
        assert_abs_diff_eq!(wrap_two_pi(4.0 * PI + 0.1), 0.1, epsilon = 1e-12);
        assert!(wrap_two_pi(-1e-20_f64) < 2.0 * PI);
    }

    #[test]
    fn level_flat_vehicle_heading_north_reads_the_horizontal_field_on_x() {
        // Paper's site (eq 25): Hh = 27473, Hz = 40247 nT.
        let h = ned_field(48730.0, (40247.0f64).atan2(27473.0), 0.0);
        assert_abs_diff_eq!(h[0], 27473.0, epsilon = 1.0);
        assert_abs_diff_eq!(h[2], 40247.0, epsilon = 1.0);
        let b = ned_to_body(h, 0.0, 0.0, 0.0);
        assert_abs_diff_eq!(magnetic_heading_rad(b, 0.0, 0.0), 0.0, epsilon = 1e-12);
        // Facing east, the field comes from the left: negative y.
        let b = ned_to_body(h, 0.0, 0.0, PI / 2.0);
        assert!(b[1] < -27000.0);
        assert_abs_diff_eq!(magnetic_heading_rad(b, 0.0, 0.0), PI / 2.0, epsilon = 1e-12);
    }

    proptest! {
        #[test]
        fn rotation_matches_the_explicit_matrices(
            roll in -PI..PI, pitch in -1.5..1.5f64, yaw in -PI..PI,
            v in prop::array::uniform3(-6e4..6e4f64)
        ) {
            let m = c_n_b(roll, pitch, yaw);
            let got = ned_to_body(v, roll, pitch, yaw);
            for i in 0..3 {
                let want: f64 = (0..3).map(|k| m[i][k] * v[k]).sum();
                prop_assert!((got[i] - want).abs() < 1e-7);
            }
        }

        #[test]
        fn heading_inverts_the_attitude(
            roll in -1.2..1.2f64, pitch in -1.2..1.2f64, yaw in -PI..PI,
            dip in -1.4..1.4f64, intensity in 2e4..7e4f64
        ) {
            let b = ned_to_body(ned_field(intensity, dip, 0.0), roll, pitch, yaw);
            let psi = magnetic_heading_rad(b, roll, pitch);
            prop_assert!((0.0..2.0 * PI).contains(&psi));
            prop_assert!(wrap_pi(psi - yaw).abs() < 1e-9);
            // Levelling recovers the horizontal and vertical channels (eqs 22–24).
            let l = level(b, roll, pitch);
            prop_assert!((horizontal(l) - intensity * dip.cos()).abs() < 1e-6);
            prop_assert!((l[2] - intensity * dip.sin()).abs() < 1e-6);
        }

        #[test]
        fn f32_heading_tracks_f64_to_a_hundredth_of_a_degree(
            roll in -1.0..1.0f64, pitch in -1.0..1.0f64, yaw in -PI..PI, dip in -1.3..1.3f64
        ) {
            let b = ned_to_body(ned_field(5e4, dip, 0.0), roll, pitch, yaw);
            let b32 = [b[0] as f32, b[1] as f32, b[2] as f32];
            let h32 = magnetic_heading_rad(b32, roll as f32, pitch as f32) as f64;
            let h64 = magnetic_heading_rad(b, roll, pitch);
            prop_assert!(wrap_pi(h32 - h64).abs() < 1e-2_f64.to_radians());
        }
    }
}
