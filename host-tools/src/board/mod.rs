//! The board client: everything that talks to a board (silicon or QEMU).
//!
//! * [`client`]: [`BoardClient`], requests and replies over the host link
//!   (USART1), with the samples the board streams;
//! * [`feed`]: [`FeedWriter`], the QEMU board's sensor feed (USART2);
//! * [`qemu`]: [`qemu::QemuBoard`], boots the firmware in QEMU;
//! * [`coefficients`]: the calibration document ↔ the board's coefficients;
//! * [`log`]: `magcal log`, the board's raw stream to a board log on the
//!   board's clock;
//! * [`reconnect`]: reopening a dropped link (the session's recording and
//!   `magcal log`).

pub(crate) mod client;
pub(crate) mod coefficients;
pub(crate) mod feed;
pub(crate) mod log;
pub(crate) mod qemu;
pub(crate) mod reconnect;

pub use client::{BoardClient, ClientError, BAUD_RATE, SAMPLE_QUEUE};
pub use feed::FeedWriter;
pub use reconnect::{reconnect_at, Resume};
pub use log::{create_log_file, log_board, LogEnd, LogError, LogOptions, LogOutput, LogProgress, LogSummary, LOGGED_SAMPLES, LOG_HEADER};
pub use qemu::{QemuBoard, QemuError, QemuOptions};
