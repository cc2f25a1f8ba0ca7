//! Which field test a recording is: the one type both the field tests
//! ([`crate::field_test`]) and the effects ([`crate::effects`], e.g. a
//! payload switched on during one of them) name, so neither imports the
//! other for it.

use serde::{Deserialize, Serialize};

/// Which field test a recording is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FieldTest {
    /// The swing test.
    Swing,
    /// The out-and-back calibration run.
    Run,
    /// The out-and-back validation run.
    Validation,
}
