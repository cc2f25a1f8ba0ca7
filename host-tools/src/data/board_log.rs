//! The board's log (`docs/INTERFACES.md`, "Board log"): raw field samples
//! on the board's clock, as `magcal log` writes them
//! (`board::log`) and `magcal merge` reads them. The one home of
//! its columns: the writer's header, the reader's column names, the
//! simulator's split and the session tests' fake board all take them from
//! here.

use std::path::Path;

use super::recording::RecordingError;
use super::table::{board_output_names, col, column_set, present_columns, read_table_mapped, take_columns, write_table, ColumnMap, ColumnSet};

/// `t`: seconds on the board's clock.
pub const T: &str = col::T;
/// `mx`, `my`, `mz`: the raw field, sensor units.
pub const MAG: [&str; 3] = col::MAG;
/// `temp_c`: the sensor's temperature, °C (optional).
pub const TEMP_C: &str = col::TEMP_C;
/// `health`: the sample's health bits (optional; see [`HEALTH_SATURATED`]).
pub const HEALTH: &str = col::HEALTH;
/// Every column in the order the board writes them: the registry's
/// columns marked `board_output`, in its order.
pub const COLUMNS: [&str; 8] = board_output_names();
/// The header line the board writes ([`COLUMNS`] joined by commas).
pub const HEADER: &str = "t,mx,my,mz,temp_c,health,heading_sigma_deg,integrity";

/// `health` bit: a channel was saturated (the raw field is not usable).
pub const HEALTH_SATURATED: u32 = 1;
/// `health` bit: the first sample after a gap (a link drop) in the log.
pub const HEALTH_AFTER_GAP: u32 = 2;

/// The board's log: raw field samples on the board's clock.
#[derive(Debug, Clone, Default)]
pub struct BoardLog {
    /// `t`, seconds on the board's clock.
    pub t_s: Vec<f64>,
    /// `mx, my, mz`, raw sensor units.
    pub mag: Vec<[f64; 3]>,
    /// `temp_c`, °C, when logged.
    pub temp_c: Option<Vec<f64>>,
    /// `health`: 0 good, bit 0 a channel saturated, bit 1 the first sample
    /// after a link drop (when logged).
    pub health: Option<Vec<f64>>,
}

// The board log's columns by their registry names (`mx, my, mz` are `mag`).
column_set!(BoardLog { required: [T => t_s], optional: [TEMP_C => temp_c, HEALTH => health] });

impl BoardLog {
    /// Reads a board log: `t, mx, my, mz` required, `temp_c`, `health` optional.
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        Self::read_mapped(path, &ColumnMap::default())
    }

    /// [`BoardLog::read`] under the file's own names and units (`map`: a
    /// board log exported by another tool, `t` in µs).
    pub fn read_mapped(path: &Path, map: &ColumnMap) -> Result<Self, RecordingError> {
        let file = std::fs::File::open(path).map_err(|source| super::table::TableError::Io { path: path.into(), source })?;
        let mut t = read_table_mapped(file, path, &[T, MAG[0], MAG[1], MAG[2]], Self::NAMES.get(1..).unwrap_or_default(), map)?;
        let [mx, my, mz] = MAG.map(|c| t.take(c).unwrap_or_default());
        let mut log = Self { t_s: t.take(T).unwrap_or_default(), mag: mx.into_iter().zip(my).zip(mz).map(|((x, y), z)| [x, y, z]).collect(), ..Self::default() };
        take_columns(&mut log, &mut t);
        Ok(log)
    }

    /// Writes the log in the columns [`BoardLog::read`] reads.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let optional: Vec<(&str, &[f64])> = present_columns(self).into_iter().filter(|(n, _)| *n != T).collect();
        let header: Vec<&str> = [T, MAG[0], MAG[1], MAG[2]].into_iter().chain(optional.iter().map(|(n, _)| *n)).collect();
        let rows = self.t_s.iter().zip(&self.mag).enumerate().map(|(i, (t, m))| [*t].into_iter().chain(*m).chain(optional.iter().map(|(_, c)| c.get(i).copied().unwrap_or(f64::NAN))).collect());
        write_table(path, &header, rows)
    }

    /// Whether sample `i` is flagged saturated (its field is not usable).
    pub fn saturated(&self, i: usize) -> bool {
        let h = self.health.as_ref().and_then(|h| h.get(i)).copied().unwrap_or(0.0);
        h.is_finite() && (h as u32) & HEALTH_SATURATED != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_is_the_columns() {
        assert_eq!(HEADER, COLUMNS.join(","));
    }
}
