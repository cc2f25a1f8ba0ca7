//! The defmt global logger, with the transport chosen at boot.
//!
//! On the board, defmt frames go to an RTT up-channel named `defmt` that
//! probe-rs reads. Under QEMU they go to the host's stdout through
//! semihosting (`SYS_WRITE`), where `defmt-print` decodes them. Semihosting
//! must never run on a board without a debugger (the `BKPT` would fault), so
//! it is used only when [`crate::platform::detect`] said QEMU. Until
//! [`init`] runs, log frames are dropped.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_semihosting::hio::{self, HostStream};
use magcal_protocol::Platform;

/// Where log frames go.
enum Sink {
    /// Not initialised yet: frames are dropped.
    Dropped,
    /// An RTT up-channel (board).
    Rtt(rtt_target::UpChannel),
    /// Semihosting stdout (QEMU).
    Semihosting(HostStream),
}

struct State {
    sink: Sink,
    encoder: defmt::Encoder,
    restore: critical_section::RestoreState,
}

struct Global(UnsafeCell<State>);

// SAFETY: `State` is only touched between `acquire` and `release`, inside the
// critical section taken in `acquire` (single core), or in `init` inside one.
unsafe impl Sync for Global {}

static STATE: Global = Global(UnsafeCell::new(State {
    sink: Sink::Dropped,
    encoder: defmt::Encoder::new(),
    restore: critical_section::RestoreState::invalid(),
}));
static TAKEN: AtomicBool = AtomicBool::new(false);
/// Set when a frame was started while another was in progress (only possible
/// from a fault or panic handler interrupting a log call): that inner frame is
/// dropped so the outer one stays intact.
static NESTED: AtomicBool = AtomicBool::new(false);

/// Chooses the transport for this platform. Call once, early in `init`.
pub fn init(platform: Platform) {
    let sink = match platform {
        Platform::Qemu => match hio::hstdout() {
            Ok(stream) => Sink::Semihosting(stream),
            Err(()) => Sink::Dropped,
        },
        Platform::Silicon => {
            let channels = rtt_target::rtt_init! {
                up: { 0: { size: 1024, name: "defmt" } }
            };
            Sink::Rtt(channels.up.0)
        }
    };
    critical_section::with(|_| {
        // SAFETY: inside a critical section and not between acquire/release
        // (`TAKEN` is false whenever no frame is being written).
        unsafe { (*STATE.0.get()).sink = sink };
    });
}

fn write_sink(sink: &mut Sink, bytes: &[u8]) {
    match sink {
        Sink::Dropped => {}
        Sink::Rtt(channel) => {
            channel.write(bytes);
        }
        Sink::Semihosting(stream) => {
            let _ = stream.write_all(bytes);
        }
    }
}

#[defmt::global_logger]
struct Logger;

// SAFETY: defmt's contract: acquire/release bracket each frame and are not
// re-entered; the critical section makes that true on this single core.
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        let restore = unsafe { critical_section::acquire() };
        if TAKEN.swap(true, Ordering::Acquire) {
            // A log call from inside the logger (e.g. a panic while logging):
            // drop it rather than corrupt the frame in progress.
            NESTED.store(true, Ordering::Relaxed);
            unsafe { critical_section::release(restore) };
            return;
        }
        // SAFETY: exclusive access inside the critical section.
        let state = unsafe { &mut *STATE.0.get() };
        state.restore = restore;
        let State { sink, encoder, .. } = state;
        encoder.start_frame(|b| write_sink(sink, b));
    }

    unsafe fn flush() {}

    unsafe fn release() {
        if NESTED.swap(false, Ordering::Relaxed) {
            return;
        }
        let state = unsafe { &mut *STATE.0.get() };
        let State { sink, encoder, restore } = state;
        encoder.end_frame(|b| write_sink(sink, b));
        let restore = *restore;
        TAKEN.store(false, Ordering::Release);
        unsafe { critical_section::release(restore) };
    }

    unsafe fn write(bytes: &[u8]) {
        if NESTED.load(Ordering::Relaxed) {
            return;
        }
        let state = unsafe { &mut *STATE.0.get() };
        let State { sink, encoder, .. } = state;
        encoder.write(bytes, |b| write_sink(sink, b));
    }
}
