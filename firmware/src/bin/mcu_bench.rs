//! Cost of the firmware's per-sample work on the Cortex-M4F, counted under
//! QEMU with `-icount shift=0,sleep=off`: every instruction advances virtual
//! time by exactly 1 ns, and SysTick (clocked at the emulated 168 MHz core
//! clock) then counts 0.168 ticks per instruction, deterministically. Run by
//! `cargo xtask bench`; prints one `name value` line per measurement through
//! semihosting and exits.
//!
//! The counts are *instructions*; on silicon, cycles are somewhat more
//! (flash wait states, FPU and load latencies), which the bench states.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("mcu-bench runs on the Cortex-M4F under QEMU: cargo xtask bench");
}

#[cfg(target_os = "none")]
mod bench {
    use calib_core::cal::{Calibration, Environment, FieldCal, Swing};
    use calib_core::conformance::{tumble_sample, SplitMix64};
    use calib_core::fit::{AxisRls, FullRls, Normalization};
    use calib_core::heading::Tilt;
    use calib_core::online::OnlineIntegrity;
    use calib_core::swing::SwingRls;
    use cortex_m::peripheral::{syst::SystClkSource, SYST};
    use cortex_m_semihosting::{debug, hprintln};
    use firmware::acquisition::{run_ready, Acquisition, SetResetStrap};
    use firmware::adc::{CRC16, FRAME_BYTES};
    use firmware::ads131m04_model::{BridgeModel, StrapPinModel};
    use stm32f4xx_hal as _;

    /// SysTick ticks per instruction with `-icount shift=0` at 168 MHz.
    const TICKS_PER_INSTRUCTION: f32 = 0.168;
    const RELOAD: u32 = 0x00FF_FFFF;

    struct Timer(SYST);

    impl Timer {
        fn start(&mut self) -> u32 {
            self.0.clear_current();
            SYST::get_current()
        }
        /// Instructions since `start`, per repetition.
        fn instructions(&self, start: u32, reps: u32) -> u32 {
            let ticks = start.wrapping_sub(SYST::get_current()) & RELOAD;
            (ticks as f32 / TICKS_PER_INSTRUCTION / reps as f32) as u32
        }
    }

    struct NoDelay;
    impl embedded_hal::delay::DelayNs for NoDelay {
        fn delay_ns(&mut self, _: u32) {}
    }

    static SENSOR: BridgeModel = BridgeModel::new();

    /// An ADS131M04 that answers every frame at once: the acknowledgements
    /// `configure` expects, then a fixed conversion.
    struct FixedSpi {
        frame: [u8; FRAME_BYTES],
        n: u32,
    }
    impl FixedSpi {
        fn new() -> Self {
            Self { frame: [0; FRAME_BYTES], n: 0 }
        }
        fn answer(&mut self, response: u16) {
            let mut f = [0u8; FRAME_BYTES];
            f[..2].copy_from_slice(&response.to_be_bytes());
            f[3..6].copy_from_slice(&[0x12, 0x34, 0x56]);
            f[6..9].copy_from_slice(&[0xED, 0xCB, 0xA9]);
            f[9..12].copy_from_slice(&[0x01, 0x02, 0x03]);
            let crc = CRC16.checksum(&f[..15]);
            f[15..17].copy_from_slice(&crc.to_be_bytes());
            self.frame = f;
        }
    }
    impl embedded_hal::spi::ErrorType for FixedSpi {
        type Error = core::convert::Infallible;
    }
    impl embedded_hal::spi::SpiDevice for FixedSpi {
        fn transaction(&mut self, ops: &mut [embedded_hal::spi::Operation<'_, u8>]) -> Result<(), Self::Error> {
            // configure(): RESET, NULL (→ 0xFF24), RREG ID, NULL (→ ID),
            // WREG CLOCK, NULL (→ ack), WREG GAIN1, NULL (→ ack).
            let response = match self.n {
                1 => 0xFF24,
                3 => 0x2410,
                5 => 0x4180,
                7 => 0x4200,
                _ => 0x050F,
            };
            self.answer(response);
            self.n += 1;
            for op in ops.iter_mut() {
                if let embedded_hal::spi::Operation::Transfer(rx, _) = op {
                    for (d, s) in rx.iter_mut().zip(self.frame.iter()) {
                        *d = *s;
                    }
                }
            }
            Ok(())
        }
    }

    /// DRDY: nothing buffered when asked, ready at once when awaited.
    struct ReadyDrdy;
    impl embedded_hal::digital::ErrorType for ReadyDrdy {
        type Error = core::convert::Infallible;
    }
    impl embedded_hal::digital::InputPin for ReadyDrdy {
        fn is_high(&mut self) -> Result<bool, Self::Error> {
            Ok(true)
        }
        fn is_low(&mut self) -> Result<bool, Self::Error> {
            Ok(false)
        }
    }
    impl embedded_hal_async::digital::Wait for ReadyDrdy {
        async fn wait_for_high(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
        async fn wait_for_low(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
        async fn wait_for_rising_edge(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
        async fn wait_for_falling_edge(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
        async fn wait_for_any_edge(&mut self) -> Result<(), Self::Error> {
            Ok(())
        }
    }

    // Each measured loop in its own function: its count does not depend on
    // what else `main` keeps in registers.

    /// The plain per-sample path: field and heading.
    #[inline(never)]
    fn apply_loop(cal: &Calibration<f32>, samples: &[[f32; 3]; 64], tilts: &[Tilt<f32>; 4]) -> f32 {
        let mut acc = 0.0;
        for (k, s) in samples.iter().enumerate() {
            let o = cal.apply_tilt(*s, &tilts[k % 4]);
            acc += o.true_heading_rad + o.field_nt[0];
        }
        acc
    }

    /// The device's path with current and temperature terms.
    #[inline(never)]
    fn apply_env_loop(cal: &Calibration<f32>, envs: &[Environment<f32>; 4], samples: &[[f32; 3]; 64], tilts: &[Tilt<f32>; 4]) -> f32 {
        let mut acc = 0.0;
        for (k, s) in samples.iter().enumerate() {
            let o = cal.apply_tilt_env(*s, &tilts[k % 4], &envs[k % 4]);
            acc += o.true_heading_rad + o.field_nt[0];
        }
        acc
    }

    /// The device's path with integrity on the tumble (a field the
    /// calibration does not fit: after a few samples the stored calibration
    /// is judged invalid and the hard-iron estimator runs every sample, the
    /// costliest path); counts the samples judged `cal_invalid` into `invalid`.
    #[inline(never)]
    fn integrity_loop(online: &mut OnlineIntegrity<f32>, cal: &Calibration<f32>, samples: &[[f32; 3]; 64], tilts: &[Tilt<f32>; 4], invalid: &mut u32) -> f32 {
        let mut acc = 0.0;
        for (k, s) in samples.iter().enumerate() {
            let j = online.process(cal, *s, Some(&tilts[k % 4]), Some([0.01, -0.02, 0.2]), 0.02);
            acc += j.heading_rad.unwrap_or(0.0) + j.field_nt[0] + j.verdict.heading_sigma_rad;
            *invalid += u32::from(j.verdict.state == calib_core::integrity::IntegrityState::CalInvalid);
        }
        acc
    }

    /// A vehicle turning a full circle in 64 output samples at 10 Hz
    /// (0.98 rad/s) at a steady 6° roll and 3° pitch, in a 50 000 nT field
    /// of 60° dip: the raw samples the calibration `cal` maps back to that
    /// field, the attitude and the body rates the gyro would give. The
    /// integrity's usual path: every sample fits, the gyro agrees.
    struct Turn {
        samples: [[f32; 3]; 64],
        tilt: Tilt<f32>,
        rate_rad_s: [f32; 3],
    }

    fn turn(cal: &Calibration<f32>) -> Option<Turn> {
        use calib_core::heading::{ned_field, ned_to_body};
        let (roll, pitch) = (0.1f32, 0.05f32);
        let yaw_rate = core::f32::consts::TAU / 6.4;
        let inverse = calib_core::linalg::inverse3(&cal.field.matrix)?;
        let ned = ned_field(50_000.0f32, 60f32.to_radians(), cal.declination_rad);
        let mut samples = [[0.0f32; 3]; 64];
        for (k, s) in samples.iter_mut().enumerate() {
            let h = ned_to_body(ned, roll, pitch, yaw_rate * 0.1 * k as f32);
            let r = calib_core::linalg::mul_mat_vec(&inverse, h);
            *s = [r[0] + cal.field.bias[0], r[1] + cal.field.bias[1], r[2] + cal.field.bias[2]];
        }
        let t = Tilt::new(roll, pitch);
        let rate_rad_s = [-t.sin_pitch * yaw_rate, t.sin_roll * t.cos_pitch * yaw_rate, t.cos_roll * t.cos_pitch * yaw_rate];
        Some(Turn { samples, tilt: t, rate_rad_s })
    }

    /// The device's path with integrity on the [`Turn`]; counts the samples
    /// judged `ok` into `ok`.
    #[inline(never)]
    fn integrity_turn_loop(online: &mut OnlineIntegrity<f32>, cal: &Calibration<f32>, turn: &Turn, ok: &mut u32) -> f32 {
        let mut acc = 0.0;
        for s in turn.samples.iter() {
            let j = online.process(cal, *s, Some(&turn.tilt), Some(turn.rate_rad_s), 0.1);
            acc += j.heading_rad.unwrap_or(0.0) + j.field_nt[0] + j.verdict.heading_sigma_rad;
            *ok += u32::from(j.verdict.state == calib_core::integrity::IntegrityState::Ok);
        }
        acc
    }

    /// The plain path on the [`Turn`] (the baseline the integrity adds to).
    #[inline(never)]
    fn apply_turn_loop(cal: &Calibration<f32>, turn: &Turn) -> f32 {
        let mut acc = 0.0;
        for s in turn.samples.iter() {
            let o = cal.apply_tilt(*s, &turn.tilt);
            acc += o.true_heading_rad + o.field_nt[0];
        }
        acc
    }

    #[cortex_m_rt::entry]
    fn main() -> ! {
        let Some(mut cp) = cortex_m::Peripherals::take() else {
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        cp.SYST.set_clock_source(SystClkSource::Core);
        cp.SYST.set_reload(RELOAD);
        cp.SYST.clear_current();
        cp.SYST.enable_counter();
        let mut t = Timer(cp.SYST);

        // Inputs: a tumble at 50 000 nT (the on-target fit test's workload).
        let mut rng = SplitMix64::new(1);
        let mut samples = [[0.0f32; 3]; 64];
        for s in samples.iter_mut() {
            let v = tumble_sample(&mut rng);
            *s = [v[0] as f32, v[1] as f32, v[2] as f32];
        }
        let cal = Calibration {
            field: FieldCal { bias: [1200.0, -800.0, 350.0], matrix: [[0.95, 0.01, 0.0], [0.01, 1.04, 0.02], [0.0, 0.02, 0.93]] },
            swing: Swing { a: 0.1, b: 0.01, c: -0.01, d: 0.005, e: 0.05 },
            declination_rad: 0.09,
            env: calib_core::cal::EnvTerms::none(),
        };

        // apply + heading: the firmware's per-sample path (attitude
        // trigonometry cached when the attitude arrives).
        let reps = 64;
        let mut acc = 0.0f32;
        let tilts: [Tilt<f32>; 4] = [Tilt::new(0.1, 0.05), Tilt::new(-0.2, 0.1), Tilt::new(0.5, -0.1), Tilt::new(0.0, 0.0)];
        let s0 = t.start();
        acc += apply_loop(&cal, &samples, &tilts);
        let apply = t.instructions(s0, reps);

        // The same with current and temperature terms, as the device does
        // it (`device::Device::on_raw_sample`): the document's formula
        // (`Calibration::apply_tilt_env`) on every sample, the current and
        // the temperature changing from sample to sample.
        let cal_env = Calibration {
            env: calib_core::cal::EnvTerms { bias_per_a: [12.0, -3.0, 25.0], ref_c: 15.0, gain_per_c: [-0.003, -0.0028, -0.0031] },
            ..cal
        };
        let envs: [Environment<f32>; 4] = [
            Environment { current_a: 12.0, temp_c: 21.5 },
            Environment { current_a: 0.5, temp_c: 22.0 },
            Environment { current_a: 30.0, temp_c: 18.25 },
            Environment { current_a: 7.0, temp_c: 25.0 },
        ];
        let s0 = t.start();
        acc += apply_env_loop(&cal_env, &envs, &samples, &tilts);
        let apply_env = t.instructions(s0, reps);

        // The same samples judged by the integrity (`device::pipeline`)
        // against a stored intensity a fifth below theirs (a calibration
        // that no longer fits): a warm-up pass, then the measured pass, all
        // `cal_invalid`, the estimator running.
        let Ok(mut online) = OnlineIntegrity::<f32>::for_stored_field(40_000.0) else {
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        let mut invalid = 0;
        acc += integrity_loop(&mut online, &cal, &samples, &tilts, &mut invalid);
        let mut invalid = 0;
        let s0 = t.start();
        acc += integrity_loop(&mut online, &cal, &samples, &tilts, &mut invalid);
        let integrity_invalid = t.instructions(s0, reps);

        // The usual path: a turn the calibration fits, judged `ok` after a
        // warm-up circle (against the stored reference inclination, the
        // turn's 60°; the gyro anchored).
        let cal_turn = Calibration { swing: Swing::zero(), ..cal };
        let Some(turn) = turn(&cal_turn) else {
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        let s0 = t.start();
        acc += apply_turn_loop(&cal_turn, &turn);
        let apply_turn = t.instructions(s0, reps);
        let Ok(mut online) = OnlineIntegrity::<f32>::for_stored(50_000.0, Some(60f32.to_radians())) else {
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        let mut ok = 0;
        for _ in 0..4 {
            acc += integrity_turn_loop(&mut online, &cal_turn, &turn, &mut ok);
        }
        let mut ok = 0;
        let s0 = t.start();
        acc += integrity_turn_loop(&mut online, &cal_turn, &turn, &mut ok);
        let integrity_turn = t.instructions(s0, reps);

        let norm = Normalization { centre: [0.0; 3], scale: 50_000.0 };
        let mut full = FullRls::<f32>::new(norm);
        let s0 = t.start();
        for s in samples.iter() {
            full.push(*s);
        }
        let rls_full = t.instructions(s0, reps);

        let mut axis = AxisRls::<f32>::new(norm);
        let s0 = t.start();
        for s in samples.iter() {
            axis.push(*s);
        }
        let rls_axis = t.instructions(s0, reps);

        let mut swing = SwingRls::<f32>::new();
        let s0 = t.start();
        for k in 0..reps {
            let h = 0.1 * k as f32;
            swing.push(h, h + 0.01);
        }
        let rls_swing = t.instructions(s0, reps);

        // One set/reset pair through the real driver and acquisition, over
        // an SPI that answers a fixed valid frame at once and a DRDY that is
        // always ready: the CPU's own work per pair, without the bus and
        // conversion waits (those are added from the datasheets by
        // `cargo xtask bench`).
        let strap = SetResetStrap::new(StrapPinModel::set(&SENSOR), StrapPinModel::reset(&SENSOR));
        let Ok(mut acq) = Acquisition::new(FixedSpi::new(), strap, ReadyDrdy) else {
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        let pair_reps = 16;
        let s0 = t.start();
        for _ in 0..pair_reps {
            if let Some(Ok(p)) = run_ready(acq.acquire_pair(&mut NoDelay)) {
                acc += p.field_counts[0];
            }
        }
        let pair = t.instructions(s0, pair_reps);

        // The scale's check: 10 000 iterations of a two-instruction loop
        // (subs; bne) must count 20 000.
        let s0 = t.start();
        unsafe {
            core::arch::asm!("1:", "subs {0}, #1", "bne 1b", inout(reg) 10_000u32 => _, options(nomem, nostack));
        }
        let check = t.instructions(s0, 1);

        // Keep the results alive.
        if acc.is_nan() {
            hprintln!("nan");
        }
        hprintln!("apply_heading_instructions {}", apply);
        hprintln!("apply_env_heading_instructions {}", apply_env);
        hprintln!("integrity_cal_invalid_instructions {}", integrity_invalid);
        hprintln!("integrity_cal_invalid_samples {}", invalid);
        hprintln!("apply_heading_turn_instructions {}", apply_turn);
        hprintln!("integrity_ok_turn_instructions {}", integrity_turn);
        hprintln!("integrity_ok_turn_samples_ok {}", ok);
        hprintln!("rls_axis_update_instructions {}", rls_axis);
        hprintln!("rls_full_update_instructions {}", rls_full);
        hprintln!("rls_swing_update_instructions {}", rls_swing);
        hprintln!("acquisition_cycle_instructions {}", pair);
        hprintln!("scale_check_20000_instructions {}", check);
        // The two integrity paths measured what they say: every sample of
        // the turn `ok`, every sample of the tumble `cal_invalid`.
        if ok != 64 || invalid != 64 {
            hprintln!("integrity paths not as measured: {} ok, {} cal_invalid of 64", ok, invalid);
            debug::exit(debug::EXIT_FAILURE);
        }
        debug::exit(debug::EXIT_SUCCESS);
        loop {
            cortex_m::asm::wfi();
        }
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        debug::exit(debug::EXIT_FAILURE);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
