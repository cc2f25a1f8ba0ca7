//! The rows of a board log: one a sample, its cells by the registry's
//! board-output columns, and the summary kept as they are written.

use std::io::{self, Read, Write};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use magcal_protocol::{Health, Sample, StreamMode};

use super::clock::{BoardClock, ClockStep};
use super::{Gap, LogEnd, LogError, LogProgress, LogSummary};
use crate::board::client::BoardClient;
use crate::data::board_log::{self, HEALTH_AFTER_GAP, HEALTH_SATURATED};
use crate::data::table::{col, Cell, TableWriter};
use crate::doc::integrity::{recalibrate_evidence, IntegrityCounts, IntegrityTally, RECALIBRATE_CAL_INVALID_FRACTION};

/// Samples written between flushes and progress updates, at most.
const BATCH: usize = 64;

/// The temperature at the sensor of a sample, °C, when the board measured
/// one (its thermistor; `None` when open, shorted or not fitted).
pub fn sample_temp_c(s: &Sample) -> Option<f64> {
    s.temp_c.map(f64::from)
}

/// The `health` flags of a sample ([`HEALTH_SATURATED`], [`HEALTH_AFTER_GAP`]).
pub fn health_flags(s: &Sample, after_gap: bool) -> u32 {
    (if s.saturated { HEALTH_SATURATED } else { 0 }) | (if after_gap { HEALTH_AFTER_GAP } else { 0 })
}

/// One sample's values for the board log's row.
struct RowValues {
    t_s: f64,
    raw: Option<[f64; 3]>,
    temp_c: Option<f64>,
    health: u32,
    heading_sigma_deg: Option<f64>,
    integrity: &'static str,
}

impl RowValues {
    /// The cell under the registry column `name`; `None` for a column the
    /// board does not produce (a test holds every board-output column to
    /// a cell).
    fn cell(&self, name: &str) -> Option<Cell<'static>> {
        if let Some(k) = col::MAG.iter().position(|&m| m == name) {
            return Some(Cell::opt(self.raw.and_then(|r| r.get(k).copied())));
        }
        Some(match name {
            col::T => Cell::Fixed(self.t_s, 3),
            col::TEMP_C => Cell::opt(self.temp_c),
            col::HEALTH => Cell::Count(u64::from(self.health)),
            col::HEADING_SIGMA_DEG => Cell::opt(self.heading_sigma_deg),
            col::INTEGRITY => Cell::Text(self.integrity),
            _ => return None,
        })
    }
}

/// The log being written: the file, the board's clock unwrapped, and the
/// summary so far.
pub(super) struct Logger<W: Write> {
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
    pub(super) fn new(out: W, out_path: PathBuf, rate_hz: u8) -> Result<Self, LogError> {
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
    pub(super) fn write_batch<P: Read + Write>(&mut self, link: &mut BoardClient<P>, first: Sample) -> Result<Option<LogEnd>, LogError> {
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
        let values = RowValues {
            t_s,
            raw,
            temp_c: temp,
            health: health_flags(sample, after_gap),
            // The board's σ to 0.001° (the f32's digits beyond are noise).
            heading_sigma_deg: sample.heading_sigma_deg.map(|d| (f64::from(d) * 1000.0).round() / 1000.0),
            integrity: sample.integrity.name(),
        };
        let cells = board_log::COLUMNS.map(|c| values.cell(c).unwrap_or(Cell::Empty));
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
    pub(super) fn count_drop<P>(&mut self, link: &BoardClient<P>) {
        self.s.link_drops += 1;
        self.count_link(link);
    }

    pub(super) fn progress(&self, link_down: bool) -> LogProgress {
        let s = &self.s;
        LogProgress { samples: s.samples, last_t_s: s.last_t_s.unwrap_or(f64::NAN), gaps: s.gaps.len(), link_drops: s.link_drops, link_down }
    }

    /// Ends the log: flushed, and with a live link, its losses and the
    /// board's counters since the start (best effort: the file is complete
    /// whatever the board says now).
    pub(super) fn finish<P: Read + Write>(mut self, ended: LogEnd, started: Instant, link: Option<&mut BoardClient<P>>, health_start: Option<Health>) -> Result<LogSummary, LogError> {
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

    /// A registry column marked for the board's output without a cell here
    /// would be written empty on every row.
    #[test]
    fn every_board_output_column_has_a_cell() {
        let values = RowValues { t_s: 0.0, raw: None, temp_c: None, health: 0, heading_sigma_deg: None, integrity: "ok" };
        let missing: Vec<&str> = board_log::COLUMNS.into_iter().filter(|c| values.cell(c).is_none()).collect();
        assert!(missing.is_empty(), "board-output columns without a cell: {missing:?}");
    }

    /// Every cell lands under its own column, whatever the registry's order:
    /// a row written for one sample, read back by the header's names,
    /// against values worked by hand.
    #[test]
    fn each_cell_is_written_under_its_column() {
        let mut bytes = Vec::new();
        let mut log = Logger::new(&mut bytes, PathBuf::from("board.csv"), 10).unwrap();
        let sample = Sample {
            t_ms: 1234,
            raw: Some([1000.0, -2000.5, 3.0]),
            field_nt: None,
            heading_rad: None,
            saturated: true,
            feed_seq: None,
            temp_c: Some(21.5),
            heading_sigma_deg: Some(1.23456),
            integrity: magcal_protocol::Integrity::Disturbed,
        };
        log.write_row(&sample, 1234).unwrap();
        log.out.flush().unwrap();
        drop(log);
        let text = String::from_utf8(bytes).unwrap();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let cells: Vec<&str> = lines.next().unwrap().split(',').collect();
        // By hand: 1234 ms is 1.234 s; saturated is health bit 0; the σ to
        // 0.001°; the state's wire name.
        let expected = [("t", "1.234"), ("mx", "1000"), ("my", "-2000.5"), ("mz", "3"), ("temp_c", "21.5"), ("health", "1"), ("heading_sigma_deg", "1.235"), ("integrity", "disturbed")];
        let mut read: Vec<(&str, &str)> = header.iter().copied().zip(cells.iter().copied()).collect();
        let mut want = expected.to_vec();
        read.sort_unstable();
        want.sort_unstable();
        assert_eq!((read, header.len()), (want, cells.len()), "header {header:?}, row {cells:?}");
    }
}
