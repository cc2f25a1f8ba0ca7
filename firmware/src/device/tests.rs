use super::*;
use crate::acquisition::{RawSample, COUNTS_PER_NT};
use calib_core::cal::EnvTerms;
use magcal_protocol::{CoefficientSource, FitReport, OnboardModel, StreamMode, ATTITUDE_TIMEOUT_MS, MAX_MOTOR_CURRENT_A, UNLOCK_TIMEOUT_MS, UNLOCK_XOR};
use calib_core::conformance::SplitMix64;
use calib_core::heading::{magnetic_heading_rad, ned_field, ned_to_body, wrap_pi};

struct MemStore {
    saved: Vec<Vec<u8>>,
    fail: bool,
}
impl CoefficientStore for MemStore {
    fn save(&mut self, bytes: &[u8]) -> Result<u32, SaveFailed> {
        if self.fail {
            return Err(SaveFailed);
        }
        self.saved.push(bytes.to_vec());
        Ok(self.saved.len() as u32)
    }
}

fn store() -> MemStore {
    MemStore { saved: vec![], fail: false }
}

fn good() -> Coefficients {
    let g = 1.0 / COUNTS_PER_NT;
    Coefficients {
        bias: [1000.0, -2000.0, 500.0],
        matrix: [[g * 1.02, 0.001 * g, 0.0], [0.001 * g, g * 0.98, 0.0], [0.0, 0.0, g]],
        swing: [0.01, 0.0, 0.0, 0.0, 0.002],
        declination_rad: 0.09,
        field_nt: 48_730.0,
        current_bias_per_a: [0.0; 3],
        temp_ref_c: 20.0,
        temp_gain_per_c: [0.0; 3],
        inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION,
    }
}

const CHALLENGE: u32 = 0x1234_5678;

fn device() -> Device {
    Device::new(Boot { stored: None, challenge: CHALLENGE })
}

fn req(d: &mut Device, r: RequestBody, now: u32, s: &mut MemStore) -> ResponseBody {
    d.handle(&r, now, s, &BoardCounters::default())
}

#[test]
fn boot_without_a_stored_set_uses_defaults_and_says_so() {
    let mut d = device();
    let mut s = store();
    match req(&mut d, RequestBody::Status, 5, &mut s) {
        ResponseBody::Status(h) => {
            assert_eq!(h.coefficient_source, CoefficientSource::Default);
            assert_eq!(h.last_error, Some(DeviceError::Storage));
            assert_eq!(h.unlock_challenge, CHALLENGE);
            assert!(!h.unlocked);
        }
        other => panic!("{other:?}"),
    }
    // A stored set that fails validation is not used either.
    let mut bad = good();
    bad.matrix[2][2] = -bad.matrix[2][2];
    let d = Device::new(Boot { stored: Some((bad, 7)), challenge: 1 });
    assert_eq!(d.bank.source(), CoefficientSource::Default);
    let d = Device::new(Boot { stored: Some((good(), 7)), challenge: 1 });
    assert_eq!((d.bank.source(), d.bank.seq()), (CoefficientSource::Stored, 7));
}

/// A set made for a sensor of another gain: every matrix entry 0.1× or
/// 10× the chain's (1 / COUNTS_PER_NT per nT). Uniform, so the columns keep
/// their ratios (no anisotropy), the determinant stays positive and the
/// bias in range: only the check of the gain against the chain's refuses
/// it — on write, on commit's re-check and at boot. Sets 0.25× and 4×
/// (inside its 0.2–5 band) still pass.
#[test]
fn a_uniformly_mis_scaled_set_is_refused_by_the_gain_check_alone() {
    let scaled = |k: f32| {
        let mut c = good();
        for row in c.matrix.iter_mut() {
            for v in row.iter_mut() {
                *v *= k;
            }
        }
        c
    };
    for k in [0.1f32, 10.0] {
        let c = scaled(k);
        // What the other checks see: a valid field calibration.
        let field = calib_core::cal::FieldCal { bias: c.bias, matrix: c.matrix };
        assert_eq!(field.validate(crate::adc::FULL_SCALE_COUNTS as f32), Ok(()), "{k}×");
        assert_eq!(validate(&c).err(), Some(DeviceError::InvalidCoefficients), "{k}×");
        let mut d = device();
        let mut s = store();
        assert_eq!(req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 10, &mut s), ResponseBody::Ack);
        assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 11, &mut s), ResponseBody::Error(DeviceError::InvalidCoefficients), "{k}×");
        // Stored by an older firmware: not used at boot either.
        let booted = Device::new(Boot { stored: Some((c, 3)), challenge: 1 });
        assert_eq!(booted.bank.source(), CoefficientSource::Default, "{k}×");
        let mut bytes = [0u8; Coefficients::MAX_ENCODED_LEN];
        let n = encode_coefficients(&c, &mut bytes).unwrap();
        assert!(decode_coefficients(&bytes[..n], crate::store::VERSION).is_none(), "{k}×");
    }
    for k in [0.25f32, 4.0] {
        assert!(validate(&scaled(k)).is_ok(), "{k}×");
    }
}

#[test]
fn the_write_path_needs_unlock_validation_and_a_matching_commit() {
    let mut d = device();
    let mut s = store();
    let c = good();
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 10, &mut s), ResponseBody::Error(DeviceError::Locked));
    assert_eq!(req(&mut d, RequestBody::Unlock { key: CHALLENGE }, 10, &mut s), ResponseBody::Error(DeviceError::BadKey));
    assert_eq!(req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 10, &mut s), ResponseBody::Ack);
    let mut mirrored = c;
    mirrored.matrix[0][0] = -mirrored.matrix[0][0];
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(mirrored), 11, &mut s), ResponseBody::Error(DeviceError::InvalidCoefficients));
    let mut wrong_field = c;
    wrong_field.field_nt = 5.0;
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(wrong_field), 11, &mut s), ResponseBody::Error(DeviceError::InvalidCoefficients));
    assert_eq!(req(&mut d, RequestBody::Commit { crc: c.crc() }, 12, &mut s), ResponseBody::Error(DeviceError::NothingStaged));
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 12, &mut s), ResponseBody::Ack);
    // Staged is not in use yet.
    assert!(matches!(req(&mut d, RequestBody::ReadCoefficients, 12, &mut s), ResponseBody::Coefficients { source: CoefficientSource::Default, .. }));
    assert_eq!(req(&mut d, RequestBody::Commit { crc: c.crc() ^ 1 }, 13, &mut s), ResponseBody::Error(DeviceError::CommitMismatch));
    assert_eq!(req(&mut d, RequestBody::Commit { crc: c.crc() }, 13, &mut s), ResponseBody::Committed { seq: 1 });
    assert_eq!(req(&mut d, RequestBody::ReadCoefficients, 14, &mut s), ResponseBody::Coefficients { coefficients: c, source: CoefficientSource::Stored, seq: 1 });
    // What was stored decodes to the same set.
    assert_eq!(decode_coefficients(&s.saved[0], crate::store::VERSION).unwrap().0, c);
    // The unlock is spent by the commit.
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 15, &mut s), ResponseBody::Error(DeviceError::Locked));
    // And a replayed Unlock frame does not open it again: the challenge moved on.
    assert_eq!(req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 16, &mut s), ResponseBody::Error(DeviceError::BadKey));
    let ResponseBody::Status(h) = req(&mut d, RequestBody::Status, 16, &mut s) else { panic!() };
    assert_ne!(h.unlock_challenge, CHALLENGE);
    assert_eq!(req(&mut d, RequestBody::Unlock { key: h.unlock_challenge ^ UNLOCK_XOR }, 16, &mut s), ResponseBody::Ack);
}

#[test]
fn a_failed_flash_write_keeps_the_old_set_in_use() {
    let mut d = device();
    let mut s = MemStore { saved: vec![], fail: true };
    let c = good();
    req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 0, &mut s);
    req(&mut d, RequestBody::WriteCoefficients(c), 0, &mut s);
    assert_eq!(req(&mut d, RequestBody::Commit { crc: c.crc() }, 0, &mut s), ResponseBody::Error(DeviceError::Storage));
    assert!(matches!(req(&mut d, RequestBody::ReadCoefficients, 0, &mut s), ResponseBody::Coefficients { source: CoefficientSource::Default, .. }));
}

#[test]
fn mission_mode_and_expiry_lock_the_writes() {
    let mut d = device();
    let mut s = store();
    req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 1000, &mut s);
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(good()), 1000 + UNLOCK_TIMEOUT_MS + 1, &mut s), ResponseBody::Error(DeviceError::Locked));
    assert_eq!(req(&mut d, RequestBody::SetMissionMode { enabled: true }, 2000, &mut s), ResponseBody::Ack);
    assert_eq!(req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 2000, &mut s), ResponseBody::Error(DeviceError::MissionMode));
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(good()), 2000, &mut s), ResponseBody::Error(DeviceError::MissionMode));
    assert_eq!(req(&mut d, RequestBody::Commit { crc: 0 }, 2000, &mut s), ResponseBody::Error(DeviceError::MissionMode));
    assert_eq!(req(&mut d, RequestBody::SetOutputRate { hz: 0 }, 2000, &mut s), ResponseBody::Error(DeviceError::BadArgument));
    assert_eq!(req(&mut d, RequestBody::SetOutputRate { hz: 101 }, 2000, &mut s), ResponseBody::Error(DeviceError::BadArgument));
    assert_eq!(req(&mut d, RequestBody::Attitude { roll_rad: f32::NAN, pitch_rad: 0.0 }, 2000, &mut s), ResponseBody::Error(DeviceError::BadArgument));
}

#[test]
fn samples_are_calibrated_as_calib_core_does_and_headed_with_a_fresh_attitude() {
    let mut d = Device::new(Boot { stored: Some((good(), 3)), challenge: 0 });
    let mut s = store();
    req(&mut d, RequestBody::SetStream(StreamMode::Both), 0, &mut s);
    let raw = RawSample { field_counts: [700_000.0, -1_100_000.0, 1_300_000.0], saturated: false, tag: None, temp_c: Some(20.0) };
    let out = d.on_raw_sample(&raw, 100).unwrap();
    let cal = validate(&good()).unwrap();
    assert_eq!(out.field_nt.unwrap(), cal.field.apply(raw.field_counts));
    assert_eq!(out.raw.unwrap(), raw.field_counts);
    assert_eq!(out.heading_rad, None, "no attitude yet");
    req(&mut d, RequestBody::Attitude { roll_rad: 0.1, pitch_rad: -0.05 }, 200, &mut s);
    let out = d.on_raw_sample(&raw, 300).unwrap();
    assert_eq!(out.heading_rad.unwrap(), cal.apply(raw.field_counts, 0.1, -0.05).true_heading_rad);
    let stale = d.on_raw_sample(&raw, 200 + ATTITUDE_TIMEOUT_MS + 1).unwrap();
    assert_eq!(stale.heading_rad, None);
    req(&mut d, RequestBody::SetStream(StreamMode::Off), 0, &mut s);
    assert!(d.on_raw_sample(&raw, 400).is_none());
}

#[test]
fn the_onboard_fit_converges_to_the_truth() {
    // The sensor: counts = COUNTS_PER_NT · D · h + b.
    let (b, f) = ([20_000.0f64, -15_000.0, 8_000.0], 48_730.0f64);
    let d_mat = [[1.03, 0.01, 0.0], [0.01, 0.97, 0.02], [0.0, 0.02, 1.01]];
    let mut dev = device();
    let mut s = store();
    assert!(matches!(req(&mut dev, RequestBody::FitStart { model: OnboardModel::Full, field_nt: 5.0 }, 0, &mut s), ResponseBody::Error(DeviceError::BadArgument)));
    assert!(matches!(req(&mut dev, RequestBody::FitStart { model: OnboardModel::Full, field_nt: f as f32 }, 0, &mut s), ResponseBody::Fit(_)));
    let mut rng = SplitMix64::new(3);
    let mut truth_cal = None;
    for _ in 0..3000 {
        let u = rng.direction();
        let h = [u[0] * f, u[1] * f, u[2] * f];
        let r = calib_core::linalg::mul_mat_vec(&d_mat, h);
        let raw = [0, 1, 2].map(|k| ((r[k] * f64::from(COUNTS_PER_NT)) + b[k] + 3.0 * rng.gauss()) as f32);
        dev.on_raw_sample(&RawSample { field_counts: raw, saturated: false, tag: None, temp_c: Some(20.0) }, 0);
        truth_cal.get_or_insert(());
    }
    let ResponseBody::Fit(rep) = req(&mut dev, RequestBody::FitQuery, 0, &mut s) else { panic!() };
    assert_eq!(rep.samples, 3000);
    assert!(rep.coverage_pct > 95);
    assert!(rep.residual_rms_nt < 5.0, "{}", rep.residual_rms_nt);
    let est = rep.estimate.expect("an estimate");
    for k in 0..3 {
        assert!((f64::from(est.bias[k]) - b[k]).abs() < 20.0, "{:?}", est.bias);
    }
    // Heading with the estimate matches the truth to a few hundredths of a degree.
    let cal = validate(&est).unwrap();
    let body = ned_to_body(ned_field(f, 0.97, 0.0), 0.2, 0.1, 1.3);
    let r = calib_core::linalg::mul_mat_vec(&d_mat, body);
    let raw = [0, 1, 2].map(|k| (r[k] * f64::from(COUNTS_PER_NT) + b[k]) as f32);
    let psi = magnetic_heading_rad(cal.field.apply(raw), 0.2, 0.1);
    assert!(wrap_pi(f64::from(psi) - 1.3).abs() < 0.05f64.to_radians());
    // A dead sensor (all zeros) does not enter the fit.
    dev.on_raw_sample(&RawSample { field_counts: [0.0; 3], saturated: false, tag: None, temp_c: Some(20.0) }, 0);
    let ResponseBody::Fit(rep) = req(&mut dev, RequestBody::FitQuery, 0, &mut s) else { panic!() };
    assert_eq!(rep.samples, 3000);
    assert!(matches!(req(&mut dev, RequestBody::FitStop, 0, &mut s), ResponseBody::Fit(FitReport { running: false, .. })));
}

/// The gyro-aided fit on the board, from the AHRS's `Motion` messages and
/// the board's own samples: a vehicle that rolls ±15° and pitches ±5°
/// while turning through every heading (rigid-body kinematics written
/// here: Z-Y-X Euler rates to body rates), a non-symmetric sensor matrix
/// (non-orthogonality), 10 Hz output.
#[test]
fn the_onboard_gyro_fit_calibrates_a_vehicle_that_cannot_tumble() {
    let (b, f) = ([20_000.0f64, -15_000.0, 8_000.0], 48_730.0f64);
    let d_mat = [[1.03, 0.02, 0.0], [-0.01, 0.97, 0.02], [0.01, 0.0, 1.01]];
    let mut dev = device();
    let mut s = store();
    let r = req(&mut dev, RequestBody::FitStart { model: OnboardModel::Gyro, field_nt: f as f32 }, 0, &mut s);
    assert!(matches!(r, ResponseBody::Fit(_)), "{r:?}");
    let mut rng = SplitMix64::new(8);
    let ned = ned_field(f, 1.0, 0.0);
    let sample = |t: f64| {
        let (wy, wr, wp) = (core::f64::consts::TAU / 50.0, core::f64::consts::TAU / 7.0, core::f64::consts::TAU / 11.0);
        let (roll, pitch, yaw) = (0.26 * (wr * t).sin(), 0.087 * (wp * t).sin(), wy * t);
        let (rd, pd, yd) = (0.26 * wr * (wr * t).cos(), 0.087 * wp * (wp * t).cos(), wy);
        let rate = [rd - yd * pitch.sin(), pd * roll.cos() + yd * roll.sin() * pitch.cos(), -pd * roll.sin() + yd * roll.cos() * pitch.cos()];
        (roll, pitch, yaw, rate)
    };
    for step in 0..3000u32 {
        let now_ms = step * 100;
        let (roll, pitch, yaw, rate) = sample(f64::from(now_ms) / 1000.0);
        let m = RequestBody::Motion { roll_rad: roll as f32, pitch_rad: pitch as f32, rate_rad_s: rate.map(|w| w as f32) };
        assert_eq!(req(&mut dev, m, now_ms, &mut s), ResponseBody::Ack);
        let h = calib_core::linalg::mul_mat_vec(&d_mat, ned_to_body(ned, roll, pitch, yaw));
        let raw = [0, 1, 2].map(|k| (h[k] * f64::from(COUNTS_PER_NT) + b[k] + 30.0 * rng.gauss()) as f32);
        dev.on_raw_sample(&RawSample { field_counts: raw, saturated: false, tag: None, temp_c: Some(20.0) }, now_ms);
    }
    let ResponseBody::Fit(rep) = req(&mut dev, RequestBody::FitQuery, 300_000, &mut s) else { panic!() };
    let est = rep.estimate.expect("an estimate");
    let cal = validate(&est).unwrap();
    // Heading error over every heading at ±15° roll with the estimate.
    let mut worst = 0.0f64;
    for k in 0..36 {
        let (roll, pitch, yaw) = (0.2, -0.05, f64::from(k) * 10f64.to_radians());
        let h = calib_core::linalg::mul_mat_vec(&d_mat, ned_to_body(ned, roll, pitch, yaw));
        let raw = [0, 1, 2].map(|j| (h[j] * f64::from(COUNTS_PER_NT) + b[j]) as f32);
        let psi = magnetic_heading_rad(cal.field.apply(raw), roll as f32, pitch as f32);
        worst = worst.max(wrap_pi(f64::from(psi) - yaw).abs());
    }
    eprintln!("on-board gyro fit: {} windows, worst heading error {:.3}°, bias {:?}", rep.samples, worst.to_degrees(), est.bias);
    // Measured: worst 0.046° (30-count noise = 0.8 nT); bias within 0.5,
    // 721 and 1 145 counts of a 1.74 M-count field radius (0.07 %: the
    // vertical channel is the weakly determined one at ±15° / ±5°).
    assert!(rep.samples > 2900, "{rep:?}");
    assert!(worst.to_degrees() < 0.15, "{}", worst.to_degrees());
    for k in 0..3 {
        assert!((f64::from(est.bias[k]) - b[k]).abs() < 3_000.0, "{:?}", est.bias);
    }
    // Without Motion messages the fit gets no windows, and says so.
    let r = req(&mut dev, RequestBody::FitStart { model: OnboardModel::Gyro, field_nt: f as f32 }, 400_000, &mut s);
    assert!(matches!(r, ResponseBody::Fit(_)));
    for step in 0..100u32 {
        dev.on_raw_sample(&RawSample { field_counts: [40_000.0 + step as f32, -15_000.0, 1_800_000.0], saturated: false, tag: None, temp_c: Some(20.0) }, 400_000 + 500 + step * 100);
    }
    let ResponseBody::Fit(rep) = req(&mut dev, RequestBody::FitQuery, 420_000, &mut s) else { panic!() };
    assert_eq!(rep.samples, 0);
    assert!(rep.estimate.is_none());
    // A rate beyond any gyro's range is refused.
    let bad = RequestBody::Motion { roll_rad: 0.0, pitch_rad: 0.0, rate_rad_s: [0.0, 40.0, 0.0] };
    assert_eq!(req(&mut dev, bad, 0, &mut s), ResponseBody::Error(DeviceError::BadArgument));
}

/// The fuzz target's seeds: valid unlock / write / commit sequences (and a
/// few refusals on the way) so that libFuzzer starts on the deep paths. The
/// files in `fuzz/seeds/frame_decoder/` must be what this writes; run with
/// `MAGCAL_WRITE_FUZZ_SEEDS=1` to rewrite them after a protocol change.
#[test]
fn fuzz_seed_corpus_is_current() {
    use magcal_protocol::{encode, Request, MAX_FRAME_LEN, UNLOCK_XOR};
    let frame = |seq: u16, body: RequestBody| {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(&Request { seq, body }, &mut buf).unwrap();
        buf[..n].to_vec()
    };
    let c = good();
    let mut bad = c;
    bad.matrix[1][1] *= 20.0;
    let key = FUZZ_CHALLENGE ^ UNLOCK_XOR;
    let seeds: Vec<Vec<Vec<u8>>> = vec![
        vec![frame(1, RequestBody::Unlock { key }), frame(2, RequestBody::WriteCoefficients(c)), frame(3, RequestBody::Commit { crc: c.crc() })],
        vec![
            frame(1, RequestBody::Status),
            frame(2, RequestBody::Unlock { key }),
            frame(3, RequestBody::WriteCoefficients(bad)),
            frame(4, RequestBody::WriteCoefficients(c)),
            frame(5, RequestBody::Commit { crc: c.crc() ^ 1 }),
            frame(6, RequestBody::Commit { crc: c.crc() }),
            frame(7, RequestBody::ReadCoefficients),
        ],
        vec![frame(1, RequestBody::SetMissionMode { enabled: true }), frame(2, RequestBody::Unlock { key }), frame(3, RequestBody::SetMissionMode { enabled: false }), frame(4, RequestBody::Unlock { key })],
        vec![frame(1, RequestBody::FitStart { model: OnboardModel::Full, field_nt: 48_730.0 }), frame(2, RequestBody::FitQuery), frame(3, RequestBody::SetStream(StreamMode::Both)), frame(4, RequestBody::Attitude { roll_rad: 0.1, pitch_rad: -0.05 }), frame(5, RequestBody::AttitudeEnv { roll_rad: 0.1, pitch_rad: -0.05, motor_current_a: 12.5 })],
    ];
    // The first seed does commit on a device with the fuzz target's challenge.
    let mut dev = Device::new(Boot { stored: None, challenge: FUZZ_CHALLENGE });
    let mut s = store();
    let mut replies = Vec::new();
    for f in &seeds[0] {
        let Request { body, .. } = magcal_protocol::decode::<Request>(f).unwrap();
        replies.push(req(&mut dev, body, 0, &mut s));
    }
    assert!(matches!(replies[2], ResponseBody::Committed { .. }), "{replies:?}");
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz/seeds/frame_decoder");
    let write = std::env::var_os("MAGCAL_WRITE_FUZZ_SEEDS").is_some();
    for (i, frames) in seeds.iter().enumerate() {
        let bytes: Vec<u8> = frames.concat();
        let path = dir.join(format!("seed-{i}"));
        if write {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &bytes).unwrap();
        }
        assert_eq!(std::fs::read(&path).ok().as_deref(), Some(bytes.as_slice()), "{} is stale: rerun with MAGCAL_WRITE_FUZZ_SEEDS=1", path.display());
    }
}

/// The sensor of the environment tests, written from physics here: the
/// bridges' gain is `1 + k·(T − T0)` for everything they see (the field
/// through the chain, the hull's hard iron `b` and the thrusters' field
/// `c·I`), with a soft-iron/scale diagonal `s`.
struct EnvSensor {
    k: [f64; 3],
    t0_c: f64,
    b: [f64; 3],
    c: [f64; 3],
    s: [f64; 3],
}

impl EnvSensor {
    fn new() -> Self {
        // HMC100x-like gain drift (≈ −0.3 %/°C), a steel hull's bias, and
        // thrusters adding ~1 800 counts (50 nT) per ampere on z.
        Self { k: [-0.003, -0.0028, -0.0032], t0_c: 15.0, b: [20_000.0, -15_000.0, 8_000.0], c: [600.0, -250.0, 1_800.0], s: [1.03, 0.97, 1.01] }
    }

    fn raw(&self, h_nt: [f64; 3], current_a: f64, temp_c: f64) -> [f32; 3] {
        let k_chain = f64::from(COUNTS_PER_NT);
        core::array::from_fn(|i| ((1.0 + self.k[i] * (temp_c - self.t0_c)) * (self.s[i] * h_nt[i] * k_chain + self.b[i] + self.c[i] * current_a)) as f32)
    }

    fn coefficients(&self, with_env: bool) -> Coefficients {
        let g = |i: usize| (1.0 / (self.s[i] * f64::from(COUNTS_PER_NT))) as f32;
        let f = |v: [f64; 3]| v.map(|x| x as f32);
        Coefficients {
            bias: f(self.b),
            matrix: [[g(0), 0.0, 0.0], [0.0, g(1), 0.0], [0.0, 0.0, g(2)]],
            swing: [0.0; 5],
            declination_rad: 0.05,
            field_nt: 48_730.0,
            current_bias_per_a: if with_env { f(self.c) } else { [0.0; 3] },
            temp_ref_c: self.t0_c as f32,
            temp_gain_per_c: if with_env { f(self.k) } else { [0.0; 3] },
            inclination_rad: magcal_protocol::Coefficients::NO_INCLINATION,
        }
    }
}

fn env_device(c: Coefficients) -> (Device, MemStore) {
    let mut d = Device::new(Boot { stored: Some((c, 1)), challenge: 0 });
    let mut s = store();
    req(&mut d, RequestBody::SetStream(StreamMode::Both), 0, &mut s);
    (d, s)
}

#[test]
fn current_and_temperature_are_corrected_to_the_truth() {
    let sensor = EnvSensor::new();
    let (roll, pitch, yaw) = (0.12f64, -0.07f64, 2.3f64);
    // Field built with declination 0.05 rad (as the coefficients): the true
    // heading is the yaw.
    let h = ned_to_body(ned_field(48_730.0, 1.12, 0.05), roll, pitch, yaw);
    let (current_a, temp_c) = (35.0, 31.5);
    let raw = RawSample { field_counts: sensor.raw(h, current_a, temp_c), saturated: false, tag: None, temp_c: Some(temp_c as f32) };
    let run = |with_env: bool| {
        let (mut d, mut s) = env_device(sensor.coefficients(with_env));
        let att = RequestBody::AttitudeEnv { roll_rad: roll as f32, pitch_rad: pitch as f32, motor_current_a: current_a as f32 };
        assert_eq!(req(&mut d, att, 100, &mut s), ResponseBody::Ack);
        d.on_raw_sample(&raw, 150).unwrap()
    };
    let out = run(true);
    let field = out.field_nt.unwrap();
    // Measured: 0.0007 nT worst axis, 5e-8 rad heading (f32 rounding).
    for i in 0..3 {
        assert!((f64::from(field[i]) - h[i]).abs() < 0.005, "axis {i}: {} vs {}", field[i], h[i]);
    }
    assert!(wrap_pi(f64::from(out.heading_rad.unwrap()) - yaw).abs() < 1e-6, "{:?}", out.heading_rad);
    assert_eq!(out.temp_c, Some(31.5));
    // Without the terms the same sample is far off: 16.5 °C of gain drift
    // scales the field by ~5 %, the thrusters add 63 000 counts on z
    // (measured: 808 nT on z, the two partly cancelling).
    let plain = run(false);
    let err_nt = (f64::from(plain.field_nt.unwrap()[2]) - h[2]).abs();
    assert!(err_nt > 500.0, "{err_nt} nT");
}

#[test]
fn a_stale_current_withholds_the_heading_and_a_missing_temperature_falls_back_to_the_reference() {
    let sensor = EnvSensor::new();
    let (mut d, mut s) = env_device(sensor.coefficients(true));
    let h = ned_to_body(ned_field(48_730.0, 1.12, 0.05), 0.0, 0.0, 1.0);
    let sample = |temp_c: Option<f64>, current_a: f64| RawSample {
        field_counts: sensor.raw(h, current_a, temp_c.unwrap_or(sensor.t0_c)),
        saturated: false,
        tag: None,
        temp_c: temp_c.map(|t| t as f32),
    };
    let health = |d: &mut Device, s: &mut MemStore, now| match req(d, RequestBody::Status, now, s) {
        ResponseBody::Status(h) => h,
        other => panic!("{other:?}"),
    };
    // Never sent a current: the stored current term needs one.
    req(&mut d, RequestBody::Attitude { roll_rad: 0.0, pitch_rad: 0.0 }, 0, &mut s);
    let out = d.on_raw_sample(&sample(Some(20.0), 0.0), 10).unwrap();
    assert_eq!(out.heading_rad, None);
    assert!(out.field_nt.is_some());
    let hl = health(&mut d, &mut s, 10);
    assert_eq!((hl.device.current_stale, hl.device.temp_missing, hl.temp_c, hl.env_degraded), (1, 0, Some(20.0), true));
    // Fresh current: heading back.
    req(&mut d, RequestBody::AttitudeEnv { roll_rad: 0.0, pitch_rad: 0.0, motor_current_a: 10.0 }, 1000, &mut s);
    let out = d.on_raw_sample(&sample(Some(20.0), 10.0), 1000 + ATTITUDE_TIMEOUT_MS).unwrap();
    assert!(wrap_pi(f64::from(out.heading_rad.unwrap()) - 1.0).abs() < 5e-5);
    assert!(!health(&mut d, &mut s, 1500).env_degraded);
    // The current ages out with the attitude timeout, even if a plain
    // Attitude keeps the attitude fresh.
    req(&mut d, RequestBody::Attitude { roll_rad: 0.0, pitch_rad: 0.0 }, 1400, &mut s);
    let out = d.on_raw_sample(&sample(Some(20.0), 10.0), 1000 + ATTITUDE_TIMEOUT_MS + 1).unwrap();
    assert_eq!(out.heading_rad, None);
    assert_eq!(health(&mut d, &mut s, 1600).device.current_stale, 2);
    // Temperature missing (open thermistor): corrected at the reference
    // temperature — exactly M·(raw − b − c·I), computed here — flagged,
    // the last valid temperature kept.
    req(&mut d, RequestBody::AttitudeEnv { roll_rad: 0.0, pitch_rad: 0.0, motor_current_a: 10.0 }, 2000, &mut s);
    let raw = sample(None, 10.0);
    let out = d.on_raw_sample(&raw, 2010).unwrap();
    assert_eq!(out.temp_c, None);
    assert!(out.heading_rad.is_some(), "a missing temperature does not withhold the heading");
    let c = sensor.coefficients(true);
    for i in 0..3 {
        let want = f64::from(c.matrix[i][i]) * (f64::from(raw.field_counts[i]) - f64::from(c.bias[i]) - f64::from(c.current_bias_per_a[i]) * 10.0);
        assert!((f64::from(out.field_nt.unwrap()[i]) - want).abs() < 0.05, "axis {i}");
    }
    let hl = health(&mut d, &mut s, 2010);
    assert_eq!((hl.device.current_stale, hl.device.temp_missing, hl.temp_c, hl.env_degraded), (2, 1, Some(20.0), true));
    // Without a current term no current is needed.
    let (mut d, mut s) = env_device(EnvSensor { c: [0.0; 3], ..EnvSensor::new() }.coefficients(true));
    req(&mut d, RequestBody::Attitude { roll_rad: 0.0, pitch_rad: 0.0 }, 0, &mut s);
    assert!(d.on_raw_sample(&sample(Some(20.0), 0.0), 10).unwrap().heading_rad.is_some());
    assert_eq!(health(&mut d, &mut s, 10).device.current_stale, 0);
}

#[test]
fn implausible_current_or_temperature_terms_and_currents_are_refused() {
    let mut d = device();
    let mut s = store();
    req(&mut d, RequestBody::Unlock { key: CHALLENGE ^ UNLOCK_XOR }, 0, &mut s);
    let mut c = EnvSensor::new().coefficients(true);
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 0, &mut s), ResponseBody::Ack);
    c.temp_gain_per_c[1] = 0.05; // 5 %/°C: no magnetometer
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 0, &mut s), ResponseBody::Error(DeviceError::InvalidCoefficients));
    let mut c = EnvSensor::new().coefficients(true);
    c.temp_ref_c = f32::NAN;
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 0, &mut s), ResponseBody::Error(DeviceError::InvalidCoefficients));
    let mut c = EnvSensor::new().coefficients(true);
    c.current_bias_per_a[2] = 2.0 * MAX_CURRENT_BIAS_PER_A;
    assert_eq!(req(&mut d, RequestBody::WriteCoefficients(c), 0, &mut s), ResponseBody::Error(DeviceError::InvalidCoefficients));
    for bad in [f32::NAN, f32::INFINITY, 2.0 * MAX_MOTOR_CURRENT_A] {
        let r = RequestBody::AttitudeEnv { roll_rad: 0.0, pitch_rad: 0.0, motor_current_a: bad };
        assert_eq!(req(&mut d, r, 0, &mut s), ResponseBody::Error(DeviceError::BadArgument));
    }
}

#[test]
fn a_record_of_the_previous_version_loads_without_terms() {
    // The version-1 payload: postcard of the five fields the protocol-2
    // Coefficients had (bias, matrix, swing, declination, field), written
    // here field by field as f32 little-endian (postcard's f32 encoding).
    let c = good();
    let mut v1 = Vec::new();
    for x in c.bias.iter().chain(c.matrix.iter().flatten()).chain(c.swing.iter()).chain([c.declination_rad, c.field_nt].iter()) {
        v1.extend_from_slice(&x.to_le_bytes());
    }
    let (back, cal) = decode_coefficients(&v1, 1).unwrap();
    assert_eq!((back.bias, back.matrix, back.swing, back.declination_rad, back.field_nt), (c.bias, c.matrix, c.swing, c.declination_rad, c.field_nt));
    assert!(cal.env.is_none());
    assert_eq!(back.env_terms(), EnvTerms::none());
    // The same bytes are not a version-2 or -3 record (too short), nor version 9.
    assert!(decode_coefficients(&v1, 2).is_none());
    assert!(decode_coefficients(&v1, crate::store::VERSION).is_none());
    assert!(decode_coefficients(&v1, 9).is_none());
    // A version-2 record (protocol 3 and 4: the current and temperature
    // terms, no inclination) loads with no reference inclination.
    let mut v2 = v1.clone();
    for x in c.current_bias_per_a.iter().chain([c.temp_ref_c].iter()).chain(c.temp_gain_per_c.iter()) {
        v2.extend_from_slice(&x.to_le_bytes());
    }
    let (back, _) = decode_coefficients(&v2, 2).unwrap();
    assert_eq!(back, Coefficients { inclination_rad: Coefficients::NO_INCLINATION, ..c });
    assert_eq!(back.inclination(), None);
}

/// A vehicle turning at 0.2 rad/s with a gently rocking attitude, the AHRS
/// sending `Motion` before each 10 Hz sample; from sample `from` to `to` a
/// magnet under the sensor adds 5 000 nT on z: |h| grows by about
/// 4 760 nT (the vertical is 43 870 nT), 8 σ of the board's reference
/// scatter (1.2 % of 48 730 nT = 585 nT), at every heading. Returns the raw samples, their requests
/// and the truth's yaw.
fn turning_run(sensor: &EnvSensor, n: usize, disturbed: core::ops::Range<usize>) -> Vec<(RawSample, RequestBody, f64)> {
    let mut rng = SplitMix64::new(23);
    (0..n)
        .map(|k| {
            let t = k as f64 * 0.1;
            let (roll, pitch, yaw) = (0.08 * (0.7 * t).sin(), 0.05 * (0.5 * t).cos(), wrap_pi(0.2 * t));
            let mut h = ned_to_body(ned_field(48_730.0, 1.12, 0.05), roll, pitch, yaw);
            for v in h.iter_mut() {
                *v += 60.0 * rng.gauss();
            }
            if disturbed.contains(&k) {
                h[2] += 5_000.0;
            }
            // Body rates of a level-ish turn: yaw rate on z (the small
            // roll/pitch rates are below the gyro model's noise).
            let motion = RequestBody::Motion { roll_rad: roll as f32, pitch_rad: pitch as f32, rate_rad_s: [0.0, 0.0, 0.2] };
            (RawSample { field_counts: sensor.raw(h, 0.0, sensor.t0_c), saturated: false, tag: None, temp_c: Some(sensor.t0_c as f32) }, motion, yaw)
        })
        .collect()
}

/// The pipeline judges every sample with calib-core's `OnlineIntegrity`
/// (f32) and streams its verdict: a passing magnet is flagged, the rest is
/// `ok` with an honest σ, and the bits are calib-core's own on the host.
#[test]
fn a_disturbed_stream_is_flagged_with_calib_cores_bits() {
    use calib_core::online::OnlineIntegrity;
    use magcal_protocol::Integrity;
    let sensor = EnvSensor::new();
    // With the stored reference inclination (the run's true dip, 1.12 rad):
    // without one nothing is `ok` (`unjudged`).
    let c = Coefficients { inclination_rad: 1.12, ..sensor.coefficients(false) };
    let (mut d, mut s) = env_device(c);
    let cal = validate(&c).unwrap();
    let mut reference = OnlineIntegrity::<f32>::for_stored(c.field_nt, c.inclination()).unwrap();
    let run = turning_run(&sensor, 400, 200..230);
    let mut states = Vec::new();
    for (k, (raw, motion, yaw)) in run.iter().enumerate() {
        let now = 1_000 + 100 * k as u32;
        assert_eq!(req(&mut d, motion.clone(), now - 5, &mut s), ResponseBody::Ack);
        let out = d.on_raw_sample(raw, now).unwrap();
        // calib-core on the host, with the same inputs.
        let RequestBody::Motion { roll_rad, pitch_rad, rate_rad_s } = *motion else { unreachable!() };
        let dt = if k == 0 { f32::NAN } else { 100.0f32 * 1e-3 };
        let corrected = cal.env.correct_raw(raw.field_counts, &calib_core::cal::Environment { current_a: 0.0, temp_c: sensor.t0_c as f32 });
        let j = reference.process(&cal, corrected, Some(&calib_core::heading::Tilt::new(roll_rad, pitch_rad)), Some(rate_rad_s), dt);
        assert_eq!(out.field_nt.unwrap().map(f32::to_bits), j.field_nt.map(f32::to_bits), "sample {k}");
        assert_eq!(out.heading_rad.map(f32::to_bits), j.heading_rad.map(f32::to_bits), "sample {k}");
        assert_eq!(out.heading_sigma_deg.map(f32::to_bits), Some(j.verdict.heading_sigma_rad.to_degrees().to_bits()), "sample {k}");
        assert_eq!(out.integrity, j.verdict.state, "sample {k}");
        if out.integrity == Integrity::Ok {
            // σ honest: the error within 4σ (measured: worst ratio below 2.5).
            let err_deg = wrap_pi(f64::from(out.heading_rad.unwrap()) - yaw).to_degrees().abs();
            assert!(err_deg < 4.0 * f64::from(out.heading_sigma_deg.unwrap()), "sample {k}: {err_deg}° vs σ {:?}", out.heading_sigma_deg);
        }
        states.push(out.integrity);
    }
    let ok_in = |r: core::ops::Range<usize>| states[r.clone()].iter().filter(|s| **s == Integrity::Ok).count() as f64 / r.len() as f64;
    assert_eq!(ok_in(200..230), 0.0, "the magnet's samples: {:?}", &states[200..230]);
    // Undisturbed after a warm-up, and once the misfit fraction (2 s time
    // constant, valid again below 0.1: about 4 s after a 3 s disturbance)
    // has decayed.
    assert!(ok_in(20..200) > 0.95, "{}", ok_in(20..200));
    assert!(ok_in(280..400) > 0.95, "{}", ok_in(280..400));
    let h = d.health(1_000 + 100 * 400, &BoardCounters::default());
    assert_eq!(h.integrity_samples.iter().sum::<u32>(), 400);
    assert_eq!(h.integrity_samples, reference.health().samples_per_state);
    // A 3 s disturbance drives the misfit fraction (τ = 2 s) to
    // 1 − e^(−1.5) = 0.78, over the 0.5 that calls the calibration invalid;
    // it decays below 0.1 after 2 s · ln(7.8) = 4.1 s: 7.1 s not ok in all
    // (measured 7.0 s).
    assert!((6_500..=7_500).contains(&h.longest_disturbance_ms), "{} ms", h.longest_disturbance_ms);
    assert!(!h.hard_iron_applied, "the stored calibration still fits");
}

/// The stored reference inclination (protocol 5, the document's reference)
/// is what the board judges the dip against, with calib-core's
/// `OnlineIntegrity::for_stored` bit for bit: the true dip (64.2°) keeps the
/// stream `ok`; a reference 15° off — a calibration that does not fit this
/// field — is never `ok` after the first 2 s; with none the board learns
/// the dip from the stream it judges and says `unjudged`, never `ok`.
#[test]
fn the_stored_reference_inclination_judges_the_dip() {
    use calib_core::online::OnlineIntegrity;
    use magcal_protocol::Integrity;
    let sensor = EnvSensor::new();
    let run = turning_run(&sensor, 300, 0..0);
    let true_dip = 1.12f32;
    for (inclination, want_ok) in [(Some(true_dip), true), (Some(true_dip - 15f32.to_radians()), false), (None, false)] {
        let mut c = sensor.coefficients(false);
        c.inclination_rad = inclination.unwrap_or(Coefficients::NO_INCLINATION);
        assert_eq!(c.inclination(), inclination);
        let (mut d, mut s) = env_device(c);
        let cal = validate(&c).unwrap();
        let mut reference = OnlineIntegrity::<f32>::for_stored(c.field_nt, inclination).unwrap();
        let (mut ok, mut unjudged) = (0usize, 0usize);
        for (k, (raw, motion, _)) in run.iter().enumerate() {
            let now = 1_000 + 100 * k as u32;
            assert_eq!(req(&mut d, motion.clone(), now - 5, &mut s), ResponseBody::Ack);
            let out = d.on_raw_sample(raw, now).unwrap();
            let RequestBody::Motion { roll_rad, pitch_rad, rate_rad_s } = *motion else { unreachable!() };
            let dt = if k == 0 { f32::NAN } else { 0.1f32 };
            let corrected = cal.env.correct_raw(raw.field_counts, &calib_core::cal::Environment { current_a: 0.0, temp_c: sensor.t0_c as f32 });
            let j = reference.process(&cal, corrected, Some(&calib_core::heading::Tilt::new(roll_rad, pitch_rad)), Some(rate_rad_s), dt);
            assert_eq!(out.integrity, j.verdict.state, "{inclination:?}: sample {k}");
            if k >= 20 && out.integrity == Integrity::Ok {
                ok += 1;
            }
            if k >= 20 && out.integrity == Integrity::Unjudged {
                unjudged += 1;
            }
        }
        let frac = ok as f64 / 280.0;
        assert!(if want_ok { frac > 0.95 } else { frac == 0.0 }, "{inclination:?}: {frac} ok");
        if inclination.is_none() {
            // Without a reference the stream passes its own checks: unjudged.
            assert!(unjudged as f64 / 280.0 > 0.95, "{unjudged}");
        }
    }
    // A dip at or beyond the vertical is refused before staging.
    let mut c = sensor.coefficients(false);
    c.inclination_rad = 1.6;
    assert_eq!(validate(&c), Err(DeviceError::InvalidCoefficients));
}
