//! Data on disk: tables (CSV, [`table`]: the one reader and writer),
//! recordings, a heading-only compass's log ([`compass`]), and the merging of
//! a board log ([`board_log`]) with a navigation log ([`nav_log`]) kept on
//! another clock; vehicle logs imported as recordings ([`dataflash`],
//! [`nmea`]).

pub mod compass;
pub mod dataflash;
pub mod intake;
pub mod board_log;
pub mod merge;
pub mod nav_log;
pub mod import;
pub mod nmea;
pub mod pairing;
pub mod recording;
pub mod table;

pub use recording::{Recording, RecordingError};
