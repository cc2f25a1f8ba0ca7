//! A vehicle that cannot tumble, on real data: BROAD trial 05
//! (`tests/data/broad-05`, CC-BY-4.0): real motion with |roll|, |pitch| ≤
//! 25°, real magnetometer noise and gyro, a known synthetic hard and soft
//! iron, and the optical motion-capture heading on the validation part.
//! The expected values are the data's own: the truth JSON and the optical
//! heading; the floor (2.22° with the true calibration) is the README's.

use std::path::PathBuf;

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::heading::magnetic_heading_rad;
use host_tools::compute::{fit_recording, heading_rms_after_offset_deg, ComputeError, FitOptions};
use host_tools::data::Recording;

/// The lab's mean intensity on the calibration part (the data's README).
const LAB_FIELD_NT: f64 = 44_204.0;

fn data(rel: &str) -> PathBuf {
    super::data("broad-05").join(rel)
}

#[derive(serde::Deserialize)]
struct Truth {
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
}

fn truth() -> FieldCal<f64> {
    let t: Truth = serde_json::from_str(&std::fs::read_to_string(data("05.truth.json")).unwrap()).unwrap();
    FieldCal { bias: t.bias, matrix: t.matrix }
}

/// The optical heading of each validation row (its own column, which the
/// product's recording reader does not know).
fn optical_heading_deg() -> Vec<f64> {
    let text = std::fs::read_to_string(data("05_validate.csv")).unwrap();
    let mut lines = text.lines();
    let col = lines.next().unwrap().split(',').position(|h| h == "truth_heading_deg").unwrap();
    lines.map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect()
}

/// Heading RMS on the validation part after removing the best constant
/// offset (as a declination would), degrees — as the data's README says.
fn validation_heading_rms_deg(cal: &FieldCal<f64>) -> f64 {
    let rec = Recording::read(&data("05_validate.csv")).unwrap();
    let optical = optical_heading_deg();
    let (roll, pitch) = (rec.roll_deg.unwrap(), rec.pitch_deg.unwrap());
    let headings = (0..rec.mag.len()).map(|i| magnetic_heading_rad(cal.apply(rec.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
    let (rms, _) = heading_rms_after_offset_deg(headings.zip(optical));
    assert_eq!(rms.samples, 990);
    rms.rms
}

fn opts(model: ModelKind) -> FitOptions {
    FitOptions { model, field_nt: LAB_FIELD_NT, saturation: None, allow_weak: false, gyro_lag: host_tools::compute::GyroLag::Given(0.0), reference: None }
}

#[test]
fn the_true_calibration_gives_the_floor_the_data_publish() {
    // The README: 2.22° with 05.truth.json. Checks this file's evaluation.
    let floor = validation_heading_rms_deg(&truth());
    assert!((floor - 2.22).abs() < 0.01, "{floor}");
}

#[test]
fn the_gyro_aided_fit_reaches_the_floor_from_the_calibration_part_alone() {
    let rec = Recording::read(&data("05_calib.csv")).unwrap();
    let doc = fit_recording(&rec, &opts(ModelKind::Gyro)).unwrap();
    let cal = doc.field_cal();
    let hdg = validation_heading_rms_deg(&cal);
    let t = truth();
    let bias_err: Vec<f64> = (0..3).map(|k| cal.bias[k] - t.bias[k]).collect();
    // Matrix error relative to the truth, after the common scale (which the
    // reference intensity sets, not the data).
    let scale = (0..3).map(|k| t.matrix[k][k]).sum::<f64>() / (0..3).map(|k| cal.matrix[k][k]).sum::<f64>();
    let mut matrix_err = 0.0f64;
    for i in 0..3 {
        for j in 0..3 {
            matrix_err = matrix_err.max((cal.matrix[i][j] * scale - t.matrix[i][j]).abs() / t.matrix[i][i]);
        }
    }
    let q = doc.quality.gyro.as_ref().unwrap();
    eprintln!(
        "broad-05 gyro-aided: heading {hdg:.2}° on validation (true calibration 2.22°); hard iron error {bias_err:.1?} counts (1σ {:.1?}); matrix error {:.1} % after scale; gyro bias {:.4?} rad/s; predicted {:.2}°",
        q.bias_sigma_raw,
        100.0 * matrix_err,
        q.gyro_bias_rad_s,
        q.predicted_heading_rms_deg
    );
    // Measured 2026-11-22: 1.67° (below the floor: the fit also absorbs some
    // of the real sensor's own residual errors); hard iron error (−9.9,
    // 4.8, −35) counts of (275, −110, 201); matrix 4.1 %. The target:
    // within 0.5° of the floor, 2.22°.
    assert!(hdg < 2.22 + 0.5, "{hdg}");
    assert!(hdg > 1.0, "better than the optical reference allows? {hdg}");
    for (k, e) in bias_err.iter().enumerate() {
        assert!(e.abs() < [25.0, 25.0, 80.0][k], "{bias_err:?}");
    }
    assert!(matrix_err < 0.08, "{matrix_err}");
    assert_eq!(doc.model, ModelKind::Gyro);
    assert!(q.kinematic_windows > 800 && q.attitude_rows == 1065, "{q:?}");
}

#[test]
fn a_cap_of_directions_is_refused_by_the_sphere_and_ellipsoid_fits() {
    // 16–19 % of the bins: the sphere fit used to accept it silently and
    // give 7.5°.
    let rec = Recording::read(&data("05_calib.csv")).unwrap();
    for model in [ModelKind::Sphere, ModelKind::Axis, ModelKind::Full] {
        let e = fit_recording(&rec, &opts(model)).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, ComputeError::Coverage { .. }), "{model:?}: {text}");
        // The recording has roll, pitch and the gyro: both models are named.
        assert!(text.contains("of field directions were visited") && text.contains("(`gyro`") && text.contains("(`attitude`"), "{text}");
    }
    // With --allow-weak the sphere still answers, and says why it is weak.
    let doc = fit_recording(&rec, &FitOptions { allow_weak: true, ..opts(ModelKind::Sphere) }).unwrap();
    let warnings: Vec<&str> = doc.quality.warnings().collect();
    assert!(warnings.iter().any(|w| w.contains("of field directions were visited")), "{warnings:?}");
    let hdg = validation_heading_rms_deg(&doc.field_cal());
    // Measured: 7.5°.
    assert!(hdg > 5.0, "{hdg}");
}

#[test]
fn the_gyro_fit_says_which_column_is_missing() {
    let rec = Recording::read(&data("05_calib.csv")).unwrap();
    let no_gyro = Recording { gz_rad_s: None, ..rec.clone() };
    let e = fit_recording(&no_gyro, &opts(ModelKind::Gyro)).unwrap_err();
    assert_eq!(e.to_string(), "the recording has no `gz` column, which this command needs");
    let deg = Recording { gx_rad_s: rec.gx_rad_s.as_ref().map(|v| v.iter().map(|w| w.to_degrees() * 10.0).collect()), ..rec.clone() };
    let e = fit_recording(&deg, &opts(ModelKind::Gyro)).unwrap_err();
    assert!(e.to_string().contains("must be in rad/s"), "{e}");
}
