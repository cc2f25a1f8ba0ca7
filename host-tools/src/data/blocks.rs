//! The calibration document's optional `current` and `temperature` blocks
//! (the shared `docs/INTERFACES.md` draft), read apart from [`CalDoc`]
//! until the document reader knows them, and the check that a document has
//! no block a reader does not know.
//!
//! [`CalDoc`] (serde, unknown keys ignored) would silently drop these blocks;
//! the contract says a reader that does not know a block must refuse the
//! document. [`ExtraBlocks::load`] reads the same file again, knows every
//! key of the document and refuses any other one.

use std::path::{Path, PathBuf};

use serde::de::IgnoredAny;
use serde::{Deserialize, Serialize};

/// The thruster-current block: `h = matrix · (raw − bias − bias_per_a · motor_current_a)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurrentBlock {
    /// Field the thrusters add per ampere of `motor_current_a`, raw input units per A.
    pub bias_per_a: [f64; 3],
}

/// The temperature block: the sensor's gain changes by `gain_per_c` (relative,
/// per °C) away from `ref_c`: `raw ⊘ (1 + gain_per_c ⊙ (temp_c − ref_c))`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureBlock {
    /// Reference temperature, °C.
    pub ref_c: f64,
    /// Relative gain change per °C, per axis.
    pub gain_per_c: [f64; 3],
}

/// The optional blocks of a calibration document that [`CalDoc`] does not read.
///
/// [`CalDoc`]: super::CalDoc
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ExtraBlocks {
    /// Thruster-current compensation.
    pub current: Option<CurrentBlock>,
    /// Temperature compensation.
    pub temperature: Option<TemperatureBlock>,
}

/// Every key of the document; any other is refused by serde's
/// `deny_unknown_fields` with the key's name.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)] // the ignored keys are only there to be allowed
struct AllKeys {
    model: IgnoredAny,
    bias: IgnoredAny,
    matrix: IgnoredAny,
    field_nt: IgnoredAny,
    #[serde(default)]
    declination_deg: Option<IgnoredAny>,
    #[serde(default)]
    swing: Option<IgnoredAny>,
    #[serde(default)]
    quality: Option<IgnoredAny>,
    #[serde(default)]
    trace: Option<IgnoredAny>,
    #[serde(default)]
    current: Option<CurrentBlock>,
    #[serde(default)]
    temperature: Option<TemperatureBlock>,
}

/// Why the optional blocks could not be read.
#[derive(Debug, thiserror::Error)]
pub enum BlocksError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// An unknown block, or a block of the wrong shape.
    #[error("{path}: {source} (a calibration document may hold model, bias, matrix, field_nt, declination_deg, swing, current, temperature, quality, trace)")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        #[source]
        source: serde_json::Error,
    },
    /// A block's numbers are unusable.
    #[error("{path}: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

impl ExtraBlocks {
    /// Reads the optional blocks of the document at `path`, refusing any key
    /// that is not part of the document.
    pub fn load(path: &Path) -> Result<Self, BlocksError> {
        let text = std::fs::read_to_string(path).map_err(|source| BlocksError::Io { path: path.into(), source })?;
        Self::from_json(&text, path)
    }

    /// As [`ExtraBlocks::load`], from the document's text (`path` names it in errors).
    pub fn from_json(text: &str, path: &Path) -> Result<Self, BlocksError> {
        let keys: AllKeys = serde_json::from_str(text).map_err(|source| BlocksError::Parse { path: path.into(), source })?;
        let invalid = |reason: &str| BlocksError::Invalid { path: path.into(), reason: reason.into() };
        if let Some(c) = keys.current {
            if !c.bias_per_a.iter().all(|v| v.is_finite()) {
                return Err(invalid("current.bias_per_a must be finite numbers"));
            }
        }
        if let Some(t) = keys.temperature {
            if !(t.ref_c.is_finite() && t.gain_per_c.iter().all(|k| k.is_finite() && k.abs() < 0.1)) {
                return Err(invalid("temperature: ref_c must be finite and each gain_per_c below 0.1 per °C in size"));
            }
        }
        Ok(Self { current: keys.current, temperature: keys.temperature })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BASE: &str = r#""model": "full", "bias": [1, 2, 3], "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "field_nt": 50000"#;

    #[test]
    fn blocks_are_read_and_unknown_keys_refused() {
        let p = Path::new("cal.json");
        let none = ExtraBlocks::from_json(&format!("{{{BASE}}}"), p).unwrap();
        assert_eq!(none, ExtraBlocks::default());
        let both = ExtraBlocks::from_json(
            &format!(r#"{{{BASE}, "current": {{"bias_per_a": [0.5, -1.5, 2]}}, "temperature": {{"ref_c": 20, "gain_per_c": [0.001, 0, -0.002]}}}}"#),
            p,
        )
        .unwrap();
        assert_eq!(both.current.unwrap().bias_per_a, [0.5, -1.5, 2.0]);
        assert_eq!(both.temperature.unwrap().gain_per_c[2], -0.002);
        let e = ExtraBlocks::from_json(&format!(r#"{{{BASE}, "hysteresis": {{"k": 1}}}}"#), p).unwrap_err();
        assert!(matches!(e, BlocksError::Parse { .. }) && e.to_string().contains("unknown field `hysteresis`"), "{e}");
        let e = ExtraBlocks::from_json(&format!(r#"{{{BASE}, "current": {{"bias_per_amp": [1, 2, 3]}}}}"#), p).unwrap_err();
        assert!(e.to_string().contains("bias_per_amp"), "{e}");
        let e = ExtraBlocks::from_json(&format!(r#"{{{BASE}, "temperature": {{"ref_c": 20, "gain_per_c": [0.5, 0, 0]}}}}"#), p).unwrap_err();
        assert!(matches!(e, BlocksError::Invalid { .. }), "{e}");
    }
}
