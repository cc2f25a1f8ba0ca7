//! The magnetometer in its hull: `raw = D·h + b (+ b_run while running) +
//! noise`, quantised to whole counts.

use calib_core::conformance::SplitMix64;
use calib_core::linalg::{mul_mat, mul_mat_vec, Mat3};
use calib_core::ortho::{gamma, OrthoAngles};
use serde::{Deserialize, Serialize};

/// The magnetometer in its hull.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SensorModel {
    /// Raw units per nT, including soft iron, misalignment, non-orthogonality.
    pub gain_raw_per_nt: Mat3<f64>,
    /// Hard iron, raw units.
    pub bias_raw: [f64; 3],
    /// Extra bias while thrusters and electronics run, raw units.
    pub running_bias_raw: [f64; 3],
    /// White noise per axis, nT (1σ).
    pub noise_nt: f64,
    /// AHRS roll/pitch noise, degrees (1σ).
    pub ahrs_noise_deg: f64,
    /// AHRS roll and pitch bias, degrees.
    pub ahrs_bias_deg: [f64; 2],
}

impl SensorModel {
    /// A paper-like sensor: the scale factors of paper 000's step-1 fit, mild
    /// soft iron, paper 001's non-orthogonality (scaled down), hard iron of
    /// the paper's magnitude, and thrusters that add a few hundred nT, mostly
    /// horizontal, only while running — the disturbance the paper's
    /// out-and-back correction was designed for.
    pub fn paper_like() -> Self {
        Self::with_soft_iron([[1.0, 0.01, 0.004], [0.01, 1.0, -0.003], [0.004, -0.003, 1.0]], [40.0, -30.0, 20.0])
    }

    /// A steel hull that couples the vertical channel to the horizontal ones
    /// (2 % and 1.2 %), with a running bias mostly along z: the swing test
    /// cannot see the coupling, and the turnaround step it causes is not one
    /// that a change of `sz` can remove.
    pub fn hull_coupled() -> Self {
        Self::with_soft_iron([[1.0, 0.015, 0.02], [0.015, 1.0, -0.012], [0.02, -0.012, 1.0]], [12.0, -9.0, 45.0])
    }

    /// The QEMU board's vehicle, in nT at the bridges (the board's own chain
    /// gain turns them into ADC counts): a steel hull's soft iron and
    /// non-orthogonality near identity, hard iron of a few thousand nT and a
    /// running-only bias of a few hundred. Fed through USART2 by the demo.
    pub fn board_like() -> Self {
        let soft_iron = [[1.04, 0.02, 0.012], [0.02, 0.95, -0.01], [0.012, -0.01, 1.02]];
        let nonorth = gamma(&OrthoAngles { theta_rad: 0.01, phi_rad: 0.015, psi_rad: -0.008, k_xz: 0.99, k_yz: 1.01 });
        Self {
            gain_raw_per_nt: mul_mat(&nonorth, &soft_iron),
            bias_raw: [1500.0, -2300.0, 800.0],
            running_bias_raw: [220.0, -160.0, 120.0],
            noise_nt: 3.0,
            ahrs_noise_deg: 0.15,
            ahrs_bias_deg: [0.05, -0.05],
        }
    }

    fn with_soft_iron(soft_iron: Mat3<f64>, running_bias: [f64; 3]) -> Self {
        let scale = [[0.19556, 0.0, 0.0], [0.0, 0.09001, 0.0], [0.0, 0.0, 0.16142]];
        let nonorth = gamma(&OrthoAngles { theta_rad: 0.01, phi_rad: 0.015, psi_rad: -0.008, k_xz: 1.0, k_yz: 1.0 });
        Self {
            gain_raw_per_nt: mul_mat(&mul_mat(&scale, &nonorth), &soft_iron),
            bias_raw: [-1865.0, 1385.0, -903.0],
            running_bias_raw: running_bias,
            noise_nt: 3.0,
            ahrs_noise_deg: 0.15,
            ahrs_bias_deg: [0.05, -0.05],
        }
    }

    /// Raw counts with the body-fixed sources' field at the sensor (nT,
    /// body: thrusters, a payload) added to the outside field, and the
    /// bridge gain of each axis applied to everything the bridge sees
    /// (outside field, hull's hard iron, running bias, body-fixed sources);
    /// the electronics' noise is not scaled. With no body-fixed field and
    /// unit gains, the simulator's original sensor. Draws three normal
    /// deviates from `rng` (x, y, z).
    pub(super) fn measure_env(&self, h_body: [f64; 3], body_fixed_nt: [f64; 3], bridge_gain: [f64; 3], running: bool, rng: &mut SplitMix64) -> [f64; 3] {
        let h = [h_body[0] + body_fixed_nt[0], h_body[1] + body_fixed_nt[1], h_body[2] + body_fixed_nt[2]];
        let r = mul_mat_vec(&self.gain_raw_per_nt, h);
        let mut out = [0.0; 3];
        for k in 0..3 {
            let gain = self.gain_raw_per_nt[k][k].abs();
            let b = self.bias_raw[k] + if running { self.running_bias_raw[k] } else { 0.0 };
            out[k] = (bridge_gain[k] * (r[k] + b) + self.noise_nt * gain * rng.gauss()).round();
        }
        out
    }
}
