//! The board client: everything that talks to a board (silicon or QEMU).
//!
//! * [`client`]: [`BoardClient`], requests and replies over the host link
//!   (USART1), with the samples the board streams;
//! * [`feed`]: [`FeedWriter`], the QEMU board's sensor feed (USART2);
//! * [`qemu`]: [`qemu::QemuBoard`], boots the firmware in QEMU;
//! * [`coefficients`]: the calibration document ↔ the board's coefficients;
//! * [`log`]: `magcal log`, the board's raw stream to a board log on the
//!   board's clock.

use std::time::Duration;

pub mod client;
pub mod coefficients;
pub mod feed;
pub mod log;
pub mod qemu;

pub use client::{BoardClient, ClientError, SAMPLE_QUEUE};
pub use feed::FeedWriter;

/// The link's baud rate (the firmware's USART1 setting).
pub const BAUD_RATE: u32 = 115_200;

/// Opens a serial port (a board's USB-serial adapter, or a QEMU pty) at
/// [`BAUD_RATE`], 8N1, with a short read timeout.
pub(crate) fn open_port(path: &str) -> Result<Box<dyn serialport::SerialPort>, ClientError> {
    serialport::new(path, BAUD_RATE)
        .timeout(Duration::from_millis(20))
        .open()
        .map_err(|source| ClientError::Open { path: path.to_string(), source })
}
