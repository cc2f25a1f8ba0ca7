//! The field procedure's limits, in one leaf module: the session holds the
//! operator to them (`session::coverage`) and the report draws them
//! (`report`); neither imports the other for them.

/// Roll the paper's swing test reaches (±55°); the gate asks for ±40°.
pub const ROLL_GATE_DEG: f64 = 40.0;
/// Pitch the swing test reaches (±10°); the gate asks for ±7°.
pub const PITCH_GATE_DEG: f64 = 7.0;
