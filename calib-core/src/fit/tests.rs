use super::*;
use crate::linalg::{mul_mat, transpose};
use proptest::prelude::*;

use crate::conformance::SplitMix64;

/// raw = D·h + b + noise, h uniform on the sphere of radius `field`.
pub(crate) fn tumble(d: &Mat3<f64>, b: [f64; 3], field: f64, noise: f64, n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let u = rng.direction();
            let h = [u[0] * field, u[1] * field, u[2] * field];
            let r = mul_mat_vec(d, h);
            [0, 1, 2].map(|k| r[k] + b[k] + noise * rng.gauss())
        })
        .collect()
}

const F: f64 = 50_000.0;

/// A steel-hull-like symmetric distortion (raw per nT).
fn soft_iron() -> Mat3<f64> {
    [[0.21, 0.012, -0.006], [0.012, 0.17, 0.009], [-0.006, 0.009, 0.25]]
}

fn rel_err(a: &Mat3<f64>, b: &Mat3<f64>) -> f64 {
    let num: f64 = a.iter().flatten().zip(b.iter().flatten()).map(|(x, y)| (x - y) * (x - y)).sum();
    let den: f64 = b.iter().flatten().map(|y| y * y).sum();
    (num / den).sqrt()
}

#[test]
fn full_fit_recovers_bias_and_matrix_exactly_without_noise() {
    let d = soft_iron();
    let b = [-1865.0, 1385.0, -903.0];
    let data = tumble(&d, b, F, 0.0, 500, 1);
    let cal = fit_batch::<Full, 9, f64>(&data, F).unwrap();
    let truth = crate::linalg::inverse3(&d).unwrap(); // symmetric, so the symmetric solution is D⁻¹
    for k in 0..3 {
        assert!((cal.bias[k] - b[k]).abs() < 1e-9 * 2000.0, "{:?}", cal.bias);
    }
    assert!(rel_err(&cal.matrix, &truth) < 1e-9, "{:?}", cal.matrix);
}

#[test]
fn axis_fit_recovers_the_papers_coefficients_exactly_without_noise() {
    // Paper 000 Table 2 "whole run": b = (−1865, 1385, −903), s = (0.19556, 0.09001, 0.16142).
    let s = [0.19556, 0.09001, 0.16142];
    let d = [[s[0], 0.0, 0.0], [0.0, s[1], 0.0], [0.0, 0.0, s[2]]];
    let b = [-1865.0, 1385.0, -903.0];
    let data = tumble(&d, b, 48_730.0, 0.0, 400, 2);
    let cal = fit_batch::<Axis, 6, f64>(&data, 48_730.0).unwrap();
    for k in 0..3 {
        assert!((cal.bias[k] - b[k]).abs() < 1e-9 * 2000.0);
        assert!((1.0 / cal.matrix[k][k] - s[k]).abs() < 1e-9 * s[k]);
    }
    assert_eq!(cal.matrix[0][1], 0.0);
}

#[test]
fn sphere_fit_recovers_bias_and_gain_exactly_without_noise() {
    let d = [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]];
    let b = [120.0, -40.0, 300.0];
    let data = tumble(&d, b, F, 0.0, 100, 3);
    let cal = fit_batch::<Sphere, 4, f64>(&data, F).unwrap();
    for k in 0..3 {
        assert!((cal.bias[k] - b[k]).abs() < 1e-9 * 300.0);
        assert!((cal.matrix[k][k] - 5.0).abs() < 1e-9 * 5.0);
    }
}

#[test]
fn noisy_full_fit_is_within_statistical_bounds() {
    // 2 nT-equivalent noise (0.4 raw at ~0.2 raw/nT) over 3000 samples.
    let d = soft_iron();
    let b = [500.0, -250.0, 80.0];
    let data = tumble(&d, b, F, 0.4, 3000, 4);
    let cal = fit_batch::<Full, 9, f64>(&data, F).unwrap();
    let truth = crate::linalg::inverse3(&d).unwrap();
    for k in 0..3 {
        // Bias error in nT: raw error times the gain (~5 nT/raw).
        assert!((cal.bias[k] - b[k]).abs() * 5.0 < 2.0, "{:?}", cal.bias);
    }
    assert!(rel_err(&cal.matrix, &truth) < 2e-4);
}

#[test]
fn recursive_fits_agree_with_batch() {
    let d = soft_iron();
    let b = [500.0, -250.0, 80.0];
    let data = tumble(&d, b, F, 0.4, 2000, 5);
    let norm = Normalization { centre: [0.0; 3], scale: 10_000.0 };
    let mut rls = FullRls::<f64>::new(norm);
    for s in &data {
        rls.push(*s);
    }
    let a = rls.estimate(F).unwrap();
    let c = fit_batch::<Full, 9, f64>(&data, F).unwrap();
    for k in 0..3 {
        assert!((a.bias[k] - c.bias[k]).abs() < 1e-6);
    }
    assert!(rel_err(&a.matrix, &c.matrix) < 1e-9);
}

#[test]
fn f32_recursive_full_fit_matches_f64_batch_at_the_issue_tolerance() {
    // 50 000 nT, 0.4 nT noise, 2000 samples of a full tumble.
    let d = crate::linalg::identity3::<f64>();
    let b = [1200.0, -800.0, 350.0];
    let data = tumble(&d, b, F, 0.4, 2000, 6);
    let reference = fit_batch::<Full, 9, f64>(&data, F).unwrap();
    let norm = Normalization { centre: [0.0f32; 3], scale: 50_000.0 };
    let mut rls = FullRls::<f32>::new(norm);
    for s in &data {
        rls.push(s.map(|v| v as f32));
    }
    let est = rls.estimate(F as f32).unwrap();
    for k in 0..3 {
        assert!((f64::from(est.bias[k]) - reference.bias[k]).abs() < 0.5, "{:?} vs {:?}", est.bias, reference.bias);
    }
    let m32 = est.matrix.map(|r| r.map(f64::from));
    assert!(rel_err(&m32, &reference.matrix) < 1e-4, "{}", rel_err(&m32, &reference.matrix));
}

#[test]
fn rotation_about_one_axis_only_is_refused() {
    // Yaw only, level: z never changes — the paper's Table 2 case 1.
    let d = soft_iron();
    let b = [100.0, 50.0, -30.0];
    let (h, v) = (27_000.0, 40_000.0);
    let data: Vec<[f64; 3]> = (0..360)
        .map(|k| {
            let psi = (k as f64).to_radians();
            let r = mul_mat_vec(&d, [h * psi.cos(), -h * psi.sin(), v]);
            [r[0] + b[0], r[1] + b[1], r[2] + b[2]]
        })
        .collect();
    for r in [
        fit_batch::<Full, 9, f64>(&data, 48_000.0).map(|_| ()),
        fit_batch::<Axis, 6, f64>(&data, 48_000.0).map(|_| ()),
    ] {
        assert!(
            matches!(r, Err(FitError::InsufficientExcitation { .. } | FitError::ImpossibleScale { .. } | FitError::NotAnEllipsoid)),
            "{r:?}"
        );
    }
}

#[test]
fn bad_input_gets_typed_errors() {
    let d = soft_iron();
    let mut data = tumble(&d, [0.0; 3], F, 0.0, 50, 7);
    assert_eq!(fit_batch::<Full, 9, f64>(&data[..5], F), Err(FitError::TooFewSamples { have: 5, need: 9 }));
    assert_eq!(fit_batch::<Full, 9, f64>(&data, -1.0), Err(FitError::BadReference));
    assert_eq!(fit_batch::<Full, 9, f64>(&data, f64::NAN), Err(FitError::BadReference));
    data[17][1] = f64::NAN;
    assert_eq!(fit_batch::<Full, 9, f64>(&data, F), Err(FitError::NonFinite { index: 17 }));
    assert_eq!(check_samples(&[[1.0, 2.0, 3.0]], 1, Some(3.0)), Err(FitError::Saturated { index: 0 }));
    let same = vec![[1.0, 2.0, 3.0]; 40];
    assert!(fit_batch::<Sphere, 4, f64>(&same, F).is_err());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    #[test]
    fn permuting_samples_does_not_change_the_fit(seed in 0u64..10_000, swap_seed in 0u64..10_000) {
        let data = tumble(&soft_iron(), [300.0, -100.0, 50.0], F, 0.5, 200, seed);
        let mut shuffled = data.clone();
        let mut rng = SplitMix64::new(swap_seed);
        for i in (1..shuffled.len()).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            shuffled.swap(i, j);
        }
        let a = fit_batch::<Full, 9, f64>(&data, F).unwrap();
        let b = fit_batch::<Full, 9, f64>(&shuffled, F).unwrap();
        for k in 0..3 {
            prop_assert!((a.bias[k] - b.bias[k]).abs() < 1e-7);
        }
        prop_assert!(rel_err(&a.matrix, &b.matrix) < 1e-10);
    }

    #[test]
    fn changing_units_scales_the_coefficients(seed in 0u64..10_000, k in 0.001..1000.0f64) {
        let data = tumble(&soft_iron(), [300.0, -100.0, 50.0], F, 0.5, 200, seed);
        let scaled: Vec<[f64; 3]> = data.iter().map(|v| v.map(|x| x * k)).collect();
        let a = fit_batch::<Full, 9, f64>(&data, F).unwrap();
        let b = fit_batch::<Full, 9, f64>(&scaled, F).unwrap();
        for i in 0..3 {
            prop_assert!((b.bias[i] - k * a.bias[i]).abs() < 1e-7 * k * 300.0);
        }
        let a_over_k = a.matrix.map(|r| r.map(|x| x / k));
        prop_assert!(rel_err(&b.matrix, &a_over_k) < 1e-9);
    }

    #[test]
    fn rotating_the_sensor_rotates_the_calibration(seed in 0u64..10_000, ang in -3.0..3.0f64, tilt in -1.5..1.5f64) {
        let data = tumble(&soft_iron(), [300.0, -100.0, 50.0], F, 0.5, 200, seed);
        let (s1, c1) = ang.sin_cos();
        let (s2, c2) = tilt.sin_cos();
        let r = mul_mat(&[[c1, -s1, 0.0], [s1, c1, 0.0], [0.0, 0.0, 1.0]], &[[1.0, 0.0, 0.0], [0.0, c2, -s2], [0.0, s2, c2]]);
        let rotated: Vec<[f64; 3]> = data.iter().map(|v| mul_mat_vec(&r, *v)).collect();
        let a = fit_batch::<Full, 9, f64>(&data, F).unwrap();
        let b = fit_batch::<Full, 9, f64>(&rotated, F).unwrap();
        let rb = mul_mat_vec(&r, a.bias);
        for i in 0..3 {
            prop_assert!((b.bias[i] - rb[i]).abs() < 1e-6);
        }
        // M' = R M Rᵀ: the same symmetric calibration seen from the rotated frame.
        let want = mul_mat(&mul_mat(&r, &a.matrix), &transpose(&r));
        prop_assert!(rel_err(&b.matrix, &want) < 1e-9);
    }
}

#[test]
fn the_papers_eq_18_arithmetic_with_its_step_1_coefficients() {
    // ALGORITHMS.md §4 check line: mean raw z 5362 with bz = −903,
    // sz = 0.16142 calibrates to (5362 + 903)/0.16142 = 38812 nT.
    let x = [
        (0.19556f64 / 0.09001).powi(2), // x1 = sx²/sy²
        (0.19556f64 / 0.16142).powi(2), // x2 = sx²/sz²
        -1865.0,
        1385.0 * (0.19556f64 / 0.09001).powi(2),
        -903.0 * (0.19556f64 / 0.16142).powi(2),
        0.0,
    ];
    // x6 from eq 14 for H = 48 730 nT.
    let h = 48_730.0;
    let mut x = x;
    x[5] = 0.19556f64.powi(2) * h * h - x[2] * x[2] - x[0] * 1385.0f64.powi(2) - x[1] * 903.0f64.powi(2);
    let s = axis_scales(&x, h).unwrap();
    assert!((s.bias[0] + 1865.0).abs() < 1e-9 && (s.bias[1] - 1385.0).abs() < 1e-9 && (s.bias[2] + 903.0).abs() < 1e-9);
    assert!((s.scale[0] - 0.19556).abs() < 1e-12 && (s.scale[1] - 0.09001).abs() < 1e-12 && (s.scale[2] - 0.16142).abs() < 1e-12);
    let cal = Axis::extract(&x, h).unwrap();
    let hz = cal.apply([0.0, 0.0, 5362.0])[2];
    assert!((hz - 38_812.0).abs() < 1.0, "{hz}");
}
