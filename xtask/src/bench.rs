//! `cargo xtask bench`: accuracy benchmarks whose numbers go into the README.
//! Writes `target/bench/results.json` and `target/bench/results.md`.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use calib_core::conformance::{paper001_sample, tumble_sample, SplitMix64, PAPER001_TRUTH, TUMBLE_FIELD_NT};
use calib_core::fit::{fit_batch, Full, FullRls, Normalization};
use calib_core::ortho::{identify_all_samples, identify_linear, identify_ml, identify_pairwise, j_index};
use serde_json::json;

mod compass;
mod import_speed;
mod integrity;
mod real_data;
mod varied;

const PAIRS: [usize; 7] = [30, 60, 120, 240, 480, 720, 1440];
const SIGMAS: [f64; 5] = [0.0, 1e-4, 1e-3, 1e-2, 3e-2];
const SEEDS: u64 = 20;

/// Paper 001 §5.1: mean J over seeds for each N (pairs) and σ, both solvers.
fn paper001() -> (serde_json::Value, String) {
    let mut rows = Vec::new();
    let mut md = String::from("| σ | solver | ");
    for n in PAIRS {
        let _ = write!(md, "N={n} | ");
    }
    md.push_str("\n|---|---|");
    md.push_str(&"---|".repeat(PAIRS.len()));
    md.push('\n');
    for sigma in SIGMAS {
        for (name, solver) in [
            ("pairwise (paper)", identify_pairwise::<f64> as fn(&[[f64; 3]], [f64; 3]) -> _),
            ("linear + Cholesky", identify_linear::<f64>),
        ] {
            let _ = write!(md, "| {sigma:e} | {name} | ");
            for n in PAIRS {
                let mut js = Vec::new();
                for seed in 0..SEEDS {
                    let mut rng = SplitMix64::new(1000 * seed + n as u64);
                    let data: Vec<[f64; 3]> = (0..2 * n).map(|_| paper001_sample(&mut rng, sigma)).collect();
                    if let Ok(Some(a)) = solver(&data, [0.0; 3]).map(|t| t.angles()) {
                        js.push(j_index(&PAPER001_TRUTH, &a));
                    }
                }
                let mean = js.iter().sum::<f64>() / js.len().max(1) as f64;
                let failed = SEEDS as usize - js.len();
                rows.push(json!({"sigma": sigma, "solver": name, "pairs": n, "mean_j": mean, "failures": failed}));
                let _ = write!(md, "{mean:.2e}{} | ", if failed > 0 { format!(" ({failed} failed)") } else { String::new() });
            }
            md.push('\n');
        }
    }
    same_data(&mut rows, &mut md);
    (json!(rows), md)
}

/// Noise levels of the same-data comparison.
const SAME_DATA_SIGMAS: [f64; 5] = [1e-3, 1e-2, 3e-2, 0.1, 0.2];

/// Paper 001 beaten on its own terms: on the same 1 440 samples, the paper's
/// pairing (720 disjoint pairs, its solver), our objective over every sample,
/// and the maximum-likelihood (distance) refinement; mean J over the seeds.
fn same_data(rows: &mut Vec<serde_json::Value>, md: &mut String) {
    const SAMPLES: usize = 1440;
    let _ = write!(
        md,
        "\n**Same data, {SAMPLES} samples** (mean J over {SEEDS} seeds; the paper pairs them into 720 disjoint pairs):\n\n| σ | pairing (paper) | every sample | every sample + ML |\n|---|---|---|---|\n"
    );
    type Solve = fn(&[[f64; 3]], [f64; 3]) -> Option<calib_core::ortho::OrthoAngles<f64>>;
    let solvers: [(&str, Solve); 3] = [
        ("same data: pairing (paper)", |d, b| identify_pairwise(d, b).ok()?.angles()),
        ("same data: every sample", |d, b| identify_all_samples(d, b).ok()?.angles()),
        ("same data: every sample + ML", |d, b| identify_ml(d, b).ok()?.tri.angles()),
    ];
    for sigma in SAME_DATA_SIGMAS {
        let _ = write!(md, "| {sigma:e} | ");
        for (name, solve) in solvers {
            let js: Vec<f64> = (0..SEEDS)
                .filter_map(|seed| {
                    let mut rng = SplitMix64::new(7000 + seed);
                    let data: Vec<[f64; 3]> = (0..SAMPLES).map(|_| paper001_sample(&mut rng, sigma)).collect();
                    solve(&data, [0.0; 3]).map(|a| j_index(&PAPER001_TRUTH, &a))
                })
                .collect();
            let mean = js.iter().sum::<f64>() / js.len().max(1) as f64;
            let failed = SEEDS as usize - js.len();
            rows.push(json!({"sigma": sigma, "solver": name, "samples": SAMPLES, "mean_j": mean, "failures": failed}));
            let _ = write!(md, "{mean:.4}{} | ", if failed > 0 { format!(" ({failed} failed)") } else { String::new() });
        }
        md.push('\n');
    }
}

/// Issue 3's f32 check, measured: the recursive full fit in f32 (bit-identical
/// to the MCU's) against the f64 batch fit of the same tumble.
fn f32_vs_f64() -> serde_json::Value {
    let mut rng = SplitMix64::new(2024);
    let samples: Vec<[f64; 3]> = (0..2400).map(|_| tumble_sample(&mut rng)).collect();
    let batch = fit_batch::<Full, 9, f64>(&samples, TUMBLE_FIELD_NT).ok();
    let mut rls = FullRls::<f32>::new(Normalization { centre: [0.0; 3], scale: TUMBLE_FIELD_NT as f32 });
    for s in &samples {
        rls.push(s.map(|v| v as f32));
    }
    match (batch, rls.estimate(TUMBLE_FIELD_NT as f32)) {
        (Some(b), Ok(r)) => {
            let bias_err = (0..3).map(|k| (f64::from(r.bias[k]) - b.bias[k]).abs()).fold(0.0, f64::max);
            let num: f64 = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| (f64::from(r.matrix[i][j]) - b.matrix[i][j]).powi(2)).sum();
            let den: f64 = b.matrix.iter().flatten().map(|v| v * v).sum();
            json!({"samples": 2400, "bias_max_abs_diff": bias_err, "matrix_rel_diff": (num / den).sqrt()})
        }
        _ => json!({"error": "fit failed"}),
    }
}

/// Paper 000's field test, simulated for several seeds and two vehicles.
fn paper000() -> (serde_json::Value, String) {
    use magcal_sim::{evaluate, SensorModel};
    let mut rows = Vec::new();
    let mut md = String::from(
        "| vehicle | seed | step: axis fit | paper | ours (nT) | heading RMS: axis fit | paper | ours (°) | field error: paper | ours (nT) | GPS delay (s) |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (name, sensor) in [("paper-like", SensorModel::paper_like()), ("hull-coupled", SensorModel::hull_coupled())] {
        for seed in 1..=5 {
            let o = match evaluate(name, sensor, seed) {
                Ok(o) => o,
                Err(e) => {
                    let _ = writeln!(md, "| {name} | {seed} | failed: {e} |");
                    rows.push(json!({"vehicle": name, "seed": seed, "error": e.to_string()}));
                    continue;
                }
            };
            let _ = writeln!(
                md,
                "| {name} | {seed} | {:.0} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {:.0} | {:.1} | {:.2} |",
                o.step_axis_fit_nt, o.step_paper_nt, o.step_ours_nt, o.heading_rms_axis_fit_deg, o.heading_rms_paper_deg, o.heading_rms_ours_deg, o.field_error_paper_nt, o.field_error_ours_nt, o.gps_delay_ours_s
            );
            rows.push(json!({"vehicle": name, "seed": seed, "outcome": o}));
        }
    }
    (json!(rows), md)
}

/// The simulated half of [`limited_tilt`]: the swing test at ±55° / ±10°
/// and ±15° / ±5°, with and without a gyro, three seeds each.
fn limited_tilt_simulated() -> (Vec<serde_json::Value>, String) {
    use magcal_sim::scenario::{evaluate_limited, LimitedSwing};
    use magcal_sim::SensorModel;

    let mut md = String::from("Simulated (paper-like hull, our chain, validation run):\n\n| swing test | gyro | seed | heading RMS (°) | field error (nT) |\n|---|---|---|---|---|\n");
    let mut sim_rows = Vec::new();
    for (roll, pitch) in [(55.0, 10.0), (15.0, 5.0)] {
        for gyro in [false, true] {
            for seed in 1..=3 {
                let kind = LimitedSwing { roll_amp_deg: roll, pitch_amp_deg: pitch, gyro };
                match evaluate_limited(SensorModel::paper_like(), seed, kind) {
                    Ok(o) => {
                        let cell = match (&o.heading_rms_deg, &o.refused) {
                            (Some(h), _) => format!("{h:.3} | {:.1}", o.field_error_nt.unwrap_or(f64::NAN)),
                            (None, Some(r)) => format!("refused: {r} | —"),
                            _ => "— | —".into(),
                        };
                        let _ = writeln!(md, "| ±{roll}° / ±{pitch}° | {} | {seed} | {cell} |", if gyro { "yes" } else { "no" });
                        sim_rows.push(json!(o));
                    }
                    Err(e) => {
                        let _ = writeln!(md, "| ±{roll}° / ±{pitch}° | {gyro} | {seed} | failed: {e} | |");
                    }
                }
            }
        }
    }
    (sim_rows, md)
}

/// Issue 15: a vehicle that cannot tumble. The simulated swing test at the
/// paper's ±55° / ±10° and at ±15° / ±5°, with and without a gyro (our
/// chain each time); and the real BROAD trial 05 data: magcal's gyro-aided
/// fit against the true calibration, the sphere fit and the peers shipped
/// in the `magyc` package (MAGYC-LS/NLS, TWOSTEP, SAR-LS, ellipsoid fit)
/// when it installs.
fn limited_tilt(root: &Path) -> (serde_json::Value, String) {
    use calib_core::cal::{FieldCal, ModelKind};
    use calib_core::heading::magnetic_heading_rad;
    use host_tools::compute::{fit_recording, truth, FitOptions};
    use host_tools::data::Recording;

    let (sim_rows, mut md) = limited_tilt_simulated();
    // broad-05.
    let dir = root.join("tests/data/broad-05");
    let (Ok(calib), Ok(validate)) = (Recording::read(&dir.join("05_calib.csv")), Recording::read(&dir.join("05_validate.csv"))) else {
        return (json!({"simulated": sim_rows, "broad05": "tests/data/broad-05 missing"}), md);
    };
    let optical: Vec<f64> = host_tools::compute::card::read_reference_column(&dir.join("05_validate.csv"), "truth_heading_deg").ok().flatten().unwrap_or_default();
    let heading = |cal: &FieldCal<f64>| {
        let (Some(roll), Some(pitch)) = (validate.roll_deg.as_ref(), validate.pitch_deg.as_ref()) else { return f64::NAN };
        let h = (0..validate.len()).map(|i| magnetic_heading_rad(cal.apply(validate.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
        truth::heading_rms_after_offset_deg(h.zip(optical.iter().copied())).0.rms
    };
    let lab_field_nt = 44_204.0;
    let mut rows: Vec<(String, Option<f64>, String)> = Vec::new();
    #[derive(serde::Deserialize)]
    struct Cal {
        bias: [f64; 3],
        matrix: [[f64; 3]; 3],
    }
    if let Some(t) = std::fs::read_to_string(dir.join("05.truth.json")).ok().and_then(|s| serde_json::from_str::<Cal>(&s).ok()) {
        rows.push(("the true calibration (the floor)".into(), Some(heading(&FieldCal { bias: t.bias, matrix: t.matrix })), String::new()));
    }
    rows.push(("none (raw counts)".into(), Some(heading(&FieldCal::identity())), String::new()));
    let opts = |model| FitOptions { model, field_nt: lab_field_nt, saturation: None, allow_weak: false, gyro_lag: host_tools::compute::GyroLag::Given(0.0), reference: None };
    let started = std::time::Instant::now();
    match fit_recording(&calib, &opts(ModelKind::Gyro)) {
        Ok(doc) => {
            let predicted = doc.quality.predicted_heading_rms_deg.unwrap_or(f64::NAN);
            rows.push(("magcal gyro-aided (`fit --model gyro`)".into(), Some(heading(&doc.field_cal())), format!("{:.0} ms; predicted {predicted:.2}° (noise only)", started.elapsed().as_secs_f64() * 1e3)));
        }
        Err(e) => rows.push(("magcal gyro-aided".into(), None, e.to_string())),
    }
    match fit_recording(&calib, &opts(ModelKind::Sphere)) {
        Ok(doc) => rows.push(("magcal sphere".into(), Some(heading(&doc.field_cal())), "accepted".into())),
        Err(e) => rows.push(("magcal sphere".into(), None, format!("refused: {e}"))),
    }
    if let Ok(doc) = fit_recording(&calib, &FitOptions { allow_weak: true, ..opts(ModelKind::Sphere) }) {
        rows.push(("magcal sphere with --allow-weak".into(), Some(heading(&doc.field_cal())), "what a silent acceptance gave".into()));
    }
    // The peers, in Python (their own code), when `magyc` imports or installs.
    let script = root.join("xtask/bench/magyc_broad05.py");
    let python = |args: &[&str]| std::process::Command::new("python3").args(args).output().ok().filter(|o| o.status.success());
    if python(&["-c", "import magyc"]).is_none() {
        let _ = python(&["-m", "pip", "install", "-q", "magyc"]);
    }
    let calib_csv = dir.join("05_calib.csv");
    let field_counts = format!("{}", lab_field_nt / 10.0);
    match python(&[&script.to_string_lossy(), &calib_csv.to_string_lossy(), &field_counts]).and_then(|o| serde_json::from_slice::<serde_json::Value>(&o.stdout).ok()) {
        Some(peers) => {
            for name in ["MAGYC-LS", "MAGYC-NLS", "TWOSTEP", "SAR-LS", "ellipsoid fit"] {
                match serde_json::from_value::<Cal>(peers[name].clone()) {
                    Ok(c) => rows.push((format!("magyc {name}"), Some(heading(&FieldCal { bias: c.bias, matrix: c.matrix })), String::new())),
                    Err(_) => rows.push((format!("magyc {name}"), None, peers[name]["error"].as_str().unwrap_or("no answer").to_string())),
                }
            }
        }
        None => rows.push(("magyc (PyPI)".into(), None, "not available here (pip install magyc failed)".into())),
    }
    let _ = writeln!(md, "\nReal data, BROAD trial 05 (`tests/data/broad-05`, |roll|, |pitch| ≤ 25°): calibration part in, heading RMS on the validation part against the optical reference out (one constant offset removed):\n\n| calibration | heading RMS (°) | note |\n|---|---|---|");
    for (name, h, note) in &rows {
        let _ = writeln!(md, "| {name} | {} | {note} |", h.map_or("—".into(), |v| format!("{v:.2}")));
    }
    let broad: Vec<_> = rows.iter().map(|(n, h, note)| json!({"calibration": n, "heading_rms_deg": h, "note": note})).collect();
    (json!({"simulated": sim_rows, "broad05": broad}), md)
}

/// Instruction counts on the Cortex-M4F: the `mcu-bench` firmware binary
/// under QEMU with `-icount shift=0,sleep=off` (1 ns of virtual time per
/// instruction; SysTick at the emulated 168 MHz counts them).
fn mcu_costs(root: &Path) -> Result<serde_json::Value> {
    let status = std::process::Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
        .current_dir(root)
        .args(["build", "--release", "-p", "firmware", "--target", "thumbv7em-none-eabihf", "--bins"])
        .status()?;
    anyhow::ensure!(status.success(), "building mcu-bench failed");
    let elf = root.join("target/thumbv7em-none-eabihf/release/mcu-bench");
    let out = std::process::Command::new("timeout")
        .arg("120")
        .args(["qemu-system-arm", "-machine", "netduinoplus2", "-display", "none", "-monitor", "none", "-serial", "null", "-serial", "null"])
        .args(["-icount", "shift=0,sleep=off", "-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(&elf)
        .output()?;
    anyhow::ensure!(out.status.success(), "mcu-bench failed under QEMU: {}", String::from_utf8_lossy(&out.stderr));
    let mut v = serde_json::Map::new();
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        if let Some((k, n)) = line.split_once(' ') {
            if let Ok(n) = n.trim().parse::<u64>() {
                v.insert(k.to_string(), json!(n));
            }
        }
    }
    anyhow::ensure!(v.get("scale_check_20000_instructions") == Some(&json!(20000)), "the instruction count is not calibrated: {v:?}");
    Ok(serde_json::Value::Object(v))
}

/// The board's CPU budget at its pair rate: the instructions counted under
/// `-icount` plus the time the CPU cannot do anything else — the polled SPI
/// bytes at the configured SCLK, the strap pulses' busy-wait — and the
/// interrupts (DRDY per conversion read, USART per byte sent). Interrupt
/// costs are estimates: 12 cycles in and 12 out (Cortex-M4 TRM §3.9,
/// exception latency) plus the handler and the async task's wake-up.
fn cpu_budget(mcu: &serde_json::Value) -> serde_json::Value {
    use firmware::acquisition::{FRAMES_PER_PAIR, PAIR_RATE_HZ, STRAP_PULSE_US};
    use firmware::clocks::{ADC_CLKIN_HZ, SPI_SCLK_HZ};
    use firmware::layout;
    const SYSCLK_HZ: f64 = firmware::clocks::BOARD_SYSCLK_HZ as f64;
    const FRAME_BYTES: f64 = firmware::adc::FRAME_BYTES as f64;
    // Polled SPI: per byte, wait TXE, write DR, wait RXNE, read DR.
    const INSTR_PER_SPI_BYTE: f64 = 12.0;
    // DRDY: exception entry/exit 24 cycles, EXTI pending clear and signal
    // write ~30, the executor polling the acquisition future ~150.
    const CYCLES_PER_DRDY: f64 = 24.0 + 30.0 + 150.0;
    // USART1 TX: one interrupt per byte, ~60 cycles with entry/exit.
    const CYCLES_PER_TX_BYTE: f64 = 60.0;
    // A streamed sample frame (COBS + CRC), bytes.
    const SAMPLE_FRAME_BYTES: f64 = 48.0;
    const OUTPUT_RATE_HZ: f64 = 100.0;
    let get = |k: &str| mcu.get(k).and_then(serde_json::Value::as_u64).unwrap_or(0) as f64;
    let pair_rate = f64::from(PAIR_RATE_HZ);
    let frames = f64::from(FRAMES_PER_PAIR);
    let spi_bytes = frames * FRAME_BYTES;
    let per_pair_us = [
        ("driver_instructions", get("acquisition_cycle_instructions") / SYSCLK_HZ * 1e6),
        ("spi_bus_wait", spi_bytes * 8.0 / f64::from(SPI_SCLK_HZ) * 1e6),
        ("spi_polling_instructions", spi_bytes * INSTR_PER_SPI_BYTE / SYSCLK_HZ * 1e6),
        ("strap_pulses", 2.0 * f64::from(STRAP_PULSE_US)),
        ("drdy_interrupts", frames * CYCLES_PER_DRDY / SYSCLK_HZ * 1e6),
    ];
    let per_sample_us = [
        // The device's per-sample path: current and temperature terms,
        // field, heading (`apply_heading_instructions` is without the terms).
        ("apply_and_heading", get("apply_env_heading_instructions") / SYSCLK_HZ * 1e6),
        // The integrity on a usual sample (the calibration fitting): what
        // the device's path adds to apply + heading on the same turn.
        ("integrity", (get("integrity_ok_turn_instructions") - get("apply_heading_turn_instructions")).max(0.0) / SYSCLK_HZ * 1e6),
        ("onboard_full_fit_update", get("rls_full_update_instructions") / SYSCLK_HZ * 1e6),
        ("usart_tx_interrupts", SAMPLE_FRAME_BYTES * CYCLES_PER_TX_BYTE / SYSCLK_HZ * 1e6),
    ];
    let pair_us: f64 = per_pair_us.iter().map(|(_, v)| v).sum();
    let sample_us: f64 = per_sample_us.iter().map(|(_, v)| v).sum();
    let busy_pct = (pair_rate * pair_us + OUTPUT_RATE_HZ * sample_us) * 1e-6 * 100.0;
    // The worst case: every sample with the stored calibration invalid (or
    // the on-line hard iron applied), the estimator running.
    let estimating_extra_us = (get("integrity_cal_invalid_instructions") - get("integrity_ok_turn_instructions")).max(0.0) / SYSCLK_HZ * 1e6;
    let busy_estimating_pct = busy_pct + OUTPUT_RATE_HZ * estimating_extra_us * 1e-6 * 100.0;
    let breakdown = |rows: &[(&str, f64)]| rows.iter().map(|(k, v)| ((*k).to_string(), json!((v * 100.0).round() / 100.0))).collect::<serde_json::Map<_, _>>();
    json!({
        "cpu_busy_pct_at_pair_rate": (busy_pct * 100.0).round() / 100.0,
        "cpu_busy_pct_at_pair_rate_estimating": (busy_estimating_pct * 100.0).round() / 100.0,
        "pair_rate_hz": PAIR_RATE_HZ,
        "output_rate_hz": OUTPUT_RATE_HZ,
        "spi_sclk_hz": SPI_SCLK_HZ,
        "per_pair_us": breakdown(&per_pair_us),
        "per_output_sample_us": breakdown(&per_sample_us),
        "conversion_wait_per_pair_us_not_busy": 2.0 * f64::from(firmware::acquisition::SETTLE_CONVERSIONS as u32 + 1) * f64::from(firmware::adc::Osr::X128.conversion_period_ns(ADC_CLKIN_HZ)) / 1000.0,
        "worst_store_stall_ms": layout::worst_store_stall_ms(),
        "watchdog_timeout_ms": layout::watchdog_min_timeout_ms(),
        "watchdog_timeout_nominal_ms": layout::WATCHDOG_TIMEOUT_MS,
        "targets": {"cpu_busy_pct_at_pair_rate_max": 10.0, "watchdog_over_worst_stall_min": 2.0, "apply_env_heading_instructions_max": 300, "flash_bytes_max": crate::size::FLASH_BUDGET_BYTES},
    })
}

/// Host throughput: batch and recursive full fits over 10⁶ samples, IGRF
/// evaluations per second, and numpy doing the same batch fit (when numpy is
/// installed) as a ratio.
fn host_throughput(root: &Path) -> serde_json::Value {
    use calib_core::conformance::{tumble_sample, SplitMix64, TUMBLE_FIELD_NT};
    use std::time::Instant;
    const N: usize = 1_000_000;
    let mut rng = SplitMix64::new(3);
    let samples: Vec<[f64; 3]> = (0..N).map(|_| tumble_sample(&mut rng)).collect();
    let t = Instant::now();
    let batch = fit_batch::<Full, 9, f64>(&samples, TUMBLE_FIELD_NT);
    let batch_s = t.elapsed().as_secs_f64();
    let mut rls = FullRls::<f64>::new(Normalization { centre: [0.0; 3], scale: TUMBLE_FIELD_NT });
    let t = Instant::now();
    for s in &samples {
        rls.push(*s);
    }
    let rls_s = t.elapsed().as_secs_f64();
    let mut rls32 = FullRls::<f32>::new(Normalization { centre: [0.0; 3], scale: TUMBLE_FIELD_NT as f32 });
    let t = Instant::now();
    for s in &samples {
        rls32.push(s.map(|v| v as f32));
    }
    let rls32_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut acc = 0.0;
    let evals = 20_000;
    for k in 0..evals {
        let lat = -80.0 + 160.0 * (k as f64 / evals as f64);
        if let Ok(f) = host_tools::geomag::igrf14(lat, (k % 360) as f64 - 180.0, 0.0, 2026.5) {
            acc += f.total_nt();
        }
    }
    let igrf_s = t.elapsed().as_secs_f64();
    let numpy = std::process::Command::new("python3")
        .arg(root.join("xtask/python/numpy_fit.py"))
        .arg(N.to_string())
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| serde_json::from_slice::<serde_json::Value>(&o.stdout).ok());
    let ratio = numpy.as_ref().and_then(|v| v["numpy_full_fit_s"].as_f64()).map(|np| batch_s / np);
    json!({
        "samples": N,
        "batch_full_fit_s": batch_s,
        "batch_full_fit_ok": batch.is_ok(),
        "recursive_full_f64_s": rls_s,
        "recursive_full_f32_s": rls32_s,
        "igrf_evaluations_per_s": evals as f64 / igrf_s,
        "igrf_checksum": acc,
        "numpy": numpy,
        "batch_time_over_numpy": ratio,
    })
}

/// The real recordings in `tests/data`: magnitude spread before and after
/// the full-ellipsoid fit (the agreement with an independent Li & Griffiths
/// fit is asserted by `cargo test -p host-tools --test real real_data`).
fn real_recordings(root: &Path) -> serde_json::Value {
    // CSV through the product's reader under a column mapping; bazhin's
    // file is bare `x y z` lines without a header (not a table).
    let load = |rel: &str, cols: [&str; 3]| -> Vec<[f64; 3]> {
        let path = root.join("tests/data").join(rel);
        if cols[0].is_empty() {
            let Ok(text) = std::fs::read_to_string(&path) else { return vec![] };
            return text.lines().filter_map(|l| {
                let v: Vec<f64> = l.split_whitespace().filter_map(|x| x.parse().ok()).collect();
                (v.len() == 3).then(|| [v[0], v[1], v[2]])
            }).collect();
        }
        let map = format!("mx={},my={},mz={}", cols[0], cols[1], cols[2]);
        let rec = map.parse().ok().and_then(|map| host_tools::data::Recording::read_mapped(&path, &map).ok());
        rec.map(|r| r.complete_mag().1).unwrap_or_default()
    };
    let spread = |samples: &[[f64; 3]], cal: &calib_core::cal::FieldCal<f64>| {
        let m: Vec<f64> = samples.iter().map(|s| { let h = cal.apply(*s); (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() }).collect();
        let mean = m.iter().sum::<f64>() / m.len().max(1) as f64;
        100.0 * (m.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / m.len().max(1) as f64).sqrt() / mean
    };
    let mut out = Vec::new();
    for (name, rel, cols) in [
        ("sunsided-full-sphere", "sunsided-full-sphere/hmc5883l_compass.csv", ["mag_x_gauss", "mag_y_gauss", "mag_z_gauss"]),
        ("ck-explorer", "ck-explorer/acc_mag_log.csv", ["mx", "my", "mz"]),
        ("bazhin", "bazhin/mag_out.txt", ["", "", ""]),
    ] {
        let s = load(rel, cols);
        let fitted = fit_batch::<Full, 9, f64>(&s, 1.0);
        out.push(json!({
            "recording": name,
            "samples": s.len(),
            "spread_before_pct": spread(&s, &calib_core::cal::FieldCal::identity()),
            "spread_after_pct": fitted.as_ref().map(|c| spread(&s, c)).ok(),
        }));
    }
    json!(out)
}

/// One log shape of the merge section: simulated logs cut into a board log
/// and a navigation log (every `nav_every`-th row, with the heading
/// `nav_heading` says) whose clocks differ by ±60 s and ±100 ppm, merged
/// with the offset searched within ±120 s; the offset and drift errors and
/// their stated σ per case, then over the cases the worst error and the
/// RMS error over the RMS σ (1 when the σ tells the truth).
fn merge_rate(
    label: &str,
    target_ms: f64,
    sim: &dyn Fn(u64) -> Option<magcal_sim::field_test::Simulation>,
    nav_every: usize,
    nav_heading: magcal_sim::logs::NavHeading,
    md: &mut String,
) -> serde_json::Value {
    use host_tools::data::merge::{merge, Clock};
    use magcal_sim::logs::{split, LogSplit};
    let estimate = Clock::Estimate { center_s: 0.0, max_offset_s: 120.0 };
    let (mut rows, mut errors) = (Vec::new(), Vec::new());
    for base in MERGE_SHAPE_SEEDS {
        for (k, (offset_s, drift_ppm)) in [(60.0f64, 100.0f64), (60.0, -100.0), (-60.0, 100.0), (-60.0, -100.0)].into_iter().enumerate() {
            // Each case its own noise (its own simulation), so the RMS
            // error over the RMS σ is measured on as many realisations.
            let seed = 4 * base + k as u64;
            let Some(sim) = sim(seed) else { continue };
            // A little off the round numbers, so no grid lines up by chance.
            let offset_s = offset_s - 0.0137 * offset_s.signum() * base as f64;
            let (board, nav) = split(&sim, &LogSplit { offset_s, drift_ppm, nav_every, trim_s: (20.0, 15.0), seed, nav_heading });
            match merge(&board, &nav, estimate) {
                Ok(m) => {
                    let r = &m.report;
                    let (e_ms, e_ppm, s_ms) = ((r.offset_s - offset_s) * 1e3, r.drift_ppm - drift_ppm, r.offset_sigma_s * 1e3);
                    errors.push((e_ms, s_ms));
                    let _ = writeln!(md, "| {label} | {seed} | {offset_s:.4} | {drift_ppm} | {e_ms:+.2} | {s_ms:.2} | {:+.2} | {e_ppm:+.1} | {:.1} |", e_ms / s_ms, r.drift_sigma_ppm);
                    rows.push(json!({"seed": seed, "offset_s": offset_s, "drift_ppm": drift_ppm, "offset_error_ms": e_ms, "offset_sigma_ms": s_ms, "drift_error_ppm": e_ppm, "drift_sigma_ppm": r.drift_sigma_ppm}));
                }
                Err(e) => {
                    let _ = writeln!(md, "| {label} | {seed} | {offset_s:.4} | {drift_ppm} | refused: {e} | | | | |");
                    rows.push(json!({"seed": seed, "offset_s": offset_s, "drift_ppm": drift_ppm, "error": e.to_string()}));
                }
            }
        }
    }
    let n = errors.len().max(1) as f64;
    let worst_ms = errors.iter().map(|e| e.0.abs()).fold(0.0, f64::max);
    let rms = |f: fn(&(f64, f64)) -> f64| (errors.iter().map(|e| f(e).powi(2)).sum::<f64>() / n).sqrt();
    let (rms_error_ms, rms_sigma_ms) = (rms(|e| e.0), rms(|e| e.1));
    json!({"rate": label, "cases": rows, "merged": errors.len(), "refused": rows.len() - errors.len(), "target_ms": target_ms, "worst_offset_error_ms": worst_ms, "rms_offset_error_ms": rms_error_ms, "rms_offset_sigma_ms": rms_sigma_ms, "error_over_sigma": rms_error_ms / rms_sigma_ms})
}

/// Seeds of the merge section's chain on merged logs.
const MERGE_SEEDS: [u64; 3] = [11, 12, 13];

/// Seeds of the merge section's clock tables: each with four clocks, each
/// clock its own simulation (seed 4·s + k), so that the RMS error over the
/// RMS stated σ is measured on 24 noise realisations per log shape.
const MERGE_SHAPE_SEEDS: [u64; 6] = [11, 12, 13, 14, 15, 16];

/// The clock tables of the merge section ([`merge_rate`], one per log
/// shape): swing tests with a 50 Hz board and a 10 Hz navigation log (with
/// the AHRS heading); swing tests with both logs at 5 Hz, with the AHRS
/// heading and without a heading column (roll, pitch, position only);
/// out-and-back runs with both logs at 1 Hz; and runs of 400 s of circles
/// at the surface then the legs with their dives, both logs at 1 Hz, whose
/// only heading is the GPS course at the surface (issue 29's two shapes).
fn merge_shapes() -> (Vec<serde_json::Value>, String) {
    use magcal_sim::field_test::{self, paper_site, RunKind, RunParams, SensorModel};
    use magcal_sim::logs::NavHeading;
    let (sensor, site) = (SensorModel::paper_like(), paper_site());
    let mut md = String::from("| logs | seed | offset put in (s) | drift put in (ppm) | offset error (ms) | offset σ (ms) | error / σ | drift error (ppm) | drift σ (ppm) |\n|---|---|---|---|---|---|---|---|---|\n");
    let swing = |rate_hz: f64| move |seed: u64| field_test::swing(&sensor, &site, seed, rate_hz).ok();
    let rates = vec![
        merge_rate("swing, board 50 Hz, navigation 10 Hz", 20.0, &swing(50.0), 5, NavHeading::Ahrs, &mut md),
        merge_rate("swing, both 5 Hz", 20.0, &swing(5.0), 1, NavHeading::Ahrs, &mut md),
        merge_rate("swing, both 5 Hz, no heading column", 20.0, &swing(5.0), 1, NavHeading::None, &mut md),
        merge_rate("run, both 1 Hz", 50.0, &|seed| field_test::run(&sensor, &site, &RunParams::paper_like(), seed + 50, 1.0, RunKind::Run).ok(), 1, NavHeading::Ahrs, &mut md),
        merge_rate(
            "circles then legs, both 1 Hz, GPS course at the surface only",
            50.0,
            &|seed| field_test::run(&sensor, &site, &RunParams::circles_then_legs(400.0), seed + 60, 1.0, RunKind::Run).ok(),
            1,
            NavHeading::CourseOnly,
            &mut md,
        ),
    ];
    md.push_str("\n| logs | merged | refused | worst offset error (ms) | target (ms) | RMS error (ms) | RMS stated σ (ms) | RMS error / RMS σ (0.5–2 asked) |\n|---|---|---|---|---|---|---|---|\n");
    for r in &rates {
        let f = |k: &str| r[k].as_f64().unwrap_or(f64::NAN);
        let _ = writeln!(md, "| {} | {} | {} | {:.2} | {} | {:.2} | {:.2} | {:.2} |", r["rate"].as_str().unwrap_or(""), r["merged"], r["refused"], f("worst_offset_error_ms"), f("target_ms"), f("rms_offset_error_ms"), f("rms_offset_sigma_ms"), f("error_over_sigma"));
    }
    md.push('\n');
    (rates, md)
}

/// Issue 14's, 22's and 29's `merge` numbers: the clock tables
/// ([`merge_shapes`]); then, per seed, the validation heading RMS of the
/// chain (axis fit → back-stepping → swing fit) on merged 50 Hz logs
/// against the single-clock recordings they were cut from.
fn merge_clocks() -> (serde_json::Value, String) {
    use host_tools::compute::{self, ChainOptions};
    use host_tools::data::merge::{merge, Clock};
    use magcal_sim::field_test::{self, paper_site, RunKind, RunParams, SensorModel};
    use magcal_sim::logs::{split, LogSplit, NavHeading};
    use magcal_sim::scenario::heading_rms_deg;
    let estimate = Clock::Estimate { center_s: 0.0, max_offset_s: 120.0 };
    let (sensor, site) = (SensorModel::paper_like(), paper_site());
    let (rates, mut md) = merge_shapes();
    // The clocks' tables now: the chain below takes minutes.
    eprintln!("{md}");

    md.push_str("| seed | validation heading RMS, single clock (°) | from merged logs (°) | difference (°) |\n|---|---|---|---|\n");
    let mut headings = Vec::new();
    for seed in MERGE_SEEDS {
        let opts = ChainOptions::default();
        let sims = (
            field_test::swing(&sensor, &site, seed + 100, 50.0),
            field_test::run(&sensor, &site, &RunParams::paper_like(), seed + 200, 25.0, RunKind::Run),
            field_test::run(&sensor, &site, &RunParams::validation(), seed + 300, 2.0, RunKind::Validation),
        );
        let (Ok(swing), Ok(run), Ok(validation)) = sims else { continue };
        let (sb, sn) = split(&swing, &LogSplit { offset_s: 41.3, drift_ppm: 80.0, nav_every: 5, trim_s: (10.0, 10.0), seed, nav_heading: NavHeading::Ahrs });
        let (rb, rn) = split(&run, &LogSplit { offset_s: -23.9, drift_ppm: -60.0, nav_every: 5, trim_s: (10.0, 10.0), seed, nav_heading: NavHeading::Ahrs });
        let result = (|| -> Result<(f64, f64), String> {
            let single = compute::calibrate(&swing.recording, &run.recording, &site, &opts).map_err(|e| e.to_string())?;
            let ms = merge(&sb, &sn, estimate).map_err(|e| e.to_string())?;
            let mr = merge(&rb, &rn, estimate).map_err(|e| e.to_string())?;
            let merged = compute::calibrate(&ms.recording, &mr.recording, &site, &opts).map_err(|e| e.to_string())?;
            Ok((heading_rms_deg(&single.final_doc, &validation), heading_rms_deg(&merged.final_doc, &validation)))
        })();
        match result {
            Ok((h1, h2)) => {
                let _ = writeln!(md, "| {seed} | {h1:.4} | {h2:.4} | {:+.4} |", h2 - h1);
                headings.push(json!({"seed": seed, "single_clock_deg": h1, "merged_deg": h2, "difference_deg": h2 - h1}));
            }
            Err(e) => {
                let _ = writeln!(md, "| {seed} | refused: {e} | | |");
                headings.push(json!({"seed": seed, "error": e}));
            }
        }
    }
    (json!({"rates": rates, "validation_heading_rms": headings}), md)
}

/// Seeds of the effects section (issue 12 asks for at least 5).
const EFFECTS_SEEDS: [u64; 5] = [1, 2, 3, 4, 5];

/// Issue 12: the simulator with the five real-vehicle effects. With all
/// five on, over [`EFFECTS_SEEDS`]: our chain with every new model, the
/// same chain with each effect's model switched off in turn, and the
/// paper's method; then each effect alone with the full chain. Scored
/// against the simulator's truth: validation true-heading RMS, |F| error
/// against the true local field, the thrusters' per-ampere vector and the
/// temperature gains, the predicted heading RMS and observed/predicted.
fn effects() -> (serde_json::Value, String) {
    use magcal_sim::scenario::{effects_data, effects_scenarios, evaluate_variant, EffectsOutcome, Variant};
    use magcal_sim::SensorModel;
    let opt = |v: Option<f64>, digits: usize| v.map_or("–".to_string(), |x| format!("{x:.digits$}"));
    let mut rows = Vec::new();
    let mut md = String::from(
        "| effects | chain | seed | heading RMS (°) | of which white noise (°) | \\|F\\| error vs true field (nT) | \\|F\\| − IGRF (nT) | current vector error (%) | gain error (%/°C) | predicted heading RMS (°) (covariance, run's noise) | observed / predicted | GPS delay (s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut full_all: Vec<EffectsOutcome> = Vec::new();
    let scenarios = effects_scenarios();
    for (name, effects) in scenarios.iter().filter(|(n, _)| *n != "none") {
        let variants: &[Variant] = if *name == "all" { &Variant::ALL } else { &[Variant::Full] };
        for seed in EFFECTS_SEEDS {
            let data = match effects_data(&SensorModel::paper_like(), seed, effects) {
                Ok(d) => d,
                Err(e) => {
                    let _ = writeln!(md, "| {name} | – | {seed} | simulation failed: {e} |");
                    rows.push(json!({"effects": name, "seed": seed, "error": e.to_string()}));
                    continue;
                }
            };
            for &v in variants {
                match evaluate_variant(&data, v) {
                    Ok(o) => {
                        let _ = writeln!(
                            md,
                            "| {name} | {} | {seed} | {:.3} | {:.3} | {} | {:.0} | {} | {} | {} ({}, {}) | {} | {:.2} |",
                            v.label(),
                            o.heading_rms_deg,
                            o.heading_noise_deg,
                            opt(o.field_error_true_nt, 0),
                            o.field_error_igrf_nt,
                            opt(o.current_vector_error_pct, 1),
                            opt(o.gain_error_pct_per_c, 4),
                            opt(o.predicted_heading_rms_deg, 3),
                            opt(o.predicted_calibration_deg, 3),
                            opt(o.run_heading_noise_deg, 3),
                            opt(o.observed_over_predicted, 2),
                            o.gps_delay_s
                        );
                        if *name == "all" && v == Variant::Full {
                            full_all.push(o);
                        }
                        rows.push(json!({"effects": name, "chain": v, "seed": seed, "outcome": o}));
                    }
                    Err(e) => {
                        let _ = writeln!(md, "| {name} | {} | {seed} | refused: {e} |", v.label());
                        rows.push(json!({"effects": name, "chain": v, "seed": seed, "error": e.to_string()}));
                    }
                }
            }
        }
    }
    // The issue's targets against the worst seed of the full chain, all five on.
    let worst = |f: &dyn Fn(&EffectsOutcome) -> Option<f64>| full_all.iter().map(|o| f(o).unwrap_or(f64::NAN)).fold(f64::NEG_INFINITY, |a, b| if b.is_nan() || a.is_nan() { f64::NAN } else { a.max(b) });
    let ratios: Vec<f64> = full_all.iter().map(|o| o.observed_over_predicted.unwrap_or(f64::NAN)).collect();
    let ratio_lo = ratios.iter().copied().fold(f64::INFINITY, |a, b| if b.is_nan() { f64::NAN } else { a.min(b) });
    let ratio_hi = ratios.iter().copied().fold(f64::NEG_INFINITY, |a, b| if b.is_nan() { f64::NAN } else { a.max(b) });
    let complete = full_all.len() == EFFECTS_SEEDS.len();
    let heading = worst(&|o| Some(o.heading_rms_deg));
    let field = worst(&|o| o.field_error_true_nt);
    let current = worst(&|o| o.current_vector_error_pct);
    let gain = worst(&|o| o.gain_error_pct_per_c);
    let targets = json!({
        "seeds": full_all.len(),
        "heading_rms_deg": {"worst": heading, "target": 0.3, "met": complete && heading <= 0.3},
        "field_error_true_nt": {"worst": field, "target": 20.0, "met": complete && field <= 20.0},
        "current_vector_error_pct": {"worst": current, "target": 10.0, "met": complete && current <= 10.0},
        "gain_error_pct_per_c": {"worst": gain, "target": 0.03, "met": complete && gain <= 0.03},
        "observed_over_predicted": {"min": ratio_lo, "max": ratio_hi, "target": [0.5, 2.0], "met": complete && ratio_lo >= 0.5 && ratio_hi <= 2.0},
    });
    let met = |k: &str| if targets[k]["met"].as_bool() == Some(true) { "met" } else { "**not met**" };
    let _ = write!(
        md,
        "\nAll five effects, our chain with every model, worst of {} seeds: heading RMS {heading:.3}° (target ≤ 0.3°: {}); |F| error vs the true local field {field:.0} nT (≤ 20 nT: {}); current vector {current:.1} % (≤ 10 %: {}); temperature gains {gain:.4} %/°C (≤ 0.03 %/°C: {}); observed/predicted heading RMS {ratio_lo:.2}…{ratio_hi:.2} (0.5…2: {}).\n\n",
        full_all.len(),
        met("heading_rms_deg"),
        met("field_error_true_nt"),
        met("current_vector_error_pct"),
        met("gain_error_pct_per_c"),
        met("observed_over_predicted"),
    );
    (json!({"rows": rows, "targets": targets}), md)
}

/// SVG figures of the results (paper 001 Figs 3–4: J vs N per σ).
fn figures(out_dir: &Path, p1: &serde_json::Value) -> Result<Vec<String>> {
    use host_tools::report::{line_plot, Series};
    let mut files = Vec::new();
    for solver in ["pairwise (paper)", "linear + Cholesky"] {
        let mut series = Vec::new();
        for sigma in SIGMAS.iter().filter(|s| **s > 0.0) {
            let points = p1
                .as_array()
                .into_iter()
                .flatten()
                .filter(|r| r["solver"] == solver && r["sigma"].as_f64() == Some(*sigma))
                .filter_map(|r| Some(((r["pairs"].as_f64()?).log10(), r["mean_j"].as_f64()?.log10())))
                .collect();
            series.push(Series { name: format!("σ = {sigma:e}"), points, dots: false });
        }
        let name = if solver.starts_with("pairwise") { "fig_paper001_j_pairwise.svg" } else { "fig_paper001_j_linear.svg" };
        std::fs::write(out_dir.join(name), line_plot(&format!("Paper 001: log10 J vs log10 N — {solver}"), "log10 N (pairs)", "log10 J", &series))?;
        files.push(name.to_string());
    }
    Ok(files)
}

/// Runs the benchmarks and writes the results.
pub fn run(out_dir: &Path) -> Result<()> {
    std::fs::create_dir_all(out_dir)?;
    let root = out_dir.join("../..");
    eprintln!("== MCU cost (instructions under QEMU -icount)");
    let mut mcu = mcu_costs(&root)?;
    let usage = crate::size::measure(&root.join("target/thumbv7em-none-eabihf/release/firmware")).ok();
    if let Some(u) = usage {
        mcu["flash_bytes"] = json!(u.flash_bytes);
        mcu["ram_bytes"] = json!(u.ram_bytes);
    }
    let budget = cpu_budget(&mcu);
    if let (Some(obj), Some(b)) = (mcu.as_object_mut(), budget.as_object()) {
        for (k, v) in b {
            obj.insert(k.clone(), v.clone());
        }
    }
    eprintln!("{}", serde_json::to_string_pretty(&mcu)?);
    eprintln!("== paper 001: J vs N and σ ({SEEDS} seeds each)");
    let (p1, p1_md) = paper001();
    eprintln!("{p1_md}");
    let f32_check = f32_vs_f64();
    eprintln!("== paper 000: simulated field tests (5 seeds × 2 vehicles)");
    let (p0, p0_md) = paper000();
    eprintln!("{p0_md}");
    eprintln!("== f32 recursive full fit vs f64 batch (2400-sample tumble, 50 000 nT, 0.4 nT noise): {f32_check}");
    eprintln!("== host throughput (10⁶ samples)");
    let host = host_throughput(&root);
    eprintln!("{}", serde_json::to_string_pretty(&host)?);
    let figs = figures(out_dir, &p1)?;
    let real = real_recordings(&root);
    eprintln!("== real recordings: {real}");
    eprintln!("== limited tilt: simulated swing tests with and without a gyro, broad-05 against the peers");
    let (limited, limited_md) = limited_tilt(&root);
    eprintln!("{limited_md}");
    // The report of a full session (`cargo xtask demo`) in headless Chromium:
    // browser start to screenshot, s (target ≤ 2 s).
    let report_page = root.join("target/demo/session/report/index.html");
    let report_render_s = match crate::browser::check_report(&report_page) {
        Ok(r) => {
            // The browser's own start, for scale: an empty page the same way.
            let empty = out_dir.join("empty.html");
            let start_s = std::fs::write(&empty, "<!doctype html><title>empty</title><link rel=\"icon\" href=\"data:,\">")
                .map_err(anyhow::Error::from)
                .and_then(|()| crate::browser::render(&empty, &out_dir.join("empty.png"), crate::browser::WINDOW))
                .map_or(f64::NAN, |e| e.render_s);
            eprintln!("== report render (headless Chromium, {}): {:.2} s (an empty page: {start_s:.2} s)", report_page.display(), r.render_s);
            json!(r.render_s)
        }
        Err(e) => {
            eprintln!("== report render: not measured ({e:#}; run `cargo xtask demo` first)");
            json!(null)
        }
    };
    let (real_data, real_data_md) = real_data::real_data(&root);
    eprintln!("== real recordings, every model (issue 22){real_data_md}");
    eprintln!("== merge: clocks ±60 s and ±100 ppm apart at 50, 5 and 1 Hz, with and without a heading, {} seeds", MERGE_SHAPE_SEEDS.len());
    let (merge_numbers, merge_md) = merge_clocks();
    eprintln!("{merge_md}");
    eprintln!("== effects (issue 12): five real-vehicle effects, {} seeds", EFFECTS_SEEDS.len());
    let (effects_numbers, effects_md) = effects();
    eprintln!("{effects_md}");
    let mut results = json!({
        "command": "cargo xtask bench",
        "report_render_s": report_render_s,
        "host_throughput": host,
        "real_recordings": real,
        "figures": figs,
        "paper001_j": p1,
        "paper000_scenarios": p0,
        "f32_rls_vs_f64_batch": f32_check,
        "limited_tilt": limited,
        "merge": merge_numbers,
        "real_data": real_data,
        "effects": effects_numbers,
    });
    results["integrity"] = integrity::section(&root);
    eprintln!("== a heading-only compass's swing on the yacht Cirrus's circles (issue 29)");
    let (compass_numbers, compass_md) = compass::section(&root);
    eprintln!("{compass_md}");
    results["compass_swing"] = compass_numbers;
    eprintln!("== the five effects on varied sites with drawn magnitudes (issue 29, item 4), {} seeds", varied::VARIED_SEEDS.len());
    let (varied_numbers, varied_md) = varied::varied_sites_section();
    eprintln!("{varied_md}");
    results["effects_varied_sites"] = varied_numbers;
    eprintln!("== import speed per format beside the independent readers");
    let (import_numbers, import_md) = import_speed::section(&root);
    eprintln!("{import_md}");
    results["import_speed"] = import_numbers;
    if let Some(obj) = mcu.as_object() {
        for (k, v) in obj {
            results[k] = v.clone();
        }
    }
    std::fs::write(out_dir.join("results.json"), serde_json::to_string_pretty(&results)?)?;
    let md = format!(
        "# Benchmarks (`cargo xtask bench`)\n\n## MCU cost (Cortex-M4F instructions, QEMU -icount; load at 168 MHz assuming 1 instruction per cycle)\n\n```\n{}\n```\n\n## Paper 000: simulated field tests\n\nTurnaround step on the calibration run; true-heading RMS and |F| − IGRF RMS on a separate validation run (other courses, other current), each chain finished by a swing fit against the delayed GPS course.\n\n{p0_md}\n## Paper 001: J (eq 16) vs N pairs and noise σ\n\nMean over {SEEDS} seeds; field norm 2; σ per axis.\n\n{p1_md}\n![J, paper's solver](fig_paper001_j_pairwise.svg)\n![J, linear solver](fig_paper001_j_linear.svg)\n\n## A vehicle that cannot tumble (issue 15)\n\n{limited_md}\n## Logs on two clocks: `magcal merge` (issue 14)\n\nSwing tests at 50 Hz (board) and 10 Hz (navigation), swing tests with both logs at 5 Hz (with the AHRS heading, and without a heading column), out-and-back runs with both at 1 Hz, and runs of surface circles then legs with dives at 1 Hz whose only heading is the GPS course at the surface, cut into two logs whose clocks differ by ±60 s and ±100 ppm; the offset searched within ±120 s; the stated σ against the error over the cases. Then the chain on merged logs vs on the single-clock recordings, heading RMS on a separate validation run.\n\n{merge_md}\n## Real-vehicle effects (issue 12)\n\nThe simulator with thruster interference, temperature drift, a crustal anomaly, an AHRS misalignment and a water current (`magcal_sim::effects`); a survey AUV at 0.9–1.3 m/s. With all five on: our chain with every model, the same chain with each effect's model switched off in turn, and the paper's method (its back-stepping, the swing fit against raw GPS course); then each effect alone with the full chain. True-heading RMS and \\|F\\| errors on a separate validation run; the per-ampere vector and the temperature gains against the simulator's truth; the predicted heading RMS is the joint back-stepping's covariance and the calibration run's white heading noise (second differences) in quadrature; the white-noise column is the validation error's own (from truth), for scale (GPS delay truth: 2 s).\n\n{effects_md}\n## f32 recursive full fit vs f64 batch\n\n`{f32_check}`\n\n## Host throughput\n\n```\n{}\n```\n",
        serde_json::to_string_pretty(&mcu)?,
        serde_json::to_string_pretty(&results["host_throughput"])?
    );
    let md = md + &format!("\n## The five effects on varied sites (issue 29, item 4)\n\nThe five effects at three sites unlike paper 000's — high latitude (Trondheimsfjord, inclination 75°), low latitude (off Goa, 19.5°), southern (off Fiji, −40°, declination 13°) — with every effect's magnitudes drawn by seed from the ranges of `magcal_sim::varied::MagnitudeRanges` (thruster places and moments, thermocline, sensor lag and gains, the crustal bodies' strength, depth and place, magnetised by the site's field, the AHRS misalignment, the current's speed and direction). Our chain with the local field's gradient along the track in the joint back-stepping, and without it (the chain before). `cargo test --release -p xtask bench::tests::varied_sites_section -- --ignored --nocapture`.\n\n{varied_md}\n\n## Import speed per format\n\n`magcal import`'s one importer in process (best of five) beside the independent reader each format's tests compare against (`xtask/python/read_speed.py`, the read only, best of three), on the committed fixtures: `cargo test --release -p xtask bench::tests::import_speed_section -- --ignored --nocapture`.\n{import_md}");
    let md = md + &format!("\n## A heading-only compass's swing (issue 29)\n\nThe yacht Cirrus's real calibration circles: compass − GNSS course before and after the swing, in-sample and on held-out halves (each half corrected by the swing fitted on the other), against numpy's plain least squares.\n{compass_md}");
    std::fs::write(out_dir.join("results.md"), md)?;
    eprintln!("wrote {}", out_dir.join("results.json").display());
    Ok(())
}

#[cfg(test)]
mod tests {
    /// Only the merge section (the clock tables, then the chain on merged
    /// logs): `cargo test --release -p xtask bench::tests::merge_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn merge_section() {
        let (v, md) = super::merge_clocks();
        eprintln!("{md}");
        for r in v["rates"].as_array().into_iter().flatten() {
            assert_eq!(r["refused"].as_u64(), Some(0), "{r}");
            assert!(r["worst_offset_error_ms"].as_f64().is_some_and(|w| w < r["target_ms"].as_f64().unwrap_or(0.0)), "{r}");
            assert!(r["error_over_sigma"].as_f64().is_some_and(|q| (0.5..=2.0).contains(&q)), "{r}");
        }
    }

    /// Only the merge section's clock tables, one row per log shape (a
    /// couple of minutes): `cargo test --release -p xtask
    /// bench::tests::merge_shapes -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn merge_shapes() {
        let (rates, md) = super::merge_shapes();
        eprintln!("{md}");
        for r in &rates {
            assert_eq!(r["refused"].as_u64(), Some(0), "{r}");
            assert!(r["worst_offset_error_ms"].as_f64().is_some_and(|w| w < r["target_ms"].as_f64().unwrap_or(0.0)), "{r}");
            assert!(r["error_over_sigma"].as_f64().is_some_and(|q| (0.5..=2.0).contains(&q)), "{r}");
        }
    }

    /// Only the MCU section (instruction counts under QEMU, the CPU budget):
    /// `cargo test -p xtask bench::tests::mcu_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn mcu_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let mcu = super::mcu_costs(&root).expect("mcu-bench under QEMU");
        let budget = super::cpu_budget(&mcu);
        eprintln!("{}\n{}", serde_json::to_string_pretty(&mcu).unwrap_or_default(), serde_json::to_string_pretty(&budget).unwrap_or_default());
        assert!(budget["cpu_busy_pct_at_pair_rate"].as_f64().is_some_and(|p| p > 0.0 && p < 100.0), "{budget}");
    }

    /// Only the varied-sites section (issue 29, item 4):
    /// `cargo test --release -p xtask bench::tests::varied_sites_section -- --ignored --nocapture`.
    /// Prints the tables; asserts only that every site and seed ran.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn varied_sites_section() {
        let (v, md) = super::varied::varied_sites_section();
        eprintln!("{md}");
        for s in v["summary"].as_array().into_iter().flatten() {
            assert_eq!(s["seeds"].as_u64(), Some(super::varied::VARIED_SEEDS.len() as u64), "{s}");
        }
    }

    /// Only the import-speed section:
    /// `cargo test --release -p xtask bench::tests::import_speed_section -- --ignored --nocapture`.
    /// Every fixture is in the tree and imports; ours is not slower than
    /// the independent reader where that was measured.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn import_speed_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let (v, md) = super::import_speed::section(&root);
        eprintln!("{md}");
        for row in v.as_array().into_iter().flatten() {
            assert!(row["rows"].as_u64().is_some_and(|n| n > 0), "{row}");
            if let Some(r) = row["ratio"].as_f64() {
                assert!(r >= 1.0, "{row}");
            }
        }
    }

    /// Only the effects section (issue 12): `cargo test -p xtask bench::tests::effects_section -- --ignored --nocapture`.
    /// Prints the table; asserts only that every seed of the full chain ran
    /// (the targets are reported, met or not, in the summary line).
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn effects_section() {
        let (v, md) = super::effects();
        eprintln!("{md}");
        assert_eq!(v["targets"]["seeds"].as_u64(), Some(super::EFFECTS_SEEDS.len() as u64), "{}", v["targets"]);
    }
}
