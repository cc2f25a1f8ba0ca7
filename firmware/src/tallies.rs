//! The board's own counters, kept by its tasks and interrupts, their
//! snapshot for a status report ([`BoardCounters`], the protocol's type),
//! and the commit's store step, which counts into them. The RTIC app owns
//! one static [`Tallies`] and calls these; nothing here touches hardware.

use core::sync::atomic::{AtomicU32, Ordering};

use magcal_protocol::BoardCounters;

use crate::acquisition::AcqCounters;
use crate::device::{CoefficientStore, PendingCommit, SaveFailed};
use crate::link::LinkCounters;

/// The counters the interrupts and tasks add to (lock-free: any priority
/// may count).
#[derive(Debug)]
pub struct Tallies {
    rx_dropped: AtomicU32,
    overruns: AtomicU32,
    max_acq_gap_ms: AtomicU32,
    store_saves: AtomicU32,
    max_store_ms: AtomicU32,
}

impl Default for Tallies {
    fn default() -> Self {
        Self::new()
    }
}

impl Tallies {
    /// All zero.
    pub const fn new() -> Self {
        Self { rx_dropped: AtomicU32::new(0), overruns: AtomicU32::new(0), max_acq_gap_ms: AtomicU32::new(0), store_saves: AtomicU32::new(0), max_store_ms: AtomicU32::new(0) }
    }

    /// A received byte was lost (queue full or a line error).
    pub fn rx_dropped(&self) {
        self.rx_dropped.fetch_add(1, Ordering::Relaxed);
    }

    /// An acquisition deadline was missed.
    pub fn overrun(&self) {
        self.overruns.fetch_add(1, Ordering::Relaxed);
    }

    /// The time between two acquired pairs, ms (the longest is kept).
    pub fn acq_gap(&self, ms: u32) {
        self.max_acq_gap_ms.fetch_max(ms, Ordering::Relaxed);
    }

    fn store_save(&self, ms: u32) {
        self.store_saves.fetch_add(1, Ordering::Relaxed);
        self.max_store_ms.fetch_max(ms, Ordering::Relaxed);
    }

    /// Every counter the device does not own, for [`crate::device::Device::health`]:
    /// these, the acquisition's and the link's, the transmit queue's drops and
    /// the sensor feed's updates.
    pub fn snapshot(&self, acq: &AcqCounters, link: &LinkCounters, tx_dropped: u32, feed_updates: u32) -> BoardCounters {
        BoardCounters {
            pairs: acq.pairs,
            saturated: acq.saturated,
            acq_errors: acq.errors,
            overruns: self.overruns.load(Ordering::Relaxed),
            rx_dropped: self.rx_dropped.load(Ordering::Relaxed),
            tx_dropped,
            bad_frames: link.bad_frames,
            requests: link.requests,
            feed_updates,
            max_acq_gap_ms: self.max_acq_gap_ms.load(Ordering::Relaxed),
            store_saves: self.store_saves.load(Ordering::Relaxed),
            max_store_ms: self.max_store_ms.load(Ordering::Relaxed),
        }
    }

    /// Stores a checked commit as the link task must, outside every lock:
    /// the watchdog fed first (the erase stalls the CPU; the sector is small
    /// enough to finish well inside the watchdog's timeout, see
    /// [`crate::layout`]), then the save, timed by `timed` (which runs the
    /// save it is given and returns its duration, ms), then counted. The
    /// result goes to [`crate::device::Device::finish_commit`].
    pub fn store_commit(&self, pending: &PendingCommit, store: &mut impl CoefficientStore, feed_watchdog: impl FnOnce(), timed: impl FnOnce(&mut dyn FnMut()) -> u32) -> Result<u32, SaveFailed> {
        feed_watchdog();
        let mut saved = Err(SaveFailed);
        let ms = timed(&mut || saved = store.save(pending.bytes()));
        self.store_save(ms);
        saved
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{Boot, Device, Handled};
    use magcal_protocol::{Coefficients, RequestBody, ResponseBody, UNLOCK_XOR};
    use std::cell::RefCell;
    use std::vec::Vec;

    /// What happened, in order.
    #[derive(Debug, PartialEq)]
    enum Step {
        Fed,
        Saved(usize),
    }

    struct Log<'a>(&'a RefCell<Vec<Step>>, Result<u32, SaveFailed>);

    impl CoefficientStore for Log<'_> {
        fn save(&mut self, bytes: &[u8]) -> Result<u32, SaveFailed> {
            self.0.borrow_mut().push(Step::Saved(bytes.len()));
            self.1
        }
    }

    /// A commit that passed every check, from a device with the defaults.
    fn pending() -> (Device, crate::device::PendingCommit) {
        let mut d = Device::new(Boot { stored: None, challenge: 7 });
        let board = BoardCounters::default();
        let mut c: Coefficients = crate::device::default_coefficients();
        c.bias = [10.0, -20.0, 5.0];
        for body in [RequestBody::Unlock { key: 7 ^ UNLOCK_XOR }, RequestBody::WriteCoefficients(c)] {
            assert!(matches!(d.handle_request(&body, 10, &board), Handled::Reply(ResponseBody::Ack)));
        }
        match d.handle_request(&RequestBody::Commit { crc: c.crc() }, 20, &board) {
            Handled::Save(p) => (d, p),
            other => panic!("{other:?}"),
        }
    }

    /// The watchdog is fed before the erase starts, the save is timed and
    /// counted (the longest kept), and a failed save is counted too and keeps
    /// the old set in use.
    #[test]
    fn a_commit_feeds_the_watchdog_first_and_counts_its_save() {
        let t = Tallies::new();
        let steps = RefCell::new(Vec::new());
        let (mut d, p) = pending();
        let len = p.bytes().len();
        let saved = t.store_commit(&p, &mut Log(&steps, Ok(42)), || steps.borrow_mut().push(Step::Fed), |save| {
            save();
            640
        });
        assert_eq!(*steps.borrow(), [Step::Fed, Step::Saved(len)]);
        assert_eq!(d.finish_commit(p, saved), ResponseBody::Committed { seq: 42 });
        assert_eq!(d.calibration().field.bias, [10.0, -20.0, 5.0]);

        let (mut d, p) = pending();
        let saved = t.store_commit(&p, &mut Log(&steps, Err(SaveFailed)), || {}, |save| {
            save();
            15
        });
        assert!(matches!(d.finish_commit(p, saved), ResponseBody::Error(_)));
        assert_eq!(d.calibration().field.bias, [0.0; 3]);
        let b = t.snapshot(&AcqCounters::default(), &LinkCounters::default(), 0, 0);
        assert_eq!((b.store_saves, b.max_store_ms), (2, 640));
    }

    /// Each counter lands in its own field of the status report, and a gap
    /// keeps its maximum.
    #[test]
    fn the_snapshot_puts_each_counter_in_its_field() {
        let t = Tallies::new();
        t.rx_dropped();
        for _ in 0..2 {
            t.overrun();
        }
        for ms in [12, 30, 9] {
            t.acq_gap(ms);
        }
        let acq = AcqCounters { pairs: 100, saturated: 3, errors: 4 };
        let link = LinkCounters { requests: 5, bad_frames: 6, encode_failures: 0 };
        let b = t.snapshot(&acq, &link, 7, 8);
        let expected = BoardCounters {
            pairs: 100,
            saturated: 3,
            acq_errors: 4,
            overruns: 2,
            rx_dropped: 1,
            tx_dropped: 7,
            bad_frames: 6,
            requests: 5,
            feed_updates: 8,
            max_acq_gap_ms: 30,
            store_saves: 0,
            max_store_ms: 0,
        };
        assert_eq!(b, expected);
    }
}
