//! The column registry: the names ([`col`]), what each column measures and
//! which logs hold it ([`COLUMNS`]), and the log types reached by name
//! ([`ColumnSet`], [`column_set!`]).

use super::*;

/// The column names of `docs/INTERFACES.md`, in one place.
pub mod col {
    /// `t`: seconds (the log's clock).
    pub const T: &str = "t";
    /// `mx`, `my`, `mz`: the raw field, sensor units.
    pub const MAG: [&str; 3] = ["mx", "my", "mz"];
    /// `roll_deg`.
    pub const ROLL_DEG: &str = "roll_deg";
    /// `pitch_deg`.
    pub const PITCH_DEG: &str = "pitch_deg";
    /// `heading_deg`: the AHRS's heading.
    pub const HEADING_DEG: &str = "heading_deg";
    /// `ref_heading_deg`: GPS course or a reference heading, true.
    pub const REF_HEADING_DEG: &str = "ref_heading_deg";
    /// `lat_deg`.
    pub const LAT_DEG: &str = "lat_deg";
    /// `lon_deg`.
    pub const LON_DEG: &str = "lon_deg";
    /// `gx`, `gy`, `gz`: the body rate, rad/s.
    pub const GYRO: [&str; 3] = ["gx", "gy", "gz"];
    /// `speed_mps`: speed through water, m/s.
    pub const SPEED_MPS: &str = "speed_mps";
    /// `motor_current_a`: thruster current, A.
    pub const MOTOR_CURRENT_A: &str = "motor_current_a";
    /// `temp_c`: temperature at the magnetometer, °C.
    pub const TEMP_C: &str = "temp_c";
    /// `health`: the board sample's health bits.
    pub const HEALTH: &str = "health";
    /// `heading_sigma_deg`: the board's 1σ of a sample's heading, degrees
    /// (empty when the board had no heading).
    pub const HEADING_SIGMA_DEG: &str = "heading_sigma_deg";
    /// `integrity`: the board's judgement of a sample, a word (every
    /// `IntegrityState::name`).
    pub const INTEGRITY: &str = "integrity";
    /// `t_board`: a merged row's time on the board's clock, s.
    pub const T_BOARD: &str = "t_board";
    /// `true_heading_deg`: a reference (or the simulator's true) heading.
    pub const TRUE_HEADING_DEG: &str = "true_heading_deg";
    /// `true_field_nt`: the simulator's true field magnitude, nT.
    pub const TRUE_FIELD_NT: &str = "true_field_nt";
    /// `compass_heading_deg`: a heading-only compass's magnetic heading as
    /// the compass gives it (its own deviation not applied), degrees.
    pub const COMPASS_HEADING_DEG: &str = "compass_heading_deg";
    /// `variation_deg`: the magnetic variation (declination) a log states,
    /// degrees, east positive.
    pub const VARIATION_DEG: &str = "variation_deg";
    /// `course_deg`: GPS course over ground, true, degrees.
    pub const COURSE_DEG: &str = "course_deg";
    /// `gps_speed_mps`: GPS speed over ground, m/s.
    pub const GPS_SPEED_MPS: &str = "gps_speed_mps";
    /// `ahrs_yaw_deg`: the vehicle's own heading estimate (an autopilot's
    /// yaw, from its compasses: never a reference), degrees.
    pub const AHRS_YAW_DEG: &str = "ahrs_yaw_deg";
}

/// What a column measures: the unit a mapping may give it, and how it is
/// interpolated between two rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The magnetic field (nT, µT, gauss, mG, counts).
    Field,
    /// An attitude, heading, course or position angle (deg, rad).
    Angle,
    /// A heading or course: an angle interpolated the short way round 360°.
    Heading,
    /// A body rate (rad/s, deg/s).
    Rate,
    /// A time (s, ms, µs).
    Time,
    /// Anything else, in its one unit (m/s, A, °C, nT of a truth column, a
    /// health word): no unit may be given.
    Other,
}

/// How a column is carried between two clocks (`magcal merge` resampling a
/// navigation-log column to a board sample's time).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interp {
    /// Linearly.
    Linear,
    /// An angle on ±180° (roll), the short way round.
    Angle180,
    /// A heading or course on 0–360°, the short way round.
    Heading360,
}

/// Which logs hold a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Logs {
    /// A recording ([`crate::data::Recording`]: the calibration's input).
    pub recording: bool,
    /// A navigation log ([`crate::data::NavLog`]); with `recording` too,
    /// `magcal merge` resamples it into the merged recording.
    pub nav: bool,
    /// A board log ([`crate::data::board_log::BoardLog`]: what `magcal log`
    /// writes and `merge` reads).
    pub board: bool,
    /// The file `magcal log` writes (the board log's header, in this
    /// registry's order): the board log's columns and the board's own
    /// judgement of each sample, which [`crate::data::board_log::BoardLog`]
    /// does not read back.
    pub board_output: bool,
}

/// One column of the project: its name, what it measures, the largest
/// magnitude it may hold (angles, degrees), the logs that hold it and how it
/// is resampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    /// The name in the header.
    pub name: &'static str,
    /// What it measures.
    pub quantity: Quantity,
    /// Values beyond ± this are refused by row (angles), degrees.
    pub limit_deg: Option<f64>,
    /// The logs whose type holds it.
    pub logs: Logs,
    /// How it is resampled to another clock.
    pub interp: Interp,
}

const fn column(name: &'static str, quantity: Quantity, limit_deg: Option<f64>, logs: Logs, interp: Interp) -> Column {
    Column { name, quantity, limit_deg, logs, interp }
}

/// In a navigation log only.
const NAV: Logs = Logs { recording: false, nav: true, board: false, board_output: false };
/// In a recording and a navigation log: merged from the navigation log
/// into the recording.
const BOTH: Logs = Logs { recording: true, nav: true, board: false, board_output: false };
/// In a recording and the board log (the board's own measurements).
const REC_BOARD: Logs = Logs { recording: true, nav: false, board: true, board_output: true };
/// In the board log only.
const BOARD: Logs = Logs { recording: false, nav: false, board: true, board_output: true };
/// In every log (the time, each on its own clock).
const ALL: Logs = Logs { recording: true, nav: true, board: true, board_output: true };
/// Written by `magcal log` only (the board's judgement of a sample).
const BOARD_OUTPUT: Logs = Logs { recording: false, nav: false, board: false, board_output: true };
/// In none of the types (a truth, a compass log's or an output column).
const OTHER: Logs = Logs { recording: false, nav: false, board: false, board_output: false };

/// Every column a recording, a navigation log or a board log may hold: the
/// one list that the column mapping (`--columns`), the unit conversions, the
/// range checks, the recording's and navigation log's readers and writers,
/// and `merge`'s resampling read. A new column is one line here and its
/// field in the type that holds it ([`crate::data::Recording`],
/// [`crate::data::NavLog`], [`crate::data::board_log::BoardLog`]: one line
/// of their column list each).
pub const COLUMNS: [Column; 27] = {
    use col::*;
    use Interp::*;
    use Quantity::*;
    [
        column(T, Time, None, ALL, Linear),
        column(MAG[0], Field, None, REC_BOARD, Linear),
        column(MAG[1], Field, None, REC_BOARD, Linear),
        column(MAG[2], Field, None, REC_BOARD, Linear),
        column(ROLL_DEG, Angle, Some(180.0), BOTH, Angle180),
        column(PITCH_DEG, Angle, Some(90.0), BOTH, Linear),
        column(HEADING_DEG, Heading, None, NAV, Heading360),
        column(REF_HEADING_DEG, Heading, Some(360.0), BOTH, Heading360),
        column(LAT_DEG, Angle, None, BOTH, Linear),
        column(LON_DEG, Angle, None, BOTH, Linear),
        column(GYRO[0], Rate, None, BOTH, Linear),
        column(GYRO[1], Rate, None, BOTH, Linear),
        column(GYRO[2], Rate, None, BOTH, Linear),
        column(SPEED_MPS, Other, None, BOTH, Linear),
        column(MOTOR_CURRENT_A, Other, None, BOTH, Linear),
        column(TEMP_C, Other, None, REC_BOARD, Linear),
        column(HEALTH, Other, None, BOARD, Linear),
        column(HEADING_SIGMA_DEG, Other, None, BOARD_OUTPUT, Linear),
        column(INTEGRITY, Other, None, BOARD_OUTPUT, Linear),
        column(T_BOARD, Time, None, OTHER, Linear),
        column(TRUE_HEADING_DEG, Heading, None, OTHER, Heading360),
        column(TRUE_FIELD_NT, Other, None, OTHER, Linear),
        column(COMPASS_HEADING_DEG, Heading, Some(360.0), OTHER, Heading360),
        column(VARIATION_DEG, Angle, Some(180.0), OTHER, Linear),
        column(COURSE_DEG, Heading, Some(360.0), OTHER, Heading360),
        column(GPS_SPEED_MPS, Other, None, OTHER, Linear),
        column(AHRS_YAW_DEG, Heading, Some(360.0), OTHER, Heading360),
    ]
};

/// The columns `magcal merge` carries from the navigation log into the
/// recording (in both logs), but the time.
pub fn merged_columns() -> impl Iterator<Item = &'static Column> {
    COLUMNS.iter().filter(|c| c.logs.recording && c.logs.nav && c.name != col::T)
}

/// A log type whose columns are reached by their registry name. Implemented
/// by [`column_set!`] from the one list of (name, field) pairs beside the
/// type's definition; the registry test checks each pair against
/// [`COLUMNS`]' `logs`.
pub trait ColumnSet {
    /// The names of the type's columns, required then optional.
    const NAMES: &'static [&'static str];
    /// The column named `name`, when the type holds it and it is present.
    fn column(&self, name: &str) -> Option<&[f64]>;
    /// The slot of an optional column named `name`, when the type holds one.
    fn column_slot(&mut self, name: &str) -> Option<&mut Option<Vec<f64>>>;
}

/// Fills each optional column of `log` that `table` has, by name.
pub(crate) fn take_columns<C: ColumnSet>(log: &mut C, table: &mut Table) {
    for name in C::NAMES {
        if let Some(slot) = log.column_slot(name) {
            *slot = table.take(name);
        }
    }
}

/// The columns `log` has, by name, in its list's order (what its writer
/// writes).
pub(crate) fn present_columns<C: ColumnSet>(log: &C) -> Vec<(&'static str, &[f64])> {
    C::NAMES.iter().filter_map(|&n| log.column(n).map(|c| (n, c))).collect()
}

/// Implements [`ColumnSet`] from `required: NAME => field, …; optional:
/// NAME => field, …` (`Vec<f64>` and `Option<Vec<f64>>` fields).
macro_rules! column_set {
    ($ty:ty { required: [$($rn:expr => $rf:ident),* $(,)?], optional: [$($on:expr => $of:ident),* $(,)?] }) => {
        impl $crate::data::table::ColumnSet for $ty {
            const NAMES: &'static [&'static str] = &[$($rn,)* $($on,)*];
            fn column(&self, name: &str) -> Option<&[f64]> {
                $(if name == $rn { return Some(&self.$rf); })*
                $(if name == $on { return self.$of.as_deref(); })*
                None
            }
            fn column_slot(&mut self, name: &str) -> Option<&mut Option<Vec<f64>>> {
                $(if name == $on { return Some(&mut self.$of); })*
                None
            }
        }
    };
}
pub(crate) use column_set;

/// The names of the columns `magcal log` writes ([`Logs::board_output`]),
/// in the registry's order; `N` must be their count (checked when the
/// constant is evaluated, at compile time).
pub const fn board_output_names<const N: usize>() -> [&'static str; N] {
    let mut out = [""; N];
    let (mut i, mut n) = (0, 0);
    while i < COLUMNS.len() {
        if COLUMNS[i].logs.board_output {
            assert!(n < N, "more columns than N");
            out[n] = COLUMNS[i].name;
            n += 1;
        }
        i += 1;
    }
    assert!(n == N, "fewer columns than N");
    out
}

/// A project column by name.
pub fn column_spec(name: &str) -> Option<&'static Column> {
    COLUMNS.iter().find(|c| c.name == name)
}
