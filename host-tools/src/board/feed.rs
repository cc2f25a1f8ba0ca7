//! [`FeedWriter`]: the QEMU board's sensor feed (its USART2), through which a
//! simulated vehicle sets the field at the bridges of the board's ADC model.

use std::io::Write;

use magcal_protocol::{self as proto, SensorFeed, MAX_FRAME_LEN};

use super::client::{open_port, ClientError};

/// Writes the QEMU board's sensor feed (its USART2).
pub struct FeedWriter<P> {
    port: P,
    seq: u32,
    last: Vec<u8>,
    offsets_sent: Option<[f32; 3]>,
}

impl FeedWriter<Box<dyn serialport::SerialPort>> {
    /// Opens the feed's serial port (QEMU's second pty).
    pub fn open(path: &str) -> Result<Self, ClientError> {
        Ok(Self { port: open_port(path)?, seq: 0, last: Vec::new(), offsets_sent: None })
    }
}

impl<P: Write> FeedWriter<P> {
    /// Sends the bridges' next truth: the field at each bridge (nT) and the
    /// bridge offsets (ADC counts). Returns the frame's sequence number.
    pub fn send(&mut self, field_nt: [f32; 3], offset_counts: [f32; 3]) -> Result<u32, ClientError> {
        self.send_env(field_nt, offset_counts, None)
    }

    /// [`FeedWriter::send`] with the temperature of the thermistor next to
    /// the sensor, °C (`None`: unchanged; the board's ADC model turns it
    /// into the thermistor divider's voltage on channel 3).
    pub fn send_env(&mut self, field_nt: [f32; 3], offset_counts: [f32; 3], temp_c: Option<f32>) -> Result<u32, ClientError> {
        self.seq = self.seq.wrapping_add(1);
        let mut frame = [0u8; MAX_FRAME_LEN];
        // Offsets only when they change (and in every resent frame's first copy).
        let offsets = (self.offsets_sent != Some(offset_counts)).then_some(offset_counts);
        self.offsets_sent = Some(offset_counts);
        let n = proto::encode(&SensorFeed { seq: self.seq, field_nt, offset_counts: offsets, temp_c }, &mut frame).map_err(ClientError::Encode)?;
        self.last = frame[..n].to_vec();
        self.port.write_all(&self.last)?;
        self.port.flush()?;
        Ok(self.seq)
    }

    /// Sends the last frame again (QEMU drops what arrives on a pty before
    /// it has noticed the other end opened it).
    pub fn resend(&mut self) -> Result<(), ClientError> {
        self.port.write_all(&self.last)?;
        self.port.flush()?;
        Ok(())
    }
}

