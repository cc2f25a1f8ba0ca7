//! The RTIC application: a thin shell that wires the firmware library to the
//! STM32F405's interrupts. All logic lives in the `firmware` library.
//!
//! * `USART1` (PA9/PA10, 115 200 Bd) carries the host link. Its interrupt
//!   moves received bytes into an rtic-sync channel and drains the transmit
//!   queue one byte per TXE interrupt.
//! * `link` (software task) assembles frames and answers requests.
//! * `idle` sleeps in WFI.
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
/// exit with a failure status so tests see it; on the board, reset.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}", defmt::Display2Format(info));
    if firmware::platform::detect_cached() == magcal_protocol::Platform::Qemu {
        cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
    }
    cortex_m::peripheral::SCB::sys_reset();
}

#[cfg(target_os = "none")]
#[rtic::app(device = stm32f4xx_hal::pac, dispatchers = [EXTI0, EXTI1])]
mod app {
    use super::Mono;
    use firmware::link::{DeviceInfo, LinkServer};
    use firmware::platform;
    use firmware::uart::TxQueue;
    use magcal_protocol::Platform;
    use rtic_monotonics::systick::prelude::*;
    use rtic_sync::channel::{Receiver, Sender};
    use rtic_sync::make_channel;
    use stm32f4xx_hal::{
        pac::USART1,
        prelude::*,
        rcc::Config,
        serial::{self, Rx, RxISR, RxListen, Tx},
    };

    /// Received bytes waiting for the link task.
    const RX_QUEUE: usize = 255;

    #[shared]
    struct Shared {
        tx: TxQueue<Tx<USART1>>,
    }

    #[local]
    struct Local {
        rx: Rx<USART1>,
        rx_sender: Sender<'static, u8, RX_QUEUE>,
        rx_dropped: u32,
        link: LinkServer,
        platform: Platform,
    }

    #[init]
    fn init(cx: init::Context) -> (Shared, Local) {
        // Before anything touches RCC: which hardware is this?
        let platform = platform::detect();
        firmware::logger::init(platform);

        let (mut rcc, sysclk_hz) = match platform {
            Platform::Qemu => (cx.device.RCC.freeze(Config::hsi()), platform::QEMU_SYSCLK_HZ),
            Platform::Silicon => {
                let rcc = cx.device.RCC.freeze(
                    Config::hse(platform::BOARD_HSE_HZ.Hz())
                        .sysclk(platform::BOARD_SYSCLK_HZ.Hz()),
                );
                let hz = rcc.clocks.sysclk().raw();
                (rcc, hz)
            }
        };
        Mono::start(cx.core.SYST, sysclk_hz);

        let gpioa = cx.device.GPIOA.split(&mut rcc);
        let config = serial::Config::default().baudrate(115_200.bps());
        let serial = match cx.device.USART1.serial((gpioa.pa9, gpioa.pa10), config, &mut rcc) {
            Ok(s) => s,
            Err(_) => firmware::halt("USART1 configuration refused"),
        };
        let (tx, mut rx) = serial.split();
        rx.listen();

        let (rx_sender, rx_receiver) = make_channel!(u8, RX_QUEUE);
        if link::spawn(rx_receiver).is_err() {
            firmware::halt("link task already running");
        }
        defmt::info!(
            "magcal-fw {} up on {}, sysclk {} Hz",
            firmware::FIRMWARE_VERSION,
            platform,
            sysclk_hz
        );
        (
            Shared { tx: TxQueue::new(tx) },
            Local { rx, rx_sender, rx_dropped: 0, link: LinkServer::new(), platform },
        )
    }

    #[idle]
    fn idle(_: idle::Context) -> ! {
        loop {
            cortex_m::asm::wfi();
        }
    }

    /// USART1: move received bytes to the link task, feed the transmitter.
    #[task(binds = USART1, priority = 3, local = [rx, rx_sender, rx_dropped], shared = [tx])]
    fn usart1(mut cx: usart1::Context) {
        let local = cx.local;
        // Bounded: the data register holds one byte per RXNE.
        if local.rx.is_rx_not_empty() {
            match local.rx.read() {
                Ok(byte) => {
                    if local.rx_sender.try_send(byte).is_err() {
                        *local.rx_dropped = local.rx_dropped.wrapping_add(1);
                    }
                }
                // Overrun/noise/framing: the byte is lost; the frame's CRC
                // or COBS check will refuse what it belonged to.
                Err(_) => *local.rx_dropped = local.rx_dropped.wrapping_add(1),
            }
        }
        cx.shared.tx.lock(|tx| tx.on_interrupt());
    }

    /// Assembles frames and answers each with exactly one reply frame.
    #[task(priority = 1, local = [link, platform], shared = [tx])]
    async fn link(mut cx: link::Context, mut bytes: Receiver<'static, u8, RX_QUEUE>) {
        while let Ok(byte) = bytes.recv().await {
            let device = DeviceInfo {
                platform: *cx.local.platform,
                uptime_ms: Mono::now().duration_since_epoch().as_millis(),
            };
            if let Some(reply) = cx.local.link.on_byte(byte, &device) {
                if !cx.shared.tx.lock(|tx| tx.enqueue(&reply)) {
                    defmt::warn!("tx queue full: reply dropped");
                }
            }
        }
    }
}
