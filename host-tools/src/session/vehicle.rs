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

/// When the session's recording takes a step column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Taken {
    /// From the first row (NaN when a step has no value).
    FromStart,
    /// Once any of these columns of a step has a finite value (earlier rows
    /// NaN): the gyro's three together, the current, the speed.
    OnceAny(&'static [&'static str]),
    /// Not a recording column (a truth the session keeps apart).
    Never,
}

/// One of a [`Step`]'s columns: its registry name, its field, and when the
/// session's recording takes it.
#[derive(Clone, Copy)]
pub(crate) struct StepColumn {
    /// The registry name ([`col`]).
    pub name: &'static str,
    /// Reads the field.
    pub get: fn(&Step) -> f64,
    /// Sets the field.
    set: fn(&mut Step, f64),
    /// When the recording takes it.
    pub recorded: Taken,
}

/// A [`Step`]'s columns by registry name (`t`, `roll_deg`, `pitch_deg`
/// first: required): the one list a navigation stream is read by and the
/// session's recording is filled from (a test holds it to the registry).
pub(crate) const STEP_COLUMNS: [StepColumn; 13] = {
    use Taken::*;
    const fn c(name: &'static str, get: fn(&Step) -> f64, set: fn(&mut Step, f64), recorded: Taken) -> StepColumn {
        StepColumn { name, get, set, recorded }
    }
    [
        c(col::T, |s| s.t_s, |s, v| s.t_s = v, FromStart),
        c(col::ROLL_DEG, |s| s.roll_deg, |s, v| s.roll_deg = v, FromStart),
        c(col::PITCH_DEG, |s| s.pitch_deg, |s, v| s.pitch_deg = v, FromStart),
        c(col::REF_HEADING_DEG, |s| s.ref_heading_deg, |s, v| s.ref_heading_deg = v, FromStart),
        c(col::LAT_DEG, |s| s.lat_deg, |s, v| s.lat_deg = v, FromStart),
        c(col::LON_DEG, |s| s.lon_deg, |s, v| s.lon_deg = v, FromStart),
        c(col::TRUE_HEADING_DEG, |s| s.true_heading_deg, |s, v| s.true_heading_deg = v, Never),
        c(col::GYRO[0], |s| s.rate_rad_s[0], |s, v| s.rate_rad_s[0] = v, OnceAny(&col::GYRO)),
        c(col::GYRO[1], |s| s.rate_rad_s[1], |s, v| s.rate_rad_s[1] = v, OnceAny(&col::GYRO)),
        c(col::GYRO[2], |s| s.rate_rad_s[2], |s, v| s.rate_rad_s[2] = v, OnceAny(&col::GYRO)),
        c(col::MOTOR_CURRENT_A, |s| s.motor_current_a, |s, v| s.motor_current_a = v, OnceAny(&[col::MOTOR_CURRENT_A])),
        c(col::SPEED_MPS, |s| s.speed_mps, |s, v| s.speed_mps = v, OnceAny(&[col::SPEED_MPS])),
        c(col::TRUE_FIELD_NT, |s| s.true_field_nt, |s, v| s.true_field_nt = v, Never),
    ]
};

/// The names of [`STEP_COLUMNS`]: the columns a navigation stream may
/// carry, read by name.
const NAV_COLUMNS: [&str; STEP_COLUMNS.len()] = {
    let mut out = [""; STEP_COLUMNS.len()];
    let mut i = 0;
    while i < out.len() {
        out[i] = STEP_COLUMNS[i].name;
        i += 1;
    }
    out
};

impl Step {
    /// The step's value of the column named `name` (`None`: not a step column).
    pub(crate) fn column(&self, name: &str) -> Option<f64> {
        STEP_COLUMNS.iter().find(|c| c.name == name).map(|c| (c.get)(self))
    }
}

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
                    let nan = f64::NAN;
                    let mut step = Step { t_s: nan, roll_deg: nan, pitch_deg: nan, ref_heading_deg: nan, lat_deg: nan, lon_deg: nan, true_heading_deg: nan, feed_seq: None, rate_rad_s: [nan; 3], motor_current_a: nan, speed_mps: nan, true_field_nt: nan };
                    for c in &STEP_COLUMNS {
                        (c.set)(&mut step, v.get(c.name));
                    }
                    return Ok(Some(step));
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::table::{column_spec, merged_columns, ColumnSet};
    use crate::data::Recording;

    /// The session's columns are the registry's: every step column is a
    /// registry column; the recording takes exactly the step columns it
    /// holds; and every column `merge` carries from a navigation log into
    /// a recording is one a navigation stream may carry and the session
    /// records (a navigation column registered but dropped by the session
    /// fails here).
    #[test]
    fn the_step_columns_are_held_to_the_registry() {
        assert_eq!(NAV_COLUMNS[..3], [col::T, col::ROLL_DEG, col::PITCH_DEG]);
        for c in &STEP_COLUMNS {
            assert!(column_spec(c.name).is_some(), "{} is not a registry column", c.name);
            let in_recording = Recording::NAMES.contains(&c.name);
            assert_eq!(c.recorded != Taken::Never, in_recording, "{}", c.name);
            if let Taken::OnceAny(names) = c.recorded {
                assert!(names.contains(&c.name), "{}", c.name);
            }
        }
        for m in merged_columns() {
            assert!(STEP_COLUMNS.iter().any(|c| c.name == m.name && c.recorded != Taken::Never), "{} is not recorded by the session", m.name);
        }
        let mut names = NAV_COLUMNS.to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), NAV_COLUMNS.len(), "a column twice");
    }
}
