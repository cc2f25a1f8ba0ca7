//! ArduPilot's compass correction (`AP_Compass_Backend::correct_field`):
//! the matrix `s·Mat` of an instance from its parameters, and its inverse
//! applied to recover the raw field.

use std::collections::HashMap;

/// The correction matrix `s·Mat` of one compass instance from its
/// parameters (names per `AP_Compass`: the first compass `COMPASS_DIA_X`,
/// the second `COMPASS_DIA2_X`, …), as `AP_Compass_Backend::correct_field`
/// applies it: zero diagonals taken as 1, `COMPASS_SCALE` only within
/// 1/1.5…1.5. Also the parameters missing (ArduPilot's defaults taken: DIA
/// 1, ODI 0, SCALE 1). Shared with the MAVLink telemetry log's import.
pub(crate) fn compass_matrix(params: &HashMap<String, f64>, instance: u8) -> ([[f64; 3]; 3], Vec<String>) {
    let suffix = if instance == 0 { String::new() } else { (instance + 1).to_string() };
    let mut missing = Vec::new();
    let mut get = |base: &str, axis: &str, default: f64| {
        let name = format!("COMPASS_{base}{suffix}{axis}");
        params.get(&name).copied().unwrap_or_else(|| {
            missing.push(name);
            default
        })
    };
    let mut dia = [get("DIA", "_X", 1.0), get("DIA", "_Y", 1.0), get("DIA", "_Z", 1.0)];
    let odi = [get("ODI", "_X", 0.0), get("ODI", "_Y", 0.0), get("ODI", "_Z", 0.0)];
    let scale = get("SCALE", "", 1.0);
    if dia == [0.0; 3] {
        dia = [1.0; 3]; // correct_field sets zero diagonals to 1
    }
    // have_scale_factor: applied only within COMPASS_MIN/MAX_SCALE_FACTOR.
    let s = if (1.0 / 1.5..=1.5).contains(&scale) { scale } else { 1.0 };
    ([[dia[0], odi[0], odi[1]], [odi[0], dia[1], odi[2]], [odi[1], odi[2], dia[2]]].map(|r| r.map(|v| v * s)), missing)
}

/// The DataFlash import's matrix: [`compass_matrix`], the parameters
/// missing said once.
pub(super) fn compass_matrix_noted(params: &HashMap<String, f64>, instance: u8, notes: &mut Vec<String>) -> [[f64; 3]; 3] {
    let (m, missing) = compass_matrix(params, instance);
    if !missing.is_empty() {
        let note = format!("no PARM {} in the log before the first MAG: taken as ArduPilot's defaults (DIA 1, ODI 0, SCALE 1)", missing.join(", "));
        if !notes.contains(&note) {
            notes.push(note);
        }
    }
    m
}

/// `m⁻¹·v`, `None` when `m` is singular.
pub(crate) fn solve3(m: &[[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let inv = calib_core::linalg::inverse3(m)?;
    Some([0, 1, 2].map(|i| inv[i][0] * v[0] + inv[i][1] * v[1] + inv[i][2] * v[2]))
}
