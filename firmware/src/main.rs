//! The RTIC application: a thin shell that wires the firmware library to the
//! STM32F405's peripherals. All logic lives in the `firmware` library.
//!
//! * `USART1` (PA9/PA10, 115 200 Bd): the host link. Its interrupt moves
//!   received bytes into an rtic-sync channel and feeds the transmitter.
//! * `link` (priority 1): frames → requests → `Device` → one reply each.
//! * `acquire` (priority 2): every 1/[`PAIR_RATE_HZ`] s, one set/reset pair
//!   through the ADS131M04; decimated to the output rate, calibrated,
//!   streamed. Feeds the independent watchdog on the board.
//! * `USART2` + `feed` (QEMU board): the host plays the magnetometer bridges.
//! * `idle`: WFI.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!(
        "the firmware runs on the STM32F405: build it with \
         `cargo build -p firmware --target thumbv7em-none-eabihf` (or `cargo xtask demo`)"
    );
    std::process::exit(2);
}

#[cfg(target_os = "none")]
use rtic_monotonics::systick::prelude::*;

#[cfg(target_os = "none")]
systick_monotonic!(Mono, 1_000);

#[cfg(target_os = "none")]
defmt::timestamp!("{=u32:ms}", Mono::now().duration_since_epoch().as_millis());


/// Panics are firmware bugs (outside data never panics): log, then on QEMU
/// exit with a failure status so tests see it; on the board, reset. The log
/// has the location and a literal message, without `core::fmt` (formatting
/// the `PanicInfo` linked ~3 KiB of formatting machinery for this one line).
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let (file, line) = info.location().map_or(("?", 0), |l| (l.file(), l.line()));
    let message = info.message().as_str().unwrap_or("(formatted message)");
    defmt::error!("panic at {=str}:{=u32}: {=str}", file, line, message);
    firmware::fail_and_reset()
}

/// A fault is a firmware bug: log it, then as for a panic.
#[cfg(target_os = "none")]
#[cortex_m_rt::exception]
unsafe fn HardFault(frame: &cortex_m_rt::ExceptionFrame) -> ! {
    defmt::error!("hard fault at pc {=u32:#x}", frame.pc());
    firmware::fail_and_reset()
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [EXTI0, EXTI1, EXTI2])]
mod app {
    use super::Mono;
    use embedded_hal_bus::spi::{ExclusiveDevice, NoDelay};
    use firmware::acquisition::{AcqCounters, Acquisition, Decimator, SetResetStrap, PAIR_RATE_HZ};
    use firmware::clocks::{self, ADC_CLKIN_HZ, SPI_SCLK_HZ};
    use firmware::board::{BoardDrdy, BoardPin, BoardSpi, BoardStore, QemuFlash};
    use firmware::board_hw::{boot_challenge, BoardFlash, CycleDelay, ExtiDrdy, Stopwatch};
    use firmware::device::{Boot, Device, Handled};
    use firmware::tallies::Tallies;
    use firmware::layout;
    use firmware::link::{DeviceInfo, LinkEvent, LinkServer};
    use firmware::platform;
    use firmware::ads131m04_model::{Ads131m04Model, BridgeModel, DrdyPinModel, FeedReceiver, StrapPinModel};
    use firmware::store::Store;
    use firmware::uart::TxQueue;
    use magcal_protocol::{self as proto, Platform};
    use rtic_monotonics::systick::prelude::*;
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;
    use rtic_sync::signal::SignalReader;
    use stm32f4xx_hal::{
        flash::LockedFlash,
        gpio::{Edge, ExtiPin, Input, Output, PA10, PA2, PA3, PA4, PA5, PA6, PA7, PA8, PA9, PB0, PB1, PB10},
        pac::{EXTI, FLASH, IWDG, RCC, SPI1, SYSCFG, USART1, USART2},
        prelude::*,
        rcc::{Config, Rcc},
        serial::{self, Rx, RxISR, RxListen, Tx},
        syscfg::SysCfgExt,
        spi::{Mode, Phase, Polarity, Spi},
        watchdog::IndependentWatchdog,
    };

    /// Received bytes waiting for the link and feed tasks.
    const RX_QUEUE: usize = 255;

    type Spi1 = ExclusiveDevice<Spi<SPI1>, PA4<Output>, NoDelay>;
    type SetPin = BoardPin<PB0<Output>>;
    type ResetPin = BoardPin<PB1<Output>>;
    type Drdy = BoardDrdy<ExtiDrdy<PB10<Input>>>;
    type FrontEnd = Acquisition<BoardSpi<Spi1>, SetPin, ResetPin, Drdy>;
    /// The ADC's bus, the strap's two pins and DRDY.
    type AdcBus = (BoardSpi<Spi1>, SetPin, ResetPin, Drdy);



    /// The bridges of the QEMU board.
    static BRIDGES: BridgeModel = BridgeModel::new();
    /// The board's own counters (`firmware::tallies`, host-tested).
    static TALLIES: Tallies = Tallies::new();

    #[shared]
    struct Shared {
        tx: TxQueue<Tx<USART1>>,
        device: Device,
        acq: AcqCounters,
        watchdog: Option<IndependentWatchdog>,
    }

    #[local]
    struct Local {
        rx: Rx<USART1>,
        drdy_edge: rtic_sync::signal::SignalWriter<'static, ()>,
        rx_sender: Sender<'static, u8, RX_QUEUE>,
        rx2: Rx<USART2>,
        feed_sender: Sender<'static, u8, RX_QUEUE>,
        link: LinkServer,
        front: Option<FrontEnd>,
        store: BoardStore<BoardFlash>,
        delay: CycleDelay,
    }

    /// USART1/2 pins: PA9/PA10 (link), PA2/PA3 (feed).
    type UartPins = (PA9, PA10, PA2, PA3);

    /// What the ADC front end needs on the board: SPI1 on PA5–PA7 with chip
    /// select PA4, CLKIN out on PA8 (MCO1), the strap on PB0/PB1, DRDY on
    /// PB10 (EXTI line 10).
    struct AdcHardware {
        spi1: SPI1,
        syscfg: SYSCFG,
        exti: EXTI,
        pa4: PA4,
        pa5: PA5,
        pa6: PA6,
        pa7: PA7,
        pa8: PA8,
        pb0: PB0,
        pb1: PB1,
        pb10: PB10,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        let platform = identify_platform();
        let challenge = boot_challenge(platform);
        let (mut rcc, sysclk_hz) = start_clocks(cx.device.RCC, platform);
        Mono::start(cx.core.SYST, sysclk_hz);
        firmware::board_hw::enable_cycle_counter(cx.core.DCB, cx.core.DWT);

        let gpioa = cx.device.GPIOA.split(&mut rcc);
        let gpiob = cx.device.GPIOB.split(&mut rcc);
        let (tx, rx, rx2) = start_uarts(cx.device.USART1, cx.device.USART2, (gpioa.pa9, gpioa.pa10, gpioa.pa2, gpioa.pa3), &mut rcc);
        let (drdy_edge, drdy_reader) = rtic_sync::make_signal!(());
        let adc = AdcHardware {
            spi1: cx.device.SPI1,
            syscfg: cx.device.SYSCFG,
            exti: cx.device.EXTI,
            pa4: gpioa.pa4,
            pa5: gpioa.pa5,
            pa6: gpioa.pa6,
            pa7: gpioa.pa7,
            pa8: gpioa.pa8,
            pb0: gpiob.pb0,
            pb1: gpiob.pb1,
            pb10: gpiob.pb10,
        };
        let front = start_front_end(platform, adc, drdy_reader, &mut rcc);

        let mut store = open_store(platform, cx.device.FLASH);
        let device = Device::new(Boot { stored: boot_coefficients(&mut store), challenge });
        let watchdog = start_watchdog(platform, cx.device.IWDG);

        let (rx_sender, rx_receiver) = make_channel!(u8, RX_QUEUE);
        let (feed_sender, feed_receiver) = make_channel!(u8, RX_QUEUE);
        if link::spawn(rx_receiver).is_err() || acquire::spawn().is_err() || feed::spawn(feed_receiver).is_err() {
            firmware::halt("task spawn");
        }
        defmt::info!("magcal-fw {} up on {}, sysclk {} Hz", firmware::FIRMWARE_VERSION, platform, sysclk_hz);
        (
            Shared { tx: TxQueue::new(tx), device, acq: AcqCounters::default(), watchdog },
            Local { rx, drdy_edge, rx_sender, rx2, feed_sender, link: LinkServer::new(), front, store, delay: CycleDelay::new(sysclk_hz) },
        )
    }

    /// Before anything touches RCC: which hardware is this? Starts the
    /// logger for it.
    fn identify_platform() -> Platform {
        let (detection, rcc_cr, idcode) = platform::detect();
        firmware::logger::init(detection.platform);
        if detection.disagreement {
            defmt::warn!("platform signals disagree: RCC_CR {=u32:#x}, DBGMCU_IDCODE {=u32:#x}; running as the board", rcc_cr, idcode);
        }
        detection.platform
    }

    /// The clock tree: the crystal and the PLL on the board, HSI under QEMU
    /// (which ignores it); returns SysTick's clock, Hz.
    fn start_clocks(rcc: RCC, platform: Platform) -> (Rcc, u32) {
        match platform {
            Platform::Qemu => (rcc.freeze(Config::hsi()), clocks::QEMU_SYSCLK_HZ),
            Platform::Silicon => {
                let rcc = rcc.freeze(Config::hse(clocks::BOARD_HSE_HZ.Hz()).sysclk(clocks::BOARD_SYSCLK_HZ.Hz()));
                let hz = rcc.clocks.sysclk().raw();
                (rcc, hz)
            }
        }
    }

    /// USART1 (the host link) and USART2 (the QEMU board's sensor feed) at
    /// 115 200 Bd, receive interrupts on.
    fn start_uarts(usart1: USART1, usart2: USART2, (pa9, pa10, pa2, pa3): UartPins, rcc: &mut Rcc) -> (Tx<USART1>, Rx<USART1>, Rx<USART2>) {
        let config = serial::Config::default().baudrate(115_200.bps());
        let Ok(serial1) = usart1.serial((pa9, pa10), config, rcc) else {
            firmware::halt("USART1 configuration refused");
        };
        let (tx, mut rx) = serial1.split();
        rx.listen();
        let Ok(serial2) = usart2.serial((pa2, pa3), config, rcc) else {
            firmware::halt("USART2 configuration refused");
        };
        let (_tx2, mut rx2) = serial2.split();
        rx2.listen();
        (tx, rx, rx2)
    }

    /// The ADC's bus, DRDY and the strap — real on the board, modelled
    /// under QEMU (no GPIO, EXTI or ADC there) — and the ADC configured;
    /// `None` (and logged) if the ADC refuses.
    fn start_front_end(platform: Platform, hw: AdcHardware, drdy_reader: SignalReader<'static, ()>, rcc: &mut Rcc) -> Option<FrontEnd> {
        let (spi, set_pin, reset_pin, drdy) = match platform {
            Platform::Silicon => board_adc_bus(hw, drdy_reader, rcc),
            Platform::Qemu => {
                BRIDGES.set_clocks(ADC_CLKIN_HZ, SPI_SCLK_HZ);
                (
                    BoardSpi::Model(Ads131m04Model::new(&BRIDGES)),
                    BoardPin::Model(StrapPinModel::set(&BRIDGES)),
                    BoardPin::Model(StrapPinModel::reset(&BRIDGES)),
                    BoardDrdy::Model(DrdyPinModel::new(&BRIDGES)),
                )
            }
        };
        match Acquisition::new(spi, SetResetStrap::new(set_pin, reset_pin), drdy) {
            Ok(f) => Some(f),
            Err(e) => {
                defmt::error!("ADC initialisation failed: {}", e);
                None
            }
        }
    }

    /// The board's ADC wiring: CLKIN on MCO1, SPI1 mode 1, the strap pins,
    /// DRDY's falling edge on EXTI line 10.
    fn board_adc_bus(
        hw: AdcHardware,
        drdy_reader: SignalReader<'static, ()>,
        rcc: &mut Rcc,
    ) -> AdcBus {
        // CLKIN for the ADC: HSE on MCO1 (PA8), undivided.
        let _clkin = hw.pa8.into_alternate::<0>();
        // SAFETY: one read-modify-write of RCC_CFGR's MCO1 fields in
        // init, after the HAL has set the clock tree.
        unsafe { (*stm32f4xx_hal::pac::RCC::ptr()).cfgr().modify(|_, w| w.mco1().hse().mco1pre().div1()) };
        let mode = Mode { polarity: Polarity::IdleLow, phase: Phase::CaptureOnSecondTransition };
        let bus = hw.spi1.spi((Some(hw.pa5), Some(hw.pa6), Some(hw.pa7)), mode, SPI_SCLK_HZ.Hz(), rcc);
        let cs = hw.pa4.into_push_pull_output();
        // DRDY on PB10, falling edge on EXTI line 10.
        let mut drdy_pin = hw.pb10.into_pull_up_input();
        let mut syscfg = hw.syscfg.constrain(rcc);
        let mut exti = hw.exti;
        drdy_pin.make_interrupt_source(&mut syscfg);
        drdy_pin.trigger_on_edge(&mut exti, Edge::Falling);
        drdy_pin.enable_interrupt(&mut exti);
        // The chip select's error type is `Infallible` on this HAL.
        let Ok(dev) = ExclusiveDevice::new_no_delay(bus, cs);
        (
            BoardSpi::Real(dev),
            BoardPin::Real(hw.pb0.into_push_pull_output()),
            BoardPin::Real(hw.pb1.into_push_pull_output()),
            BoardDrdy::Real(ExtiDrdy::new(drdy_pin, drdy_reader)),
        )
    }

    /// Coefficients: flash sectors 1/2 on the board (see `layout`), RAM
    /// under QEMU.
    fn open_store(platform: Platform, flash: FLASH) -> BoardStore<BoardFlash> {
        let [a, b] = layout::STORE_OFFSETS;
        let store = match platform {
            Platform::Silicon => Store::new(BoardFlash::new(LockedFlash::new(flash)), a, b, layout::STORE_SECTOR_BYTES).map(BoardStore::Flash),
            Platform::Qemu => Store::new(QemuFlash::new(), 0, 1024, 1024).map(BoardStore::Ram),
        };
        match store {
            Ok(s) => s,
            Err(_) => firmware::halt("coefficient store layout"),
        }
    }

    /// The stored set to boot with, logged (see
    /// [`BoardStore::load_coefficients`]).
    fn boot_coefficients(store: &mut BoardStore<BoardFlash>) -> Option<(proto::Coefficients, u32)> {
        let stored = store.load_coefficients().unwrap_or_else(|_| {
            defmt::error!("coefficient store unreadable");
            None
        });
        match &stored {
            Some((_, seq)) => defmt::info!("coefficients #{} loaded", seq),
            None => defmt::warn!("no valid coefficients stored: using the nominal chain gain"),
        }
        stored
    }

    /// The independent watchdog on the board (QEMU does not model it):
    /// long enough for the worst flash erase twice over (see `layout`).
    fn start_watchdog(platform: Platform, iwdg: IWDG) -> Option<IndependentWatchdog> {
        match platform {
            Platform::Silicon => {
                let mut w = IndependentWatchdog::new(iwdg);
                w.start(stm32f4xx_hal::prelude::_fugit_ExtU32::millis(layout::WATCHDOG_TIMEOUT_MS));
                Some(w)
            }
            Platform::Qemu => None,
        }
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// USART1: move received bytes to the link task, feed the transmitter.
    #[task(binds = USART1, priority = 3, local = [rx, rx_sender], shared = [tx])]
    fn usart1(mut cx: usart1::Context) {
        if cx.local.rx.is_rx_not_empty() {
            match cx.local.rx.read() {
                Ok(byte) => {
                    if cx.local.rx_sender.try_send(byte).is_err() {
                        TALLIES.rx_dropped();
                    }
                }
                // Overrun/noise/framing: the byte is lost; the frame's CRC or
                // COBS check refuses what it belonged to.
                Err(_) => {
                    TALLIES.rx_dropped();
                }
            }
        }
        cx.shared.tx.lock(|tx| tx.on_interrupt());
    }

    /// DRDY's falling edge (EXTI line 10, board only): wake the acquisition.
    #[task(binds = EXTI15_10, priority = 3, local = [drdy_edge])]
    fn drdy(cx: drdy::Context) {
        // SAFETY: writing 1 to EXTI_PR bit 10 clears only line 10's pending
        // flag (RM0090 §12.3.6: rc_w1); nothing else uses line 10.
        unsafe { (*stm32f4xx_hal::pac::EXTI::ptr()).pr().write(|w| w.bits(1 << 10)) };
        cx.local.drdy_edge.write(());
    }

    /// USART2: the sensor feed (QEMU board).
    #[task(binds = USART2, priority = 3, local = [rx2, feed_sender])]
    fn usart2(cx: usart2::Context) {
        if cx.local.rx2.is_rx_not_empty() {
            let ok = cx.local.rx2.read().ok().map(|b| cx.local.feed_sender.try_send(b).is_ok());
            if ok != Some(true) {
                TALLIES.rx_dropped();
            }
        }
    }

    fn now_ms() -> u32 {
        Mono::now().duration_since_epoch().as_millis()
    }

    /// Frames → requests → one reply each.
    #[task(priority = 1, local = [link, store], shared = [tx, device, acq, watchdog])]
    async fn link(mut cx: link::Context, mut bytes: Receiver<'static, u8, RX_QUEUE>) {
        let mut policy = firmware::link::ReplyPolicy::new();
        while let Ok(byte) = bytes.recv().await {
            let info = DeviceInfo { platform: platform::detect_cached(), uptime_ms: now_ms() };
            let reply = match cx.local.link.on_byte(byte, &info) {
                None => continue,
                Some(LinkEvent::Reply(frame)) => Some(frame),
                Some(LinkEvent::Request(req)) => {
                    let store = &mut *cx.local.store;
                    let acq = cx.shared.acq.lock(|a| *a);
                    let tx_dropped = cx.shared.tx.lock(|t| t.dropped_frames());
                    let board = TALLIES.snapshot(&acq, &cx.local.link.counters(), tx_dropped, BRIDGES.updates());
                    let handled = cx.shared.device.lock(|d| d.handle_request(&req.body, now_ms(), &board));
                    let body = match handled {
                        Handled::Reply(body) => body,
                        // The erase stalls the CPU (one flash bank): stored
                        // outside every lock, right after a watchdog feed
                        // (`Tallies::store_commit`, host-tested).
                        Handled::Save(pending) => {
                            let feed = || {
                                cx.shared.watchdog.lock(|w| {
                                    if let Some(w) = w.as_mut() {
                                        w.feed();
                                    }
                                })
                            };
                            let timed = |save: &mut dyn FnMut()| {
                                let t0 = Stopwatch::now(now_ms());
                                save();
                                t0.elapsed_ms(now_ms())
                            };
                            let saved = TALLIES.store_commit(&pending, store, feed, timed);
                            cx.shared.device.lock(|d| d.finish_commit(pending, saved))
                        }
                    };
                    cx.local.link.reply(Some(req.seq), body)
                }
            };
            if let Some(frame) = reply {
                // The link's output policy (`firmware::link::ReplyPolicy`, host-tested).
                let nmea_now = cx.shared.device.lock(|d| d.stream() == proto::StreamMode::Nmea);
                let out = policy.outgoing(frame, nmea_now);
                if !cx.shared.tx.lock(|tx| tx.enqueue(out.bytes())) {
                    defmt::warn!("tx queue full: reply dropped");
                }
            }
        }
    }

    /// The sensor feed: the host's truth for the simulated bridges.
    #[task(priority = 1)]
    async fn feed(_cx: feed::Context, mut bytes: Receiver<'static, u8, RX_QUEUE>) {
        let mut receiver = FeedReceiver::new();
        while let Ok(byte) = bytes.recv().await {
            receiver.on_byte(byte, &BRIDGES);
        }
    }

    /// Acquisition at the pair rate; decimation, correction, streaming.
    #[task(priority = 2, local = [front, delay], shared = [tx, device, acq, watchdog])]
    async fn acquire(mut cx: acquire::Context) {
        let period = rtic_monotonics::fugit::MillisDurationU32::from_ticks(1_000 / PAIR_RATE_HZ);
        let mut next = Mono::now();
        let mut rate = cx.shared.device.lock(|d| d.output_rate_hz());
        let mut decimator = Decimator::new(Decimator::factor_for(PAIR_RATE_HZ, u32::from(rate)));
        let mut last_pair: Option<Stopwatch> = None;
        loop {
            next += period;
            Mono::delay_until(next).await;
            cx.shared.watchdog.lock(|w| {
                if let Some(w) = w.as_mut() {
                    w.feed();
                }
            });
            let now_pair = Stopwatch::now(now_ms());
            if let Some(last) = last_pair.replace(now_pair) {
                TALLIES.acq_gap(last.elapsed_ms_to(&now_pair));
            }
            let Some(front) = cx.local.front.as_mut() else { continue };
            let tag = (platform::detect_cached() == Platform::Qemu).then(|| BRIDGES.seq());
            let pair = front.acquire_pair(cx.local.delay).await;
            let counters = front.counters();
            cx.shared.acq.lock(|a| *a = counters);
            let Ok(pair) = pair else { continue };
            let new_rate = cx.shared.device.lock(|d| d.output_rate_hz());
            if new_rate != rate {
                rate = new_rate;
                decimator = Decimator::new(Decimator::factor_for(PAIR_RATE_HZ, u32::from(rate)));
            }
            if let Some(raw) = decimator.push_tagged(&pair, tag) {
                let t = now_ms();
                let out = cx.shared.device.lock(|d| d.on_raw_sample(&raw, t).map(|s| (s, d.stream(), d.calibration().declination_rad)));
                // What a sample is on the wire (`firmware::link::sample_bytes`, host-tested).
                if let Some(bytes) = out.and_then(|(sample, stream, declination_rad)| firmware::link::sample_bytes(&sample, stream, declination_rad)) {
                    let _ = cx.shared.tx.lock(|tx| tx.enqueue(bytes.bytes()));
                }
            }
            // Missed deadlines: count them and resynchronise.
            let now = Mono::now();
            if now > next + period {
                TALLIES.overrun();
                next = now;
            }
        }
    }
}
