//! Interrupt-driven transmit queue for the host link.
//!
//! Replies are queued whole or not at all (a partial frame would be garbage
//! on the wire). Bytes are written while the transmitter can take them, and
//! the TXE interrupt is enabled only while bytes remain: on silicon the first
//! bytes go out at once and the interrupt sends the rest; QEMU 7.2's USART
//! transmits synchronously and never raises TXE, so there the whole frame
//! goes out in `enqueue` and the same code needs no interrupt.

/// What the queue needs from a UART transmitter.
pub trait ByteTx {
    /// The data register can take a byte.
    fn is_ready(&self) -> bool;
    /// Writes one byte (only called when [`ByteTx::is_ready`]).
    fn write_byte(&mut self, byte: u8);
    /// Enables or disables the TXE interrupt.
    fn set_tx_interrupt(&mut self, enabled: bool);
}

/// Bytes of reply frames waiting to be sent.
pub const TX_QUEUE: usize = 1024;

/// A transmitter with its queue.
pub struct TxQueue<T> {
    tx: T,
    queue: heapless::Deque<u8, TX_QUEUE>,
    dropped_frames: u32,
}

impl<T: ByteTx> TxQueue<T> {
    /// An empty queue in front of `tx`.
    pub fn new(tx: T) -> Self {
        Self { tx, queue: heapless::Deque::new(), dropped_frames: 0 }
    }

    /// Queues a whole frame; returns false (and counts it) when it does not
    /// fit, leaving the queue unchanged.
    pub fn enqueue(&mut self, frame: &[u8]) -> bool {
        if TX_QUEUE - self.queue.len() < frame.len() {
            self.dropped_frames = self.dropped_frames.wrapping_add(1);
            return false;
        }
        for &b in frame {
            // Cannot fail: the space was checked above.
            let _ = self.queue.push_back(b);
        }
        self.pump();
        true
    }

    /// Call from the UART interrupt (and after queueing): writes bytes while
    /// the transmitter takes them, then enables TXE only if some remain.
    /// Bounded by the queue's length.
    pub fn on_interrupt(&mut self) {
        self.pump();
    }

    fn pump(&mut self) {
        while self.tx.is_ready() {
            match self.queue.pop_front() {
                Some(b) => self.tx.write_byte(b),
                None => break,
            }
        }
        self.tx.set_tx_interrupt(!self.queue.is_empty());
    }

    /// Frames refused because the queue was full.
    pub fn dropped_frames(&self) -> u32 {
        self.dropped_frames
    }

    /// Bytes waiting.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// Nothing waiting.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }
}

#[cfg(target_os = "none")]
mod stm32 {
    use super::ByteTx;
    use stm32f4xx_hal::serial::{Instance, Tx, TxISR, TxListen};

    impl<U: Instance> ByteTx for Tx<U, u8> {
        fn is_ready(&self) -> bool {
            self.is_tx_empty()
        }
        fn write_byte(&mut self, byte: u8) {
            // Ready was checked, so this cannot block or fail.
            let _ = embedded_hal_nb::serial::Write::write(self, byte);
        }
        fn set_tx_interrupt(&mut self, enabled: bool) {
            if enabled {
                TxListen::listen(self);
            } else {
                TxListen::unlisten(self);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A transmitter that takes `room` bytes, then is busy until the next
    /// "interrupt" (when the shift register has emptied).
    #[derive(Default)]
    struct MockTx {
        sent: Vec<u8>,
        irq: bool,
        room: usize,
    }
    impl ByteTx for MockTx {
        fn is_ready(&self) -> bool {
            self.room > 0
        }
        fn write_byte(&mut self, byte: u8) {
            self.sent.push(byte);
            self.room -= 1;
        }
        fn set_tx_interrupt(&mut self, enabled: bool) {
            self.irq = enabled;
        }
    }

    #[test]
    fn frames_go_out_in_order_and_txe_turns_off_when_done() {
        let mut q = TxQueue::new(MockTx { room: 2, ..MockTx::default() });
        assert!(q.enqueue(&[1, 2, 3]));
        assert_eq!(q.tx.sent, vec![1, 2], "bytes go out at once while there is room");
        assert!(q.tx.irq, "the rest waits for TXE");
        assert!(q.enqueue(&[4, 0]));
        let mut interrupts = 0;
        while q.tx.irq {
            q.tx.room = 1;
            q.on_interrupt();
            interrupts += 1;
        }
        assert_eq!(interrupts, 3);
        assert_eq!(q.tx.sent, vec![1, 2, 3, 4, 0]);
        assert!(q.is_empty());
    }

    #[test]
    fn a_synchronous_transmitter_needs_no_interrupt() {
        // QEMU 7.2: TXE is always set and never interrupts.
        let mut q = TxQueue::new(MockTx { room: usize::MAX, ..MockTx::default() });
        assert!(q.enqueue(&[1, 2, 3, 0]));
        assert_eq!(q.tx.sent, vec![1, 2, 3, 0]);
        assert!(!q.tx.irq);
    }

    #[test]
    fn a_frame_that_does_not_fit_is_refused_whole() {
        let mut q = TxQueue::new(MockTx::default()); // transmitter stalled
        assert!(q.enqueue(&[7u8; TX_QUEUE - 10]));
        assert!(!q.enqueue(&[9u8; 11]));
        assert_eq!(q.len(), TX_QUEUE - 10);
        assert_eq!(q.dropped_frames(), 1);
        assert!(q.enqueue(&[9u8; 10]));
    }
}
