use super::*;
use crate::conformance::SplitMix64;
use crate::heading::{ned_field, ned_to_body};
use crate::linalg::inverse3;

fn paper_step1() -> AxisCoefficients<f64> {
    AxisCoefficients { bias: [-1865.0, 1385.0, -903.0], scale: [0.19556, 0.09001, 0.16142] }
}

#[test]
fn table_3_horizontal_scale_correction() {
    let c = scale_horizontal(&paper_step1(), 27_999.0, 27_451.0);
    // The paper prints five decimals.
    assert!((c.scale[0] - 0.19947).abs() < 1e-5, "{:?}", c.scale);
    assert!((c.scale[1] - 0.09181).abs() < 1e-5, "{:?}", c.scale);
    assert_eq!(c.scale[2], 0.16142);
}

#[test]
fn tables_4_to_6_vertical_arithmetic() {
    // Step-1 coefficients on the run's mean raw z (5362): Hzⁿ = 38 812 nT.
    let c = paper_step1();
    assert!(((5362.0 - c.bias[2]) / c.scale[2] - 38_812.0).abs() < 1.0);
    // Table 4 → 5: with sz = 0.20642, bz from the magnitude (IGRF at the run:
    // Hh = 27 450 after correction 1, F = 48 752).
    let mut c4 = scale_horizontal(&c, 27_999.0, 27_451.0);
    c4.scale[2] = 0.20642;
    assert!(((5362.0 - c4.bias[2]) / c4.scale[2] - 30_350.0).abs() < 5.0, "Table 4: Hz with the new sz");
    let c5 = z_bias_from_magnitude(&c4, 5362.0, 27_450.0, 48_752.0).unwrap();
    assert!((c5.bias[2] + 2955.0).abs() < 1.0, "Table 5 bz = {}", c5.bias[2]);
    assert!(((5362.0 - c5.bias[2]) / c5.scale[2] - 40_290.0).abs() < 2.0);
    // Table 6: sz = 0.26142 gives bz = −5171 and Hz = 40 291.
    let mut c6 = c5;
    c6.scale[2] = 0.26142;
    let c6 = z_bias_from_magnitude(&c6, 5362.0, 27_450.0, 48_752.0).unwrap();
    assert!((c6.bias[2] + 5171.0).abs() < 1.0, "Table 6 bz = {}", c6.bias[2]);
    assert!(((5362.0 - c6.bias[2]) / c6.scale[2] - 40_291.0).abs() < 2.0);
    assert_eq!(z_bias_from_magnitude(&c6, 5362.0, 50_000.0, 48_752.0), Err(BackstepError::BadReference));
}

/// A level-ish out-and-back run seen through distortion `d`, bias `b` and a
/// running-only bias `b_run`.
fn synthetic_run(d: &Mat3<f64>, b: [f64; 3], b_run: [f64; 3]) -> Vec<RunSample<f64>> {
    let (hh, hz): (f64, f64) = (27_450.0, 40_289.0);
    let f = ned_field((hh * hh + hz * hz).sqrt(), (hz / hh).atan(), 0.0);
    let mut rng = SplitMix64::new(5);
    let mut out = Vec::new();
    for k in 0..4000 {
        let back = k >= 2000;
        let course: f64 = if back { -117.0 } else { 62.0 };
        let yaw = (course + 2.0 * (k as f64 * 0.01).sin()).to_radians();
        let (roll, pitch) = ((3.0 * (k as f64 * 0.05).sin()).to_radians(), (8.0 * (k as f64 * 0.003).sin()).to_radians());
        let h = ned_to_body(f, roll, pitch, yaw);
        let r = crate::linalg::mul_mat_vec(d, h);
        let raw = [0, 1, 2].map(|i| r[i] + b[i] + b_run[i] + 0.5 * rng.gauss());
        let leg = if (1500..2000).contains(&k) { Leg::Out } else if (2000..2500).contains(&k) { Leg::Back } else { Leg::Other };
        out.push(RunSample { raw, roll_rad: roll, pitch_rad: pitch, h_ref_nt: hh, z_ref_nt: hz, leg, current_a: f64::NAN, temp_c: f64::NAN, position_m: [f64::NAN; 2] });
    }
    out
}

#[test]
fn the_joint_refinement_removes_the_step_and_matches_igrf() {
    // Truth: the paper's scales with a z-coupled soft iron, and a running bias.
    let d = [[0.19556, 0.003, 0.004], [0.003, 0.09001, -0.002], [0.0035, -0.002, 0.16142]];
    let (b, b_run) = ([-1865.0, 1385.0, -903.0], [10.0, -8.0, 40.0]);
    let run = synthetic_run(&d, b, b_run);
    // Start: the diagonal part only, resting bias (what a swing fit would give).
    let start = AxisCoefficients { bias: b, scale: [0.19556, 0.09001, 0.16142] }.field_cal();
    let s0 = run_stats(&start, &run).unwrap();
    assert!(s0.step_nt.abs() > 100.0, "the start must show a step: {s0:?}");
    let res = joint_refine(&start, &run, &[], 1.0, &JointWeights::default()).unwrap();
    let s1 = run_stats(&res.running, &run).unwrap();
    assert!(s1.step_nt.abs() < 5.0, "{s1:?}");
    assert!(s1.f_error_rms_nt < 10.0, "{s1:?}");
    assert!((s1.hz_nt - 40_289.0).abs() < 5.0 && (s1.hh_nt - 27_450.0).abs() < 5.0, "{s1:?}");
    // The truth's running calibration gives the same numbers.
    let ideal = FieldCal { bias: [b[0] + b_run[0], b[1] + b_run[1], b[2] + b_run[2]], matrix: inverse3(&d).unwrap() };
    let si = run_stats(&ideal, &run).unwrap();
    assert!((s1.f_error_rms_nt - si.f_error_rms_nt).abs() < 5.0, "{si:?} vs {s1:?}");
}

#[test]
fn each_paper_correction_does_what_the_paper_says() {
    // A horizontal running bias makes Hh differ between the legs; the
    // paper's sz correction trades it against the vertical channel.
    let d = [[0.19556, 0.0, 0.0], [0.0, 0.09001, 0.0], [0.0, 0.0, 0.16142]];
    let b = [-1865.0, 1385.0, -903.0];
    let run = synthetic_run(&d, b, [60.0, -30.0, 0.0]);
    let start = AxisCoefficients { bias: b, scale: [0.2, 0.088, 0.17] };
    let mut trace = Vec::new();
    let end = paper_backstep(&start, &run, 4, 20.0, 50.0, &mut |e| trace.push(e)).unwrap();
    let f_ref = (27_450.0f64 * 27_450.0 + 40_289.0 * 40_289.0).sqrt();
    for pair in trace.windows(2) {
        let (prev, e) = (pair[0], pair[1]);
        match e.correction {
            // Correction 1 brings the mean levelled Hh to the reference.
            1 => assert!((e.stats.hh_nt - 27_450.0).abs() < 0.005 * 27_450.0, "{e:?}"),
            // Correction 3 (eq 30): the mean raw z maps to √(F² − Hh²).
            3 => {
                let c = e.coefficients;
                let hz = (e.stats.raw_z_mean - c.bias[2]) / c.scale[2];
                let want = (f_ref * f_ref - prev.stats.hh_nt * prev.stats.hh_nt).sqrt();
                assert!((hz - want).abs() < 1e-6, "{hz} vs {want}");
            }
            _ => {}
        }
    }
    // Correction 2 never makes the step larger than correction 1 left it.
    for pair in trace.windows(2) {
        if pair[1].correction == 2 {
            assert!(pair[1].stats.step_nt.abs() <= pair[0].stats.step_nt.abs() + 1e-9);
        }
    }
    let s0 = trace[0].stats;
    let s1 = run_stats(&end.field_cal(), &run).unwrap();
    assert!(s1.step_nt.abs() < s0.step_nt.abs(), "{s0:?} → {s1:?}");
}

#[test]
fn a_run_without_a_turnaround_window_is_refused() {
    let mut run = synthetic_run(&[[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.2]], [0.0; 3], [0.0; 3]);
    for s in run.iter_mut() {
        if s.leg == Leg::Back {
            s.leg = Leg::Other;
        }
    }
    assert_eq!(run_stats(&FieldCal::identity(), &run), Err(BackstepError::NoTurnaroundWindows));
}
