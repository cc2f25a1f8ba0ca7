//! Vehicles: where a session's steps come from. A [`Vehicle`] plays the
//! three manoeuvres (swing test, out-and-back run, optional validation run):
//! a real vehicle's navigation arrives as CSV streams ([`NavVehicle`]); the
//! simulator's vehicle lives in the `magcal-sim` crate and plays the same
//! trait into the QEMU board's sensor feed.

use std::io::BufRead;

use super::error::{NavStreamError, SessionError};
use crate::board::ClientError;
use crate::data::table::{col, StreamColumns};

/// A manoeuvre of the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// The swing test: the vehicle turned through every heading, rolled and
    /// pitched, thrusters off.
    Swing,
    /// The out-and-back run with GPS at the surface.
    Run,
    /// A validation run on other courses, with a known heading.
    Validation,
}

impl Phase {
    /// The phase's file stem in the session directory (`swing.csv`, …).
    pub fn label(self) -> &'static str {
        match self {
            Phase::Swing => "swing",
            Phase::Run => "run",
            Phase::Validation => "validation",
        }
    }
}

/// The host-side columns of one step (the board supplies the field).
#[derive(Debug, Clone, Copy)]
pub struct Step {
    /// Time, s.
    pub t_s: f64,
    /// AHRS roll, degrees.
    pub roll_deg: f64,
    /// AHRS pitch, degrees.
    pub pitch_deg: f64,
    /// GPS course, degrees true (NaN when not available).
    pub ref_heading_deg: f64,
    /// Position, degrees (NaN when not available).
    pub lat_deg: f64,
    /// Position, degrees (NaN when not available).
    pub lon_deg: f64,
    /// The vehicle's true heading, degrees (validation; NaN when unknown).
    pub true_heading_deg: f64,
    /// The sensor-feed frame the board must have seen (simulated vehicle).
    pub feed_seq: Option<u32>,
    /// Body rates from the AHRS's gyro, rad/s (NaN when not available):
    /// sent to the board with the attitude, for its gyro-aided fit, and
    /// recorded as `gx, gy, gz`.
    pub rate_rad_s: [f64; 3],
    /// Thruster (motor) current, A (NaN when not available): sent to the
    /// board with the attitude, for its current term, and recorded as
    /// `motor_current_a`.
    pub motor_current_a: f64,
    /// Speed through water from the speed log, m/s (NaN when not
    /// available): recorded as `speed_mps`, for the swing fit's removal of
    /// the water current.
    pub speed_mps: f64,
    /// The magnitude of the true local field at the vehicle, nT (NaN when
    /// unknown: the validation's field error is then taken against IGRF at
    /// the logged position). A simulated vehicle knows it (crustal anomaly
    /// included); a real one may from a magnetic survey.
    pub true_field_nt: f64,
}

/// A source of steps: applies each step's stimulus to the board (simulated)
/// or waits for the vehicle's next navigation record (real).
pub trait Vehicle {
    /// Starts a manoeuvre. `Ok(false)`: this vehicle has none (only the
    /// validation run is optional).
    fn begin(&mut self, phase: Phase) -> Result<bool, SessionError>;
    /// The next step of the current manoeuvre, `None` when it is over.
    fn next_step(&mut self) -> Result<Option<Step>, ClientError>;
    /// Steps in the current manoeuvre, when known (for progress).
    fn len_hint(&self) -> Option<usize>;
    /// Applies the current step's stimulus again (it may have been lost).
    fn repeat(&mut self) -> Result<(), ClientError> {
        Ok(())
    }
    /// Whether each step's attitude goes to the board while raw data are
    /// recorded (a real vehicle: the board then pairs it with its sample).
    /// The validation run always sends it, for the board's heading.
    fn sends_attitude(&self) -> bool;
    /// One line for the session's settings: what played the manoeuvres.
    fn describe(&self) -> String;
}

/// Navigation columns a stream may carry (`t`, `roll_deg`, `pitch_deg`
/// required, first): the navigation log's (the registry's), a reference
/// heading and, from the simulator, the true field. Read by name.
const NAV_COLUMNS: [&str; 13] = [
    col::T,
    col::ROLL_DEG,
    col::PITCH_DEG,
    col::REF_HEADING_DEG,
    col::LAT_DEG,
    col::LON_DEG,
    col::TRUE_HEADING_DEG,
    col::GYRO[0],
    col::GYRO[1],
    col::GYRO[2],
    col::MOTOR_CURRENT_A,
    col::SPEED_MPS,
    col::TRUE_FIELD_NT,
];

/// One navigation stream: CSV lines in the INTERFACES.md columns from a
/// file, a FIFO or stdin, one line per step.
pub struct NavStream<R> {
    lines: std::io::Lines<R>,
    columns: StreamColumns,
    line_no: usize,
}

impl<R: BufRead> NavStream<R> {
    /// Reads the header; `t`, `roll_deg` and `pitch_deg` are required.
    pub fn new(reader: R) -> Result<Self, SessionError> {
        let mut lines = reader.lines();
        let header = lines
            .next()
            .ok_or(NavStreamError::Empty)?
            .map_err(NavStreamError::Read)?;
        let columns = StreamColumns::new(&header, &NAV_COLUMNS, 3).map_err(NavStreamError::Header)?;
        Ok(Self { lines, columns, line_no: 1 })
    }

    /// The next step; lines that are not numbers are skipped with a warning.
    pub fn next_step(&mut self) -> Result<Option<Step>, ClientError> {
        loop {
            let Some(line) = self.lines.next() else { return Ok(None) };
            self.line_no += 1;
            let line = line?;
            if line.trim().is_empty() {
                continue;
            }
            match self.columns.values(&line) {
                Some(v) if v.get(col::T).is_finite() => {
                    return Ok(Some(Step {
                        t_s: v.get(col::T),
                        roll_deg: v.get(col::ROLL_DEG),
                        pitch_deg: v.get(col::PITCH_DEG),
                        ref_heading_deg: v.get(col::REF_HEADING_DEG),
                        lat_deg: v.get(col::LAT_DEG),
                        lon_deg: v.get(col::LON_DEG),
                        true_heading_deg: v.get(col::TRUE_HEADING_DEG),
                        feed_seq: None,
                        rate_rad_s: col::GYRO.map(|g| v.get(g)),
                        motor_current_a: v.get(col::MOTOR_CURRENT_A),
                        speed_mps: v.get(col::SPEED_MPS),
                        true_field_nt: v.get(col::TRUE_FIELD_NT),
                    }))
                }
                _ => eprintln!("  navigation line {} skipped: not numbers: {line}", self.line_no),
            }
        }
    }
}

/// A real vehicle: its navigation for each manoeuvre arrives as a CSV
/// stream (AHRS attitude, GPS course, position; for validation, a reference
/// heading as `true_heading_deg`). Each stream's header is read when its
/// manoeuvre begins, so a FIFO is only opened by then.
pub struct NavVehicle<R> {
    streams: [Option<R>; 3],
    current: Option<NavStream<R>>,
}

impl<R: BufRead> NavVehicle<R> {
    /// The streams of the swing test, the run and (optionally) a validation
    /// run.
    pub fn new(swing: R, run: R, validation: Option<R>) -> Self {
        Self { streams: [Some(swing), Some(run), validation], current: None }
    }
}

impl<R: BufRead> Vehicle for NavVehicle<R> {
    fn begin(&mut self, phase: Phase) -> Result<bool, SessionError> {
        let slot = match phase {
            Phase::Swing => 0,
            Phase::Run => 1,
            Phase::Validation => 2,
        };
        match self.streams.get_mut(slot).and_then(Option::take) {
            Some(reader) => {
                self.current = Some(NavStream::new(reader)?);
                Ok(true)
            }
            None if phase == Phase::Validation => Ok(false),
            None => Err(NavStreamError::AlreadyUsed(phase.label()).into()),
        }
    }
    fn next_step(&mut self) -> Result<Option<Step>, ClientError> {
        match self.current.as_mut() {
            Some(s) => s.next_step(),
            None => Ok(None),
        }
    }
    fn len_hint(&self) -> Option<usize> {
        None
    }
    fn sends_attitude(&self) -> bool {
        true
    }
    fn describe(&self) -> String {
        "a real vehicle (navigation CSV streams)".into()
    }
}
