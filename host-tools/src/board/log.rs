//! `magcal log`: the board's raw stream written to a board log (the CSV
//! that [`crate::data::board_log::BoardLog`] reads), on the board's own clock,
//! for as long as asked.
//!
//! * `t` is the board's `t_ms` in seconds, unwrapped across the `u32`
//!   millisecond counter's wrap-around (every 49.7 days) by [`BoardClock`];
//! * every row is written and flushed as it arrives, so a killed process
//!   loses nothing it had written;
//! * a dropped link is reopened (the session's reconnect, with a growing
//!   backoff between rounds) and logging goes on; the samples lost meanwhile
//!   show as a gap in `t`, the first sample after it carries
//!   [`HEALTH_AFTER_GAP`], and the gaps are listed in the [`LogSummary`];
//! * the board's `Health` counters before and after give what the board
//!   produced and dropped on its side;
//! * the board's integrity state of every sample is counted
//!   ([`IntegrityTally`]), with the on-line hard iron from its `Health` at
//!   the end, and the session's "recalibrate" rule
//!   ([`crate::doc::integrity::recalibrate_evidence`]) judges them.

use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use magcal_protocol::{Health, Sample, StreamMode};
use serde::{Deserialize, Serialize};

use super::client::{BoardClient, ClientError};
use super::reconnect::{reconnect_at, Resume};
use crate::data::board_log::{self, HEALTH_AFTER_GAP, HEALTH_SATURATED};
use crate::data::table::{Cell, TableWriter};
use crate::doc::results::RecalibrateEvidence;
use crate::doc::integrity::{recalibrate_evidence, IntegrityCounts, IntegrityTally, RECALIBRATE_CAL_INVALID_FRACTION};

/// Samples written between flushes and progress updates, at most.
const BATCH: usize = 64;

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

/// What [`BoardClock::unwrap`] made of a `t_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClockStep {
    /// Milliseconds since the board's boot, unwrapped.
    Ms(u64),
    /// Not after the last time (a repeated or reordered sample).
    Stale,
    /// The clock went back by less than half its range: the board restarted.
    Restarted,
}

/// A step back of less than this is a repeated sample, not a restart, ms.
const STALE_MS: u32 = 50;

/// The board's `u32` millisecond clock unwrapped into a `u64`: a step
/// backwards by more than half the counter's range is a wrap-around (the
/// counter passed 2³² − 1), a smaller one a restart (its uptime starts
/// again from 0) unless it is under 50 ms (a repeated sample).
#[derive(Debug, Clone, Copy, Default)]
pub struct BoardClock {
    last: Option<u64>,
}

impl BoardClock {
    /// The unwrapped time of `t_ms`, the sample after the last one taken.
    pub fn unwrap(&mut self, t_ms: u32) -> ClockStep {
        let Some(last) = self.last else {
            self.last = Some(u64::from(t_ms));
            return ClockStep::Ms(u64::from(t_ms));
        };
        let last_low = last as u32;
        let ahead = t_ms.wrapping_sub(last_low);
        if ahead == 0 {
            ClockStep::Stale
        } else if ahead < 1 << 31 {
            let now = last + u64::from(ahead);
            self.last = Some(now);
            ClockStep::Ms(now)
        } else if last_low.wrapping_sub(t_ms) < STALE_MS {
            // A hair behind: a repeated sample.
            ClockStep::Stale
        } else {
            ClockStep::Restarted
        }
    }
}

/// The temperature at the sensor of a sample, °C, when the board measured
/// one (its thermistor; `None` when open, shorted or not fitted).
pub fn sample_temp_c(s: &Sample) -> Option<f64> {
    s.temp_c.map(f64::from)
}

/// The `health` flags of a sample ([`HEALTH_SATURATED`], [`HEALTH_AFTER_GAP`]).
pub fn health_flags(s: &Sample, after_gap: bool) -> u32 {
    (if s.saturated { HEALTH_SATURATED } else { 0 }) | (if after_gap { HEALTH_AFTER_GAP } else { 0 })
}

/// The board log's file, made by [`create_log_file`]: checked when made,
/// created only when its first bytes come (the port open and a board
/// answering), written and flushed as the rows arrive.
///
/// A new log is written at its path directly (a killed process loses
/// nothing it had written). One that replaces an existing log (`force`)
/// is written to a temporary beside it ([`crate::files::Temporary`]) and
/// renamed over the old log by [`LogOutput::finish`] only when it holds
/// samples: a port that does not open, a board that does not answer or a
/// log ended before its first sample leave the old log as it was.
#[derive(Debug)]
pub struct LogOutput {
    path: PathBuf,
    /// An existing log is to be replaced.
    replaces: bool,
    file: LogFile,
    /// Line ends written (the header's and one per row).
    lines: u64,
}

#[derive(Debug)]
enum LogFile {
    /// Nothing written yet: nothing made.
    NotYet,
    /// A new file at the path.
    Live(std::fs::File),
    /// A temporary that replaces the old log when it holds samples.
    Replacing(crate::files::Temporary),
}

/// Checks the output for a new log (before the port is touched): refused
/// when it exists unless `force`, and as [`crate::files::check_output`]
/// refuses it (a directory, a device, a pipe, a read-only file, a folder
/// that cannot be written). Nothing is created until the first write.
pub fn create_log_file(path: &std::path::Path, force: bool) -> Result<LogOutput, LogError> {
    if !force && std::fs::symlink_metadata(path).is_ok() {
        return Err(LogError::Exists(path.to_path_buf()));
    }
    // Never a directory, a device or a pipe, even with --force.
    let replaces = crate::files::check_output(path, &[])? == crate::files::Replaces::ExistingFile;
    Ok(LogOutput { path: path.to_path_buf(), replaces, file: LogFile::NotYet, lines: 0 })
}

impl LogOutput {
    /// Whether rows were written beyond the header.
    pub fn holds_samples(&self) -> bool {
        self.lines > 1
    }

    /// Whether an existing log is to be replaced (`force` on a log there).
    pub fn replaces(&self) -> bool {
        self.replaces
    }

    /// Ends the file. With samples: a new log stays, a replacing one is
    /// renamed over the old log (keeping its mode). Without: the
    /// replacing temporary is removed (the old log kept as it was); a new
    /// log holding its header alone is removed when `logged` is false
    /// (logging failed), kept otherwise (a log that ran and saw nothing).
    pub fn finish(self, logged: bool) -> Result<(), LogError> {
        let samples = self.holds_samples();
        match self.file {
            LogFile::NotYet => Ok(()),
            LogFile::Live(file) => {
                drop(file);
                if !samples && !logged {
                    std::fs::remove_file(&self.path).map_err(|source| LogError::Io { path: self.path.clone(), source })?;
                }
                Ok(())
            }
            LogFile::Replacing(tmp) if samples => Ok(tmp.commit()?),
            LogFile::Replacing(tmp) => {
                drop(tmp);
                Ok(())
            }
        }
    }

    /// The file, made at the first write.
    fn file(&mut self) -> io::Result<&mut dyn Write> {
        if let LogFile::NotYet = self.file {
            self.file = if self.replaces {
                LogFile::Replacing(crate::files::Temporary::beside(&self.path).map_err(io::Error::other)?)
            } else {
                // Not there when checked: still not there, or it is not ours.
                LogFile::Live(std::fs::OpenOptions::new().write(true).create_new(true).open(&self.path)?)
            };
        }
        Ok(match &mut self.file {
            LogFile::Live(f) => f,
            LogFile::Replacing(t) => t.file_mut(),
            LogFile::NotYet => unreachable!("made above"),
        })
    }
}

impl Write for LogOutput {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let n = self.file()?.write(buf)?;
        self.lines += buf[..n].iter().filter(|&&b| b == b'\n').count() as u64;
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        match &mut self.file {
            LogFile::NotYet => Ok(()),
            LogFile::Live(f) => f.flush(),
            LogFile::Replacing(t) => t.file_mut().flush(),
        }
    }
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

/// The log being written: the file, the board's clock unwrapped, and the
/// summary so far.
struct Logger<W: Write> {
    out: TableWriter<W>,
    out_path: PathBuf,
    clock: BoardClock,
    /// The output interval, ms.
    interval_ms: f64,
    /// The board time of the last row written, ms.
    last_ms: Option<u64>,
    /// The board's integrity states so far.
    tally: IntegrityTally,
    s: LogSummary,
}

impl<W: Write> Logger<W> {
    /// Starts the log: the header, flushed.
    fn new(out: W, out_path: PathBuf, rate_hz: u8) -> Result<Self, LogError> {
        let s = LogSummary {
            out: out_path.clone(),
            samples: 0,
            first_t_s: None,
            last_t_s: None,
            rate_hz,
            gaps: vec![],
            gap_total_s: 0.0,
            missing_samples: 0,
            link_drops: 0,
            saturated_samples: 0,
            samples_with_temp: 0,
            host_discarded_frames: 0,
            host_queue_dropped: 0,
            out_of_order_samples: 0,
            board_samples_produced: None,
            board_tx_dropped: None,
            board_saturated_pairs: None,
            integrity: IntegrityCounts::default(),
            recalibrate: None,
            ended: LogEnd::Interrupted,
            wall_s: 0.0,
        };
        let table = TableWriter::new(out, &board_log::COLUMNS).map_err(|source| LogError::Io { path: out_path.clone(), source })?;
        let mut log = Self { out: table, out_path, clock: BoardClock::default(), interval_ms: 1000.0 / f64::from(rate_hz), last_ms: None, tally: IntegrityTally::default(), s };
        log.out.flush().map_err(|e| log.io_err(e))?;
        Ok(log)
    }

    fn io_err(&self, source: io::Error) -> LogError {
        LogError::Io { path: self.out_path.clone(), source }
    }

    /// Writes `first` and what has arrived after it (a bounded batch: a
    /// stream faster than the file would never end one), then flushes;
    /// `Some` when the board restarted (the log ends there).
    fn write_batch<P: Read + Write>(&mut self, link: &mut BoardClient<P>, first: Sample) -> Result<Option<LogEnd>, LogError> {
        let mut next = Some(first);
        let mut batch = 0;
        while let Some(sample) = next {
            match self.clock.unwrap(sample.t_ms) {
                ClockStep::Stale => self.s.out_of_order_samples += 1,
                ClockStep::Restarted => return Ok(Some(LogEnd::BoardRestarted)),
                ClockStep::Ms(ms) => self.write_row(&sample, ms)?,
            }
            batch += 1;
            // (An error here shows again on the next wait.)
            next = if batch < BATCH { link.next_sample(Duration::ZERO).ok().flatten() } else { None };
        }
        self.out.flush().map_err(|e| self.io_err(e))?;
        Ok(None)
    }

    /// One row at board time `ms`, noting the gap before it if there is one.
    fn write_row(&mut self, sample: &Sample, ms: u64) -> Result<(), LogError> {
        let t_s = ms as f64 / 1000.0;
        let after_gap = self.last_ms.is_some_and(|l| (ms - l) as f64 > 1.5 * self.interval_ms);
        if let (true, Some(l)) = (after_gap, self.last_ms) {
            let length_s = (ms - l) as f64 / 1000.0;
            let missing = ((ms - l) as f64 / self.interval_ms).round().max(1.0) as u64 - 1;
            self.s.gaps.push(Gap { after_t_s: l as f64 / 1000.0, length_s, missing_samples: missing });
            self.s.gap_total_s += length_s;
            self.s.missing_samples += missing;
        }
        let raw = sample.raw.map(|r| r.map(f64::from));
        let temp = sample_temp_c(sample);
        let flags = health_flags(sample, after_gap);
        // The board's σ to 0.001° (the f32's digits beyond are noise) and
        // its integrity word.
        let sigma = sample.heading_sigma_deg.map(|d| (f64::from(d) * 1000.0).round() / 1000.0);
        let field = |k: usize| Cell::opt(raw.map(|r| r[k]));
        let cells = [Cell::Fixed(t_s, 3), field(0), field(1), field(2), Cell::opt(temp), Cell::Count(u64::from(flags)), Cell::opt(sigma), Cell::Text(sample.integrity.name())];
        self.out.row(&cells).map_err(|e| self.io_err(e))?;
        self.s.samples += 1;
        self.tally.push(sample.integrity, t_s);
        self.s.saturated_samples += u64::from(sample.saturated);
        self.s.samples_with_temp += u64::from(temp.is_some());
        self.s.first_t_s.get_or_insert(t_s);
        self.s.last_t_s = Some(t_s);
        self.last_ms = Some(ms);
        Ok(())
    }

    /// Adds the link's host-side losses to the summary.
    fn count_link<P>(&mut self, link: &BoardClient<P>) {
        self.s.host_discarded_frames += u64::from(link.discarded_frames);
        self.s.host_queue_dropped += link.dropped_samples;
    }

    /// A link drop: counted, with what the dropped link had lost.
    fn count_drop<P>(&mut self, link: &BoardClient<P>) {
        self.s.link_drops += 1;
        self.count_link(link);
    }

    fn progress(&self, link_down: bool) -> LogProgress {
        let s = &self.s;
        LogProgress { samples: s.samples, last_t_s: s.last_t_s.unwrap_or(f64::NAN), gaps: s.gaps.len(), link_drops: s.link_drops, link_down }
    }

    /// Ends the log: flushed, and with a live link, its losses and the
    /// board's counters since the start (best effort: the file is complete
    /// whatever the board says now).
    fn finish<P: Read + Write>(mut self, ended: LogEnd, started: Instant, link: Option<&mut BoardClient<P>>, health_start: Option<Health>) -> Result<LogSummary, LogError> {
        self.s.ended = ended;
        self.s.wall_s = started.elapsed().as_secs_f64();
        self.out.flush().map_err(|e| self.io_err(e))?;
        if let Some(link) = link {
            self.count_link(link);
            let health_end = link.status().ok();
            let _ = link.set_stream(StreamMode::Off);
            if let (Some(a), Some(b)) = (health_start, health_end) {
                (self.s.board_samples_produced, self.s.board_tx_dropped, self.s.board_saturated_pairs) = health_deltas(&a, &b);
            }
            if let Some(b) = &health_end {
                // After a restart the start's counters were another run's.
                let start = health_start.as_ref().filter(|_| !matches!(ended, LogEnd::BoardRestarted));
                let (applied, estimate_nt) = hard_iron_over_log(start, b);
                self.tally.set_hard_iron(applied, estimate_nt);
            }
        }
        self.s.integrity = self.tally.counts();
        self.s.recalibrate = recalibrate_evidence(&self.s.integrity, RECALIBRATE_CAL_INVALID_FRACTION);
        Ok(self.s)
    }
}

/// The board's counters between two `Status` replies (`None` when the
/// board restarted in between: its uptime went back).
fn health_deltas(a: &Health, b: &Health) -> (Option<u32>, Option<u32>, Option<u32>) {
    if b.uptime_ms < a.uptime_ms {
        return (None, None, None);
    }
    (Some(b.device.samples.wrapping_sub(a.device.samples)), Some(b.board.tx_dropped.wrapping_sub(a.board.tx_dropped)), Some(b.board.saturated.wrapping_sub(a.board.saturated)))
}

/// The board's on-line hard iron over a log, from its `Health` at the
/// start (if read, and the board not restarted since) and at the end:
/// applied when it is applied now or was applied again since the start
/// (any application since a restart between the two: the uptime or the
/// sample counter went back), and the estimate at the end, nT.
pub fn hard_iron_over_log(start: Option<&Health>, end: &Health) -> (Option<bool>, Option<[f64; 3]>) {
    let before = start.filter(|a| a.uptime_ms <= end.uptime_ms && a.device.samples <= end.device.samples).map_or(0, |a| a.hard_iron_applications);
    let applied = end.hard_iron_applied || end.hard_iron_applications > before;
    (Some(applied), end.hard_iron_nt.map(|h| h.map(f64::from)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counter's wrap-around continues the time; a small step back is
    /// a stale sample; a large one (not a wrap) a restart.
    #[test]
    fn the_board_clock_unwraps_and_tells_a_restart() {
        let mut c = BoardClock::default();
        assert_eq!(c.unwrap(u32::MAX - 14), ClockStep::Ms(u64::from(u32::MAX) - 14));
        // 2³² − 15 + 20 ms = 2³² + 5 ms.
        assert_eq!(c.unwrap(5), ClockStep::Ms((1u64 << 32) + 5));
        assert_eq!(c.unwrap(15), ClockStep::Ms((1u64 << 32) + 15));
        assert_eq!(c.unwrap(15), ClockStep::Stale);
        assert_eq!(c.unwrap(5), ClockStep::Stale);
        assert_eq!(c.unwrap(25), ClockStep::Ms((1u64 << 32) + 25));
        let mut d = BoardClock::default();
        assert_eq!(d.unwrap(3_600_000), ClockStep::Ms(3_600_000));
        assert_eq!(d.unwrap(3_599_990), ClockStep::Stale);
        assert_eq!(d.unwrap(1_200), ClockStep::Restarted);
    }

    #[test]
    fn an_existing_output_is_refused_unless_forced() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("board.csv");
        std::fs::write(&p, "keep me").unwrap();
        let e = create_log_file(&p, false).unwrap_err();
        assert!(matches!(&e, LogError::Exists(p) if p == &dir.path().join("board.csv")) && e.to_string().contains("exists"), "{e}");
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "keep me");
        // Forced, nothing written (the port did not open): the old log kept
        // (it was once truncated to nothing).
        create_log_file(&p, true).unwrap().finish(false).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "keep me");
    }

    #[test]
    fn a_forced_log_replaces_the_old_one_only_when_it_holds_samples() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("board.csv");
        let old = "t,mx\n1,2\n";
        std::fs::write(&p, old).unwrap();
        #[cfg(unix)]
        std::fs::set_permissions(&p, std::os::unix::fs::PermissionsExt::from_mode(0o644)).unwrap();
        let listing = || {
            let mut v: Vec<String> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
            v.sort();
            v
        };
        // The header alone (the board stopped before its first sample).
        let mut out = create_log_file(&p, true).unwrap();
        out.write_all(format!("{LOG_HEADER}\n").as_bytes()).unwrap();
        out.flush().unwrap();
        assert!(!out.holds_samples() && out.replaces());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), old, "the old log untouched while logging");
        out.finish(true).unwrap();
        assert_eq!((std::fs::read_to_string(&p).unwrap().as_str(), listing()), (old, vec!["board.csv".to_string()]));
        // With rows: replaced, keeping the old file's mode.
        let mut out = create_log_file(&p, true).unwrap();
        let new = format!("{LOG_HEADER}\n0.010,1,2,3,,0,,ok\n");
        out.write_all(new.as_bytes()).unwrap();
        assert!(out.holds_samples());
        out.finish(true).unwrap();
        assert_eq!((std::fs::read_to_string(&p).unwrap(), listing()), (new, vec!["board.csv".to_string()]));
        #[cfg(unix)]
        assert_eq!(std::os::unix::fs::PermissionsExt::mode(&std::fs::metadata(&p).unwrap().permissions()) & 0o777, 0o644);
        // A new log that failed before its first row leaves nothing; one
        // that ran and saw nothing keeps its header.
        let q = dir.path().join("new.csv");
        let mut out = create_log_file(&q, false).unwrap();
        out.write_all(b"t,mx\n").unwrap();
        out.finish(false).unwrap();
        assert!(!q.exists());
        let mut out = create_log_file(&q, false).unwrap();
        out.write_all(b"t,mx\n").unwrap();
        out.finish(true).unwrap();
        assert_eq!(std::fs::read_to_string(&q).unwrap(), "t,mx\n");
    }
}
