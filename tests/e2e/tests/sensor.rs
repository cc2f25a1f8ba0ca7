//! Sampling → correction → output, end to end: the host plays the bridges on
//! USART2, uploads coefficients over USART1, and reads the calibrated field
//! and heading back; they must match calib-core on the host bit for bit and
//! the truth to within the sensor chain's resolution.

use std::time::{Duration, Instant};

use calib_core::cal::{Calibration, Environment};
use calib_core::heading::{ned_field, ned_to_body, wrap_pi, Tilt};
use calib_core::linalg::{inverse3, mul_mat_vec};
use e2e_tests::boot_with_feed;
use firmware::acquisition::COUNTS_PER_NT;
use host_tools::board::{FeedWriter, BoardClient, ClientError};
use magcal_protocol::{CoefficientSource, Coefficients, DeviceError as Remote, StreamMode};

/// The hull's distortion (nT → nT) and hard iron (nT).
const D: [[f64; 3]; 3] = [[1.04, 0.02, -0.01], [0.02, 0.95, 0.015], [-0.01, 0.015, 1.02]];
const B_NT: [f64; 3] = [1500.0, -2300.0, 800.0];

fn coefficients() -> Coefficients {
    let g = f64::from(COUNTS_PER_NT);
    let m = inverse3(&D.map(|r| r.map(|v| v * g))).unwrap();
    Coefficients {
        bias: B_NT.map(|v| (v * g) as f32),
        matrix: m.map(|r| r.map(|v| v as f32)),
        swing: [0.0; 5],
        declination_rad: 0.05,
        field_nt: 48_730.0,
        current_bias_per_a: [0.0; 3],
        temp_ref_c: 20.0,
        temp_gain_per_c: [0.0; 3],
        inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION,
    }
}

#[test]
fn fed_field_comes_back_calibrated_with_the_heading() {
    let board = boot_with_feed("sensor");
    let mut link = BoardClient::open(board.link_port()).expect("open link");
    let mut feed = FeedWriter::open(board.sensor_port().expect("feed pty")).expect("open feed");
    link.identify().expect("identify");

    let c = coefficients();
    let seq = link.upload_coefficients(&c).expect("upload");
    assert!(seq >= 1);
    link.set_output_rate(20).unwrap();
    link.set_stream(StreamMode::Both).unwrap();

    // Truth: a field with 0.05 rad declination; vehicle at roll 0.2, pitch
    // −0.1, true heading 1.2 rad.
    let (roll, pitch, yaw) = (0.2f32, -0.1f32, 1.2f64);
    let h = ned_to_body(ned_field(48_730.0, 0.97, 0.05), f64::from(roll), f64::from(pitch), yaw);
    let at_bridges = {
        let d = mul_mat_vec(&D, h);
        [0, 1, 2].map(|k| (d[k] + B_NT[k]) as f32)
    };
    let offsets = [120_000.0, -95_000.0, 33_000.0]; // removed by set/reset
    // What the QEMU board's ADC model converts the bridges to, with its own
    // transcription of the chain (it differs from the driver's f32
    // COUNTS_PER_NT by about 1e-6: 1.5 codes at 1.6 M).
    let expected_raw = at_bridges.map(|v| (f64::from(v) * firmware::ads131m04_model::model_codes_per_nt()).round() as f32);
    let cal: Calibration<f32> = firmware::device::validate(&c).unwrap();

    let deadline = Instant::now() + Duration::from_secs(20);
    let mut checked = 0;
    let mut last_attitude = Instant::now() - Duration::from_secs(1);
    while checked < 5 && Instant::now() < deadline {
        feed.send(at_bridges, offsets).unwrap();
        if last_attitude.elapsed() > Duration::from_millis(200) {
            link.attitude(roll, pitch).unwrap();
            last_attitude = Instant::now();
        }
        let Some(s) = link.next_sample(Duration::from_millis(100)).unwrap() else { continue };
        let (Some(raw), Some(field), Some(heading)) = (s.raw, s.field_nt, s.heading_rad) else { continue };
        if raw.iter().zip(expected_raw).any(|(a, b)| (a - b).abs() > 1.0) {
            continue; // still averaging the previous truth
        }
        assert!(!s.saturated);
        // The board's numbers are calib-core's, bit for bit.
        assert_eq!(field, cal.field_nt(raw));
        assert_eq!(heading, cal.apply(raw, roll, pitch).true_heading_rad);
        // And they are the truth, to the chain's resolution.
        for k in 0..3 {
            assert!((f64::from(field[k]) - h[k]).abs() < 1.0, "field {field:?} vs {h:?}");
        }
        assert!(wrap_pi(f64::from(heading) - yaw).abs() < 0.01f64.to_radians(), "heading {heading} vs {yaw}");
        checked += 1;
    }
    assert_eq!(checked, 5, "no matching samples within the deadline");

    let health = link.status().unwrap();
    assert!(health.board.pairs > 100 && health.board.feed_updates > 0, "{health:?}");
    assert_eq!(health.coefficient_source, CoefficientSource::Stored);
    assert_eq!(health.board.acq_errors, 0);

    // Mission mode locks the coefficients.
    link.set_mission_mode(true).unwrap();
    match link.upload_coefficients(&c) {
        Err(ClientError::Remote(Remote::MissionMode)) => {}
        other => panic!("{other:?}"),
    }
}

/// The current and temperature terms on the board: the feed sets the
/// sensor's temperature (the ADC model makes the thermistor's voltage on
/// channel 3 from it), the host sends the motor current with the attitude,
/// and the bridges see the field through a drifted gain plus the thrusters'
/// field — written here from that physics.
#[test]
fn current_and_temperature_terms_are_applied_on_the_board() {
    let board = boot_with_feed("sensor-env");
    let mut link = BoardClient::open(board.link_port()).expect("open link");
    let mut feed = FeedWriter::open(board.sensor_port().expect("feed pty")).expect("open feed");
    link.identify().expect("identify");
    // HMC100x-like drift, −0.3 %/°C from 20 °C; thrusters adding 40 nT/A on z.
    let (k, t0_c, c_nt_per_a) = ([-0.003f64, -0.0028, -0.0032], 20.0f64, [15.0f64, -6.0, 40.0]);
    let (temp_c, current_a) = (31.0f32, 22.0f32);
    let g = f64::from(COUNTS_PER_NT);
    let c = Coefficients {
        current_bias_per_a: c_nt_per_a.map(|v| (v * g) as f32),
        temp_ref_c: t0_c as f32,
        temp_gain_per_c: k.map(|v| v as f32),
        ..coefficients()
    };
    link.upload_coefficients(&c).expect("upload");
    link.set_output_rate(20).unwrap();
    link.set_stream(StreamMode::Both).unwrap();
    let (roll, pitch, yaw) = (0.15f32, 0.05f32, 4.0f64);
    let h = ned_to_body(ned_field(48_730.0, 0.97, 0.05), f64::from(roll), f64::from(pitch), yaw);
    let at_bridges = {
        let d = mul_mat_vec(&D, h);
        [0, 1, 2].map(|i| ((1.0 + k[i] * (f64::from(temp_c) - t0_c)) * (d[i] + B_NT[i] + c_nt_per_a[i] * f64::from(current_a))) as f32)
    };
    let expected_raw = at_bridges.map(|v| (f64::from(v) * firmware::ads131m04_model::model_codes_per_nt()).round() as f32);
    let offsets = [120_000.0, -95_000.0, 33_000.0];
    let cal: Calibration<f32> = firmware::device::validate(&c).unwrap();
    // Phase 1: fresh current and a sound thermistor; phase 2: attitude
    // without current (heading withheld); phase 3: open thermistor.
    let deadline = Instant::now() + Duration::from_secs(30);
    let (mut checked, mut phase) = (0, 1);
    let mut last_attitude = Instant::now() - Duration::from_secs(1);
    while phase <= 3 && Instant::now() < deadline {
        let feed_temp = if phase == 3 { f32::NAN } else { temp_c };
        feed.send_env(at_bridges, offsets, Some(feed_temp)).unwrap();
        if last_attitude.elapsed() > Duration::from_millis(200) {
            match phase {
                1 => link.attitude_env(roll, pitch, current_a).unwrap(),
                _ => link.attitude(roll, pitch).unwrap(),
            }
            last_attitude = Instant::now();
        }
        let Some(s) = link.next_sample(Duration::from_millis(100)).unwrap() else { continue };
        let (Some(raw), Some(field)) = (s.raw, s.field_nt) else { continue };
        if raw.iter().zip(expected_raw).any(|(a, b)| (a - b).abs() > 1.0) {
            continue;
        }
        match phase {
            1 => {
                let (Some(heading), Some(measured_c)) = (s.heading_rad, s.temp_c) else { continue };
                // The thermistor through the model and the driver (host: 0.11 °C).
                assert!((measured_c - temp_c).abs() < 0.3, "{measured_c} °C");
                let env = Environment { current_a, temp_c: measured_c };
                let want = cal.apply_tilt_env(raw, &Tilt::new(roll, pitch), &env);
                assert_eq!((field, heading), (want.field_nt, want.true_heading_rad), "calib-core, bit for bit");
                // The truth, to what the temperature reading allows (0.1 °C
                // × 0.3 %/°C of 48 000 nT: 15 nT).
                for i in 0..3 {
                    assert!((f64::from(field[i]) - h[i]).abs() < 30.0, "field {field:?} vs {h:?}");
                }
                assert!(wrap_pi(f64::from(heading) - yaw).abs() < 0.05f64.to_radians(), "heading {heading} vs {yaw}");
                checked += 1;
                if checked == 3 {
                    let health = link.status().unwrap();
                    assert!(!health.env_degraded && health.temp_c.is_some(), "{health:?}");
                    phase = 2;
                    // Let the current go stale.
                    std::thread::sleep(Duration::from_millis(600));
                }
            }
            2 => {
                if s.heading_rad.is_some() {
                    continue; // a sample from before the current went stale
                }
                let health = link.status().unwrap();
                assert!(health.device.current_stale > 0 && health.env_degraded, "{health:?}");
                phase = 3;
            }
            _ => {
                if s.temp_c.is_some() {
                    continue;
                }
                let health = link.status().unwrap();
                assert!(health.device.temp_missing > 0 && health.env_degraded, "{health:?}");
                phase = 4;
            }
        }
    }
    assert_eq!(phase, 4, "phase {phase} not reached within the deadline ({checked} samples checked)");
}

#[test]
fn the_onboard_fit_runs_on_the_mcu_and_reports_convergence() {
    let board = boot_with_feed("onboard-fit");
    let mut link = BoardClient::open(board.link_port()).expect("open link");
    let mut feed = FeedWriter::open(board.sensor_port().expect("feed pty")).expect("open feed");
    link.identify().expect("identify");
    link.set_output_rate(100).unwrap();
    link.fit_start(magcal_protocol::OnboardModel::Full, 48_730.0).unwrap();
    // Until the first feed frame arrives the bridges read zero: the board's
    // plausibility gate keeps those samples out of the fit.
    // Tumble the simulated sensor smoothly (a spiral over the sphere, 1.5° a
    // step): the board averages pairs, and an average of directions far apart
    // would lie inside the sphere. The feed is not synchronised with the
    // board's output windows, so some windows straddle two steps.
    let start = Instant::now();
    let mut report = link.fit_query().unwrap();
    let mut k = 0u32;
    while start.elapsed() < Duration::from_secs(40) && (report.samples < 800 || k < 1200) {
        for _ in 0..10 {
            k += 1;
            let t = f64::from(k) * 1.5f64.to_radians();
            let (a, b) = (t, (0.37 * t).sin().asin() * 1.4);
            let u = [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()];
            let d = mul_mat_vec(&D, u.map(|v| v * 48_730.0));
            feed.send([0, 1, 2].map(|k| (d[k] + B_NT[k]) as f32), [0.0; 3]).unwrap();
            std::thread::sleep(Duration::from_millis(8));
        }
        report = link.fit_query().unwrap();
    }
    assert!(report.running && report.samples >= 800, "{report:?}");
    assert!(report.coverage_pct >= 60, "{report:?}");
    let est = report.estimate.expect("estimate");
    let want = coefficients();
    let bias_err_nt: Vec<f32> = (0..3).map(|k| (est.bias[k] - want.bias[k]).abs() / COUNTS_PER_NT).collect();
    eprintln!("on-board fit bias error {bias_err_nt:?} nT, residual {} nT RMS, coverage {} %", report.residual_rms_nt, report.coverage_pct);
    // Measured: 0.21–0.22 nT RMS when the board's output windows fall inside
    // the feed's steps, 44 nT when they straddle them (timing decides; both
    // seen on 2026-11-22); 66–68 % coverage. Was < 500 nT, > 50 %.
    assert!(report.residual_rms_nt < 150.0, "{report:?}");
    for e in &bias_err_nt {
        // The fit's precision is checked on exact samples by the on-target
        // test; here the samples are windows of a moving feed.
        // Measured on 2026-11-22 over 13 runs: bimodal, like the residual —
        // worst 0.12 nT when the windows fall inside the steps, 56.6 nT (x;
        // 19.8 y, 17.6 z) when they straddle them. Was 200 nT.
        assert!(*e < 150.0, "{:?} vs {:?}", est.bias, want.bias);
    }
    let stopped = link.fit_stop().unwrap();
    assert!(!stopped.running);
}
