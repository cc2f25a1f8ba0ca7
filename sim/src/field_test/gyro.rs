//! A MEMS gyro mounted with the magnetometer: the body rates of the true
//! attitude history, a misaligned triad, bias and noise.

use calib_core::linalg::mul_mat_vec;
use serde::{Deserialize, Serialize};

use super::noise::gyro_generator;
use super::Simulation;

/// A MEMS gyro mounted with the magnetometer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GyroModel {
    /// Constant bias, rad/s.
    pub bias_rad_s: [f64; 3],
    /// White noise per axis and sample, rad/s (1σ).
    pub noise_rad_s: f64,
    /// Small rotation of the gyro triad against the magnetometer's axes,
    /// rad (about x, y, z).
    pub misalignment_rad: [f64; 3],
}

impl GyroModel {
    /// A consumer MEMS gyro after its factory calibration: 0.2–0.3 °/s of
    /// bias, 0.1 °/s of noise, axes within 0.2° of the magnetometer's.
    pub fn mems() -> Self {
        Self { bias_rad_s: [0.004, -0.003, 0.005], noise_rad_s: 0.002, misalignment_rad: [0.003, -0.002, 0.004] }
    }
}

/// Body rates from Euler angles and their rates (rad, rad/s), Z-Y-X:
/// `p = φ̇ − ψ̇ sin θ`, `q = θ̇ cos φ + ψ̇ sin φ cos θ`,
/// `r = −θ̇ sin φ + ψ̇ cos φ cos θ`.
fn body_rates(roll: f64, pitch: f64, roll_dot: f64, pitch_dot: f64, yaw_dot: f64) -> [f64; 3] {
    [
        roll_dot - yaw_dot * pitch.sin(),
        pitch_dot * roll.cos() + yaw_dot * roll.sin() * pitch.cos(),
        -pitch_dot * roll.sin() + yaw_dot * roll.cos() * pitch.cos(),
    ]
}

impl Simulation {
    /// Adds `gx, gy, gz`: the body rates of the true attitude history
    /// (Euler-angle rates by central differences over the sample interval,
    /// turned into body rates by the Z-Y-X kinematics
    /// `p = φ̇ − ψ̇ sin θ`, `q = θ̇ cos φ + ψ̇ sin φ cos θ`,
    /// `r = −θ̇ sin φ + ψ̇ cos φ cos θ`), through the misaligned triad, plus
    /// bias and noise (a generator of its own, so the magnetometer's noise
    /// is the same with and without the gyro).
    pub fn with_gyro(mut self, gyro: &GyroModel, seed: u64) -> Self {
        let mut rng = gyro_generator(seed);
        let t = self.recording.t_s.clone().unwrap_or_default();
        let n = t.len().min(self.true_heading_deg.len());
        let [mx, my, mz] = gyro.misalignment_rad;
        let misalign = [[1.0, -mz, my], [mz, 1.0, -mx], [-my, mx, 1.0]];
        let (mut gx, mut gy, mut gz) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for i in 0..n {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let span = t[b] - t[a];
            let rate = |v: &[f64], wrap: bool| {
                let mut d = v[b] - v[a];
                if wrap {
                    d = host_tools::data::wrap180(d);
                }
                if span > 0.0 { d.to_radians() / span } else { 0.0 }
            };
            let (roll_dot, pitch_dot, yaw_dot) = (rate(&self.true_roll_deg, false), rate(&self.true_pitch_deg, false), rate(&self.true_heading_deg, true));
            let body = body_rates(self.true_roll_deg[i].to_radians(), self.true_pitch_deg[i].to_radians(), roll_dot, pitch_dot, yaw_dot);
            let seen = mul_mat_vec(&misalign, body);
            gx.push(seen[0] + gyro.bias_rad_s[0] + gyro.noise_rad_s * rng.gauss());
            gy.push(seen[1] + gyro.bias_rad_s[1] + gyro.noise_rad_s * rng.gauss());
            gz.push(seen[2] + gyro.bias_rad_s[2] + gyro.noise_rad_s * rng.gauss());
        }
        self.recording.gx_rad_s = Some(gx);
        self.recording.gy_rad_s = Some(gy);
        self.recording.gz_rad_s = Some(gz);
        self
    }
}
