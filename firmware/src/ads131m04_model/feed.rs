//! The QEMU board's sensor feed on USART2: the decoder of the host's
//! [`magcal_protocol::SensorFeed`] frames that set what the modelled bridges
//! of [`super::BridgeModel`] see. Apart from the ADC model itself: the model
//! is the datasheet's device, this is the wire into it.

use super::BridgeModel;

/// The QEMU board's sensor feed (USART2): frames from the host that set what
/// the modelled bridges see. The body of the firmware's `feed` task.
pub struct FeedReceiver {
    decoder: magcal_protocol::FrameDecoder,
    offsets: [f32; 3],
}

impl Default for FeedReceiver {
    fn default() -> Self {
        Self::new()
    }
}

impl FeedReceiver {
    /// A receiver with no frame yet (bridge offsets zero).
    pub const fn new() -> Self {
        Self { decoder: magcal_protocol::FrameDecoder::new(), offsets: [0.0; 3] }
    }

    /// One byte from USART2. A complete, valid [`magcal_protocol::SensorFeed`]
    /// frame sets `bridges` (offsets kept when the frame leaves them out) and
    /// returns its sequence number; damaged frames are ignored.
    pub fn on_byte(&mut self, byte: u8, bridges: &BridgeModel) -> Option<u32> {
        let Some(Ok(body)) = self.decoder.push(byte) else { return None };
        let f = magcal_protocol::decode_body::<magcal_protocol::SensorFeed>(body).ok()?;
        if let Some(o) = f.offset_counts {
            self.offsets = o;
        }
        if let Some(t) = f.temp_c {
            bridges.set_temp_c(t);
        }
        bridges.set_truth_seq(f.field_nt, self.offsets, f.seq);
        Some(f.seq)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::indexing_slicing)]
    use super::*;
    use magcal_protocol::{encode, SensorFeed, MAX_FRAME_LEN};

    fn frame(f: &SensorFeed) -> ([u8; MAX_FRAME_LEN], usize) {
        let mut buf = [0u8; MAX_FRAME_LEN];
        let n = encode(f, &mut buf).unwrap();
        (buf, n)
    }

    #[test]
    fn feed_frames_set_the_bridges_and_damage_is_ignored() {
        static BRIDGES: BridgeModel = BridgeModel::new();
        let mut rx = FeedReceiver::new();
        let (a, n) = frame(&SensorFeed { seq: 5, field_nt: [1000.0, -2000.0, 500.0], offset_counts: Some([10.0, 20.0, 30.0]), temp_c: None });
        let got: Vec<Option<u32>> = a[..n].iter().map(|&b| rx.on_byte(b, &BRIDGES)).collect();
        assert_eq!(got.iter().flatten().copied().collect::<Vec<_>>(), vec![5]);
        assert_eq!((BRIDGES.seq(), BRIDGES.updates()), (5, 1));
        // A damaged frame changes nothing; the next good one, without
        // offsets, keeps the previous offsets.
        let (mut b, n) = frame(&SensorFeed { seq: 6, field_nt: [0.0; 3], offset_counts: None, temp_c: None });
        b[3] ^= 0x40;
        assert!(b[..n].iter().all(|&x| rx.on_byte(x, &BRIDGES).is_none()));
        assert_eq!((BRIDGES.seq(), BRIDGES.updates()), (5, 1));
        let (c, n) = frame(&SensorFeed { seq: 7, field_nt: [0.0; 3], offset_counts: None, temp_c: None });
        assert_eq!(c[..n].iter().filter_map(|&x| rx.on_byte(x, &BRIDGES)).last(), Some(7));
        assert_eq!(rx.offsets, [10.0, 20.0, 30.0]);
    }
}
