//! Column mapping and units: a log's own names and units given to the
//! project's columns (`--columns mx=NAME:uT`).

use super::*;

/// A unit a mapped column is given in (`--columns mx=NAME:uT`), converted
/// on reading to the project's: the field to nT, angles to degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColumnUnit {
    /// Nanotesla.
    Nanotesla,
    /// Microtesla (`uT` or `µT`).
    Microtesla,
    /// Gauss (1 G = 100 000 nT).
    Gauss,
    /// Milligauss (1 mG = 100 nT).
    Milligauss,
    /// Raw sensor counts: kept as they are.
    Counts,
    /// Degrees.
    Degrees,
    /// Radians.
    Radians,
    /// Radians per second (a gyro's rate).
    RadiansPerSecond,
    /// Degrees per second.
    DegreesPerSecond,
    /// Seconds (a time column).
    Seconds,
    /// Milliseconds.
    Milliseconds,
    /// Microseconds (e.g. ArduPilot's `TimeUS`).
    Microseconds,
}

/// What a unit measures: it fits only columns of the same kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum UnitKind {
    Field,
    Angle,
    Rate,
    Time,
}

/// The units a mapping may name, as written.
pub const COLUMN_UNITS: &str = "nT, uT, µT, gauss, mG, counts (field); deg, rad (angles); rad/s, deg/s (gx, gy, gz); s, ms, us (t, t_board)";

impl ColumnUnit {
    /// From its name (any case): `None` when unknown.
    fn parse(text: &str) -> Option<Self> {
        Some(match text.trim().to_ascii_lowercase().as_str() {
            "nt" => Self::Nanotesla,
            "ut" | "µt" | "μt" => Self::Microtesla,
            "g" | "gauss" => Self::Gauss,
            "mg" | "mgauss" | "milligauss" => Self::Milligauss,
            "counts" | "raw" => Self::Counts,
            "deg" | "degrees" => Self::Degrees,
            "rad" | "radians" => Self::Radians,
            "rad/s" | "rad_s" => Self::RadiansPerSecond,
            "deg/s" | "dps" | "deg_s" => Self::DegreesPerSecond,
            "s" | "sec" | "seconds" => Self::Seconds,
            "ms" | "milliseconds" => Self::Milliseconds,
            "us" | "µs" | "μs" | "microseconds" => Self::Microseconds,
            _ => return None,
        })
    }

    /// The factor to the project's unit (nT, degrees, rad/s, s; counts
    /// stay counts).
    fn factor(self) -> f64 {
        match self {
            Self::Nanotesla | Self::Counts | Self::Degrees | Self::RadiansPerSecond | Self::Seconds => 1.0,
            Self::Microtesla => 1e3,
            Self::Gauss => 1e5,
            Self::Milligauss => 100.0,
            Self::Radians => 180.0 / std::f64::consts::PI,
            Self::DegreesPerSecond => std::f64::consts::PI / 180.0,
            Self::Milliseconds => 1e-3,
            Self::Microseconds => 1e-6,
        }
    }

    /// What it measures.
    fn kind(self) -> UnitKind {
        match self {
            Self::Nanotesla | Self::Microtesla | Self::Gauss | Self::Milligauss | Self::Counts => UnitKind::Field,
            Self::Degrees | Self::Radians => UnitKind::Angle,
            Self::RadiansPerSecond | Self::DegreesPerSecond => UnitKind::Rate,
            Self::Seconds | Self::Milliseconds | Self::Microseconds => UnitKind::Time,
        }
    }
}

/// The project's columns a mapping may name: every one.
fn mappable_columns() -> Vec<&'static str> {
    COLUMNS.iter().map(|c| c.name).collect()
}

/// Why a column mapping could not be understood.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ColumnMapError {
    /// An entry is not `column=NAME` or `column=NAME:unit`.
    #[error("column mapping `{0}`: expected column=NAME or column=NAME:unit (e.g. mx=Magnetometer X (uT):uT)")]
    Syntax(String),
    /// The mapping names a column the project does not have.
    #[error("column mapping `{0}`: no such column; the columns are: {1}")]
    UnknownColumn(String, String),
    /// The unit is not one of [`COLUMN_UNITS`].
    #[error("column mapping `{0}`: unknown unit `{1}` (the units: {COLUMN_UNITS})")]
    UnknownUnit(String, String),
    /// A unit given for a column it does not fit (a field unit for an angle,
    /// any unit for a column other than the field's and the angles').
    #[error("column mapping `{0}`: a unit fits only mx, my, mz (nT, uT, gauss, mG, counts), angle columns (deg, rad), gx, gy, gz (rad/s, deg/s) and t, t_board (s, ms, us)")]
    WrongUnit(String),
    /// A column mapped twice.
    #[error("column mapping: `{0}` is mapped twice")]
    Duplicate(String),
}

/// The file's own names (and units) for the project's columns:
/// `mx=mag_x_gauss:gauss,my=...,roll_deg=Roll (rad):rad`. Names are matched
/// exactly but in any case; they may hold spaces and parentheses, not `,`
/// or `:`. Columns not mapped keep their project names.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ColumnMap {
    /// (project column, the file's name, unit).
    pub(super) entries: Vec<(&'static str, String, Option<ColumnUnit>)>,
}

impl std::str::FromStr for ColumnMap {
    type Err = ColumnMapError;

    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let mut entries: Vec<(&'static str, String, Option<ColumnUnit>)> = Vec::new();
        for entry in spec.split(',').map(str::trim).filter(|e| !e.is_empty()) {
            let (key, value) = entry.split_once('=').ok_or_else(|| ColumnMapError::Syntax(entry.into()))?;
            let known = mappable_columns();
            let column = *known.iter().find(|c| c.eq_ignore_ascii_case(key.trim())).ok_or_else(|| ColumnMapError::UnknownColumn(entry.into(), known.join(", ")))?;
            let (name, unit) = match value.rsplit_once(':') {
                Some((name, unit)) => (name, Some(ColumnUnit::parse(unit).ok_or_else(|| ColumnMapError::UnknownUnit(entry.into(), unit.trim().into()))?)),
                None => (value, None),
            };
            let name = name.trim();
            if name.is_empty() {
                return Err(ColumnMapError::Syntax(entry.into()));
            }
            if let Some(u) = unit {
                let kind = column_spec(column).and_then(|c| match c.quantity {
                    Quantity::Field => Some(UnitKind::Field),
                    Quantity::Angle | Quantity::Heading => Some(UnitKind::Angle),
                    Quantity::Rate => Some(UnitKind::Rate),
                    Quantity::Time => Some(UnitKind::Time),
                    Quantity::Other => None,
                });
                let fits = kind == Some(u.kind());
                if !fits {
                    return Err(ColumnMapError::WrongUnit(entry.into()));
                }
            }
            if entries.iter().any(|(c, _, _)| *c == column) {
                return Err(ColumnMapError::Duplicate(column.into()));
            }
            entries.push((column, name.to_string(), unit));
        }
        Ok(Self { entries })
    }
}

impl ColumnMap {
    /// The name the file gives the project's `column`.
    pub(super) fn file_name<'a>(&'a self, column: &'a str) -> &'a str {
        self.entries.iter().find(|(c, _, _)| *c == column).map_or(column, |(_, n, _)| n.as_str())
    }

    /// The unit the mapping gives the project's `column`, if any.
    pub fn unit(&self, column: &str) -> Option<ColumnUnit> {
        self.entries.iter().find(|(c, _, _)| *c == column).and_then(|(_, _, u)| *u)
    }

    /// The file's name of the project's `column` (its own name when not
    /// mapped).
    pub fn name_of<'a>(&'a self, column: &'a str) -> &'a str {
        self.file_name(column)
    }

    /// The factor from the file's unit of `column` to the project's.
    pub(super) fn factor(&self, column: &str) -> f64 {
        self.entries.iter().find(|(c, _, _)| *c == column).and_then(|(_, _, u)| *u).map_or(1.0, ColumnUnit::factor)
    }
}

/// For a missing field column: the header's names that look like the
/// magnetometer's, as a mapping to give (empty when none do).
pub(super) fn mapping_hint(header: &[&str]) -> String {
    let looks_like_field = |lower: &str| {
        let words: Vec<&str> = lower.split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).collect();
        let axis = words.iter().find_map(|w| match *w {
            "x" | "y" | "z" => Some(*w),
            w if w.starts_with("mag") && w.len() == 4 => w.get(3..),
            _ => None,
        });
        let unit = words.iter().find_map(|w| match *w {
            "ut" | "nt" | "gauss" | "mg" => Some(*w),
            _ => None,
        });
        let field = lower.contains("mag") || (axis.is_some() && (unit.is_some() || lower.contains("field")));
        field.then(|| (axis.map(str::to_string), unit.map(str::to_string)))
    };
    let candidates: Vec<(&str, Option<String>, Option<String>)> =
        header.iter().filter_map(|h| looks_like_field(&h.trim().to_lowercase()).map(|(a, u)| (h.trim(), a, u))).collect();
    if candidates.is_empty() {
        return String::new();
    }
    let by_axis: Vec<Option<String>> = ["x", "y", "z"]
        .iter()
        .zip(col::MAG)
        .map(|(axis, mag)| {
            let (name, _, unit) = candidates.iter().find(|(_, a, _)| a.as_deref() == Some(*axis))?;
            Some(format!("{mag}={name}{}", unit.as_ref().map(|u| format!(":{u}")).unwrap_or_default()))
        })
        .collect();
    let names = candidates.iter().map(|(n, _, _)| format!("`{n}`")).collect::<Vec<_>>().join(", ");
    match by_axis.into_iter().collect::<Option<Vec<_>>>() {
        Some(map) => format!("; {names} look like magnetometer columns: give the column mapping `{}`", map.join(",")),
        None => format!("; {names} look like magnetometer columns: give a column mapping `mx=NAME,my=NAME,mz=NAME`"),
    }
}
