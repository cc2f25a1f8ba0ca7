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
    use calib_core::cal::{Calibration, FieldCal, Swing};
    use calib_core::conformance::{tumble_sample, SplitMix64};
    use calib_core::fit::{AxisRls, FullRls, Normalization};
    use calib_core::heading::Tilt;
    use calib_core::swing::SwingRls;
    use cortex_m::peripheral::{syst::SystClkSource, SYST};
    use cortex_m_semihosting::{debug, hprintln};
    use firmware::acquisition::{Acquisition, SetResetStrap};
    use firmware::ads131m04_model::{Ads131m04Model, StrapPinModel, BridgeModel};
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

    #[cortex_m_rt::entry]
    fn main() -> ! {
        let Some(mut cp) = cortex_m::Peripherals::take() else {
            debug::exit(debug::EXIT_FAILURE);
            loop {}
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
        };

        // apply + heading: the firmware's per-sample path (attitude
        // trigonometry cached when the attitude arrives).
        let reps = 64;
        let mut acc = 0.0f32;
        let tilts: [Tilt<f32>; 4] = [Tilt::new(0.1, 0.05), Tilt::new(-0.2, 0.1), Tilt::new(0.5, -0.1), Tilt::new(0.0, 0.0)];
        let s0 = t.start();
        for (k, s) in samples.iter().enumerate() {
            let o = cal.apply_tilt(*s, &tilts[k % 4]);
            acc += o.true_heading_rad + o.field_nt[0];
        }
        let apply = t.instructions(s0, reps);

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

        // One set/reset pair through the real driver (over the ADC model,
        // whose own frame building is included: an upper bound).
        SENSOR.set_truth([1_000_000.0, -500_000.0, 1_500_000.0], [20_000.0; 3]);
        let strap = SetResetStrap::new(StrapPinModel::set(&SENSOR), StrapPinModel::reset(&SENSOR));
        let Ok(mut acq) = Acquisition::new(Ads131m04Model::new(&SENSOR), strap) else {
            debug::exit(debug::EXIT_FAILURE);
            loop {}
        };
        let pair_reps = 16;
        let s0 = t.start();
        for _ in 0..pair_reps {
            if let Ok(p) = acq.acquire_pair(&mut NoDelay) {
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
        hprintln!("rls_axis_update_instructions {}", rls_axis);
        hprintln!("rls_full_update_instructions {}", rls_full);
        hprintln!("rls_swing_update_instructions {}", rls_swing);
        hprintln!("acquisition_cycle_instructions {}", pair);
        hprintln!("scale_check_20000_instructions {}", check);
        debug::exit(debug::EXIT_SUCCESS);
        loop {}
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        debug::exit(debug::EXIT_FAILURE);
        loop {}
    }
}
