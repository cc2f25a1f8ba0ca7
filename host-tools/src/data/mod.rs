//! Data on disk: tables (CSV, [`table`]: the one reader and writer),
//! recordings, a heading-only compass's log ([`compass`]), and the merging of
//! a board log ([`board_log`]) with a navigation log ([`nav_log`]) kept on
//! another clock; vehicle logs imported as recordings ([`dataflash`],
//! [`nmea`]).

pub(crate) mod compass;
pub(crate) mod dataflash;
pub(crate) mod intake;
pub(crate) mod board_log;
pub(crate) mod merge;
pub(crate) mod nav_log;
pub(crate) mod import;
pub(crate) mod nmea;
pub(crate) mod pairing;
pub(crate) mod recording;
pub(crate) mod table;

pub use recording::{Recording, RecordingError};
pub use board_log::BoardLog;
pub use compass::CompassLog;
pub use import::{import, import_file, Format, ImportError, ImportOptions, Imported, Role};
pub use intake::{
    check_positions, read_compass, read_recording, Intake, IntakeError, SiteWarning, DECLINATION_CHANGE_LIMIT_DEG, SITE_REFUSE_KM,
    SITE_WARN_KM,
};
pub use merge::{merge, merge_files_with, Clock, MergeError, MergeOptions, MergeReport, SharedSignal, MAX_NAV_GAP_S};
pub use merge::{merge_files, merge_files_mapped, HEALTH_AFTER_GAP, HEALTH_SATURATED};
pub use nav_log::NavLog;
pub use pairing::TimePairer;
/// Each format's own file importer (the one [`import_file`] sniffs and dispatches).
pub use {dataflash::import_file as import_dataflash_file, nmea::import_file as import_nmea_file};
/// NMEA 0183 import, named apart from the format-sniffing [`import`] above.
pub use nmea::{import_reader as import_nmea_reader, ImportOptions as NmeaOptions, Imported as NmeaImported};
pub use pairing::wrap180;
pub use table::{col, ColumnMap};
