//! `magcal log`: the board's raw stream written to a board log (the CSV
//! that [`crate::data::board_log::BoardLog`] reads), on the board's own clock,
//! for as long as asked.
//!
//! * `t` is the board's `t_ms` in seconds, unwrapped across the `u32`
//!   millisecond counter's wrap-around (every 49.7 days) by [`clock::BoardClock`];
//! * every row is written and flushed as it arrives, so a killed process
//!   loses nothing it had written;
//! * a dropped link is reopened (the session's reconnect, with a growing
//!   backoff between rounds) and logging goes on; the samples lost meanwhile
//!   show as a gap in `t`, the first sample after it carries
//!   [`crate::data::HEALTH_AFTER_GAP`], and the gaps are listed in the [`LogSummary`];
//! * the board's `Health` counters before and after give what the board
//!   produced and dropped on its side;
//! * the board's integrity state of every sample is counted
//!   ([`crate::doc::integrity::IntegrityTally`]), with the on-line hard iron from its `Health` at
//!   the end, and the session's "recalibrate" rule
//!   ([`crate::doc::integrity::recalibrate_evidence`]) judges them.

use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use magcal_protocol::{Health, StreamMode};
use serde::{Deserialize, Serialize};

use super::client::{BoardClient, ClientError};
use super::reconnect::{reconnect_at, Resume};
use crate::data::board_log;
use crate::doc::results::RecalibrateEvidence;
use crate::doc::integrity::IntegrityCounts;

mod clock;
pub(crate) mod logger;
mod output;

pub use output::{create_log_file, LogOutput};
use logger::Logger;

/// What the "recalibrate" line of a log calls its samples.
pub const LOGGED_SAMPLES: &str = "logged samples";

/// The board log's header (`docs/INTERFACES.md`, "Board log"; its one
/// home is [`crate::data::board_log`]).
pub const LOG_HEADER: &str = board_log::HEADER;

/// Why logging could not start or could not go on.
#[derive(Debug, thiserror::Error)]
pub enum LogError {
    /// The output path is refused ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
    /// The output file exists (and overwriting was not asked for).
    #[error("{} exists (and overwriting it was not asked for)", .0.display())]
    Exists(PathBuf),
    /// The output file could not be created or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: io::Error,
    },
    /// The port could not be opened at the start.
    #[error(transparent)]
    Open(ClientError),
    /// The port opened but no board answered `Identify`.
    #[error("no board answers on the port (Identify): {0}")]
    Identify(ClientError),
    /// The board refused to stream (at the start).
    #[error("the board would not stream raw samples: {0}")]
    Stream(ClientError),
    /// The output rate asked for is not 1 to 100 Hz.
    #[error("the output rate must be 1 to 100 Hz, not {0}")]
    RateOutOfRange(u8),
}

/// How long to log and how to treat the link.
#[derive(Debug, Clone)]
pub struct LogOptions {
    /// Stop after this long (host time); `None`: until stopped.
    pub duration: Option<Duration>,
    /// The board's output rate, Hz (1–100).
    pub rate_hz: u8,
    /// No sample for this long means the link is down (reopened).
    pub silence: Duration,
    /// First pause between reconnection rounds; doubled each failed round.
    pub backoff_initial: Duration,
    /// Longest pause between reconnection rounds.
    pub backoff_max: Duration,
    /// Show an indicatif bar (a terminal); otherwise plain progress lines.
    pub interactive: bool,
}

impl Default for LogOptions {
    fn default() -> Self {
        Self {
            duration: None,
            rate_hz: 100,
            silence: Duration::from_secs(3),
            backoff_initial: Duration::from_millis(200),
            backoff_max: Duration::from_secs(5),
            interactive: false,
        }
    }
}

/// A stretch of board time without samples.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    /// Board time of the last sample before the gap, s.
    pub after_t_s: f64,
    /// Board time from that sample to the next one, s.
    pub length_s: f64,
    /// Samples missing in it at the output rate.
    pub missing_samples: u64,
}

/// Why logging ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LogEnd {
    /// The duration asked for passed.
    Duration,
    /// Stopped (Ctrl-C).
    Interrupted,
    /// The board's clock went back (it restarted): the log ends there, on
    /// one clock (start another log for what follows).
    BoardRestarted,
}

/// What was logged (`magcal log --json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LogSummary {
    /// The file written.
    pub out: PathBuf,
    /// Rows written.
    pub samples: u64,
    /// Board time of the first row, s.
    pub first_t_s: Option<f64>,
    /// Board time of the last row, s.
    pub last_t_s: Option<f64>,
    /// The output rate asked for, Hz.
    pub rate_hz: u8,
    /// Gaps in the board's time (more than 1.5 output intervals between rows).
    pub gaps: Vec<Gap>,
    /// Board time in gaps, s.
    pub gap_total_s: f64,
    /// Samples missing in the gaps at the output rate.
    pub missing_samples: u64,
    /// Times the link dropped (an I/O error or silence) and was reopened.
    pub link_drops: u32,
    /// Rows with a saturated channel.
    pub saturated_samples: u64,
    /// Rows with a temperature.
    pub samples_with_temp: u64,
    /// Frames the host received damaged or out of place.
    pub host_discarded_frames: u64,
    /// Samples the host dropped because its queue was full.
    pub host_queue_dropped: u64,
    /// Samples repeated or out of order (board time not after the last row), not written.
    pub out_of_order_samples: u64,
    /// Output samples the board produced from the first to the last
    /// `Status` (its `Health` counters; `None` when the last could not be read).
    pub board_samples_produced: Option<u32>,
    /// Frames the board dropped because its transmit queue was full, over the same span.
    pub board_tx_dropped: Option<u32>,
    /// Pairs the board saw saturated, over the same span.
    pub board_saturated_pairs: Option<u32>,
    /// The board's integrity states of the rows written, the longest
    /// stretches not `ok` and `cal_invalid` on its clock, and its on-line
    /// hard iron from its `Health` at the end (`hard_iron_applied` `None`
    /// when the last `Status` could not be read).
    #[serde(default)]
    pub integrity: IntegrityCounts,
    /// "Recalibrate" with the evidence, by the session's rule
    /// ([`crate::doc::integrity::recalibrate_evidence`]); absent when
    /// the calibration fits.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recalibrate: Option<RecalibrateEvidence>,
    /// Why logging ended.
    pub ended: LogEnd,
    /// Host time spent logging, s.
    pub wall_s: f64,
}

/// The state shown on the progress line.
#[derive(Debug, Clone, Copy)]
pub struct LogProgress {
    /// Rows written so far.
    pub samples: u64,
    /// Board time of the last row, s.
    pub last_t_s: f64,
    /// Gaps so far.
    pub gaps: usize,
    /// Link drops so far.
    pub link_drops: u32,
    /// The link is down (reconnecting).
    pub link_down: bool,
}

/// Logs the board's raw stream into `out` (a fresh file, see
/// [`create_log_file`], written only once the link is up; `out_path`
/// names it in errors) until the duration
/// passes, `stop` is set, or the board restarts. `connect` opens the link
/// (at the start and after each drop); `on_progress` sees every batch.
pub fn log_board<P: Read + Write, W: Write>(
    connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>,
    out: W,
    out_path: PathBuf,
    opts: &LogOptions,
    stop: &AtomicBool,
    mut on_progress: impl FnMut(&LogProgress),
) -> Result<LogSummary, LogError> {
    if !(1..=100).contains(&opts.rate_hz) {
        return Err(LogError::RateOutOfRange(opts.rate_hz));
    }
    let (mut link, health_start) = start_streaming(connect, opts)?;
    let mut log = Logger::new(out, out_path, opts.rate_hz)?;
    let started = Instant::now();
    let mut last_sample_at = Instant::now();
    let mut link_alive = true;
    let ended = loop {
        if let Some(end) = time_to_stop(stop, opts, started) {
            break end;
        }
        let dropped = match link.next_sample(Duration::from_millis(100)) {
            Ok(Some(first)) => {
                let restarted = log.write_batch(&mut link, first)?;
                last_sample_at = Instant::now();
                if let Some(end) = restarted {
                    break end;
                }
                on_progress(&log.progress(false));
                false
            }
            Ok(None) => last_sample_at.elapsed() >= opts.silence,
            Err(_) => true,
        };
        if !dropped {
            continue;
        }
        // The link is down: reopen it (the session's reconnect), backing
        // off between rounds, until it answers or logging is over.
        log.count_drop(&link);
        link_alive = false;
        on_progress(&log.progress(true));
        match reopen(connect, opts, stop, started) {
            Ok(l) => {
                link = l;
                link_alive = true;
                last_sample_at = Instant::now();
            }
            Err(end) => break end,
        }
    };
    log.finish(ended, started, link_alive.then_some(&mut link), health_start)
}

/// Opens the link, checks a board answers, and starts its raw stream at the
/// asked rate; returns the link and the board's `Health` at the start.
fn start_streaming<P: Read + Write>(connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>, opts: &LogOptions) -> Result<(BoardClient<P>, Option<Health>), LogError> {
    let mut link = connect().map_err(LogError::Open)?;
    link.identify().map_err(LogError::Identify)?;
    let health_start = link.status().ok();
    link.set_output_rate(opts.rate_hz).map_err(LogError::Stream)?;
    link.set_stream(StreamMode::Raw).map_err(LogError::Stream)?;
    link.clear_samples();
    Ok((link, health_start))
}

/// Why logging should end now, if it should.
fn time_to_stop(stop: &AtomicBool, opts: &LogOptions, started: Instant) -> Option<LogEnd> {
    if stop.load(Ordering::Relaxed) {
        Some(LogEnd::Interrupted)
    } else if opts.duration.is_some_and(|d| started.elapsed() >= d) {
        Some(LogEnd::Duration)
    } else {
        None
    }
}

/// Reopens a dropped link, one attempt a round with a pause doubling from
/// `backoff_initial` to `backoff_max` between rounds, until it answers
/// (`Ok`) or logging is over (`Err` with why).
fn reopen<P: Read + Write>(connect: &mut dyn FnMut() -> Result<BoardClient<P>, ClientError>, opts: &LogOptions, stop: &AtomicBool, started: Instant) -> Result<BoardClient<P>, LogEnd> {
    let mut pause = opts.backoff_initial;
    loop {
        if let Some(end) = time_to_stop(stop, opts, started) {
            return Err(end);
        }
        let mut resume = Resume { connect: &mut *connect, stream: StreamMode::Raw, attempts: 1 };
        if let Ok(l) = reconnect_at(&mut resume, opts.rate_hz) {
            return Ok(l);
        }
        let until = Instant::now() + pause;
        while Instant::now() < until && !stop.load(Ordering::Relaxed) {
            std::thread::sleep(Duration::from_millis(20));
        }
        pause = (pause * 2).min(opts.backoff_max);
    }
}
