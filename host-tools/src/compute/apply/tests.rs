use super::*;
use crate::doc::results::{GyroQuality, Quality};
use calib_core::cal::{FieldCal, ModelKind};
use calib_core::conformance::SplitMix64;
use calib_core::heading::magnetic_heading_rad;

/// A document whose dip and noise come from its gyro fit: `F` 50 000 nT,
/// levelled vertical 40 000 nT (sin I = 0.8, so cos I = 0.6 and the
/// horizontal field is 30 000 nT), residual `noise_nt`, the fit's own
/// predicted heading error `predicted_deg`.
fn gyro_doc(noise_nt: f64, predicted_deg: f64) -> CalDoc {
    let cal = FieldCal { bias: [0.0; 3], matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]] };
    let gyro = GyroQuality {
        kinematic_windows: 1000,
        attitude_rows: 1000,
        window_s: 4.0,
        gyro_lag_s: 0.0,
        gyro_bias_rad_s: [0.0; 3],
        vertical_nt: 40_000.0,
        residual_rms_nt: noise_nt,
        bias_sigma_raw: [0.0; 3],
        matrix_sigma_rel: [0.0; 8],
        predicted_heading_rms_deg: predicted_deg,
        weakly_determined: vec![],
    };
    let quality = Quality { gyro: Some(gyro), predicted_heading_rms_deg: Some(predicted_deg), ..Quality::default() };
    CalDoc::new(ModelKind::Full, &cal, 50_000.0, quality)
}

/// By hand: a noise of 30 000 nT × 0.1° (in radians: 52.36 nT) across a
/// 30 000 nT horizontal field is 0.1° of heading; with the calibration's
/// own 0.075° in quadrature, √(0.075² + 0.1²) = 0.125° (a 3-4-5 triangle).
/// Without a predicted error the noise alone: 0.1°.
#[test]
fn the_expected_heading_rms_is_the_hand_computed_quadrature() {
    let noise_nt = 30_000.0 * 0.1f64.to_radians();
    let e = expected_heading_rms_deg(&gyro_doc(noise_nt, 0.075)).unwrap();
    assert!((e - 0.125).abs() < 1e-12, "{e}");
    let e = expected_heading_rms_deg(&gyro_doc(noise_nt, 0.0)).unwrap();
    assert!((e - 0.1).abs() < 1e-12, "{e}");
}

/// The noise term from physics rather than the formula: a level sensor in
/// the field above (30 000 nT north, 40 000 nT down) with 52.36 nT of
/// white noise on each component shows a heading scatter of 0.1° (20 000
/// draws: the RMS known to 0.5 %; measured 0.1002°).
#[test]
fn the_noise_term_is_the_heading_scatter_noise_makes() {
    let noise_nt = 30_000.0 * 0.1f64.to_radians();
    let mut rng = SplitMix64::new(7);
    let n = 20_000;
    let sum: f64 = (0..n)
        .map(|_| {
            let h = [30_000.0 + noise_nt * rng.gauss(), noise_nt * rng.gauss(), 40_000.0 + noise_nt * rng.gauss()];
            wrap_pi(magnetic_heading_rad(h, 0.0, 0.0)).powi(2)
        })
        .sum();
    let scatter_deg = (sum / n as f64).sqrt().to_degrees();
    let e = expected_heading_rms_deg(&gyro_doc(noise_nt, 0.0)).unwrap();
    eprintln!("heading scatter {scatter_deg:.5}°, expected {e:.5}°");
    assert!((scatter_deg / e - 1.0).abs() < 0.02, "{scatter_deg} vs {e}");
}
