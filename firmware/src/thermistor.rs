//! The temperature at the magnetometer: an NTC thermistor in a divider on the
//! ADS131M04's spare channel (CH3; X/Y/Z use CH0–CH2, see `acquisition`).
//!
//! The part is a Murata **NCP18XH103F03RB** (0603, R25 = 10 kΩ ±1 %,
//! B25/50 = 3380 K ±1 %, B25/85 = 3434 K, B25/100 = 3455 K; Murata catalog
//! R44E, "Temperature Characteristics (Center Value)", XH column), mounted
//! against the sensor block. The divider:
//!
//! ```text
//! V_REF (1.25 V, TI REF3312) ── R_TOP 10.0 kΩ 0.1 % ──┬── AIN3P
//!                                                      NTC
//! AGND ────────────────────────────────────────────────┴── AIN3N
//! ```
//!
//! so `V = V_REF · R / (R + R_TOP)`, within the ADC's ±1.2 V at gain 1 from
//! −40 °C (1.189 V) to 125 °C (0.063 V). The thermistor does not see the
//! set/reset straps: its voltage is the same in both phases of a pair and
//! the acquisition averages the two codes.
//!
//! Code → °C: `R = R_TOP · V / (V_REF − V)`, then the Steinhart–Hart
//! equation `1/T = A + B ln R + C (ln R)³` with A, B, C fitted here through
//! three points of the datasheet's R–T table (0 °C: 27.219 kΩ, 25 °C:
//! 10.000 kΩ, 85 °C: 1.452 kΩ). Against the rest of the table it is within
//! 0.12 °C from −10 to 110 °C (0.2 °C at −20 °C, 0.7 °C at −40 °C). A code outside the
//! range of −40 … 125 °C is an open (V → V_REF, beyond full scale) or
//! shorted (V → 0) thermistor: no temperature.

/// The divider's reference, V (TI REF3312: 1.25 V).
pub const DIVIDER_REF_V: f32 = 1.25;
/// The divider's fixed (top) resistor, Ω.
pub const DIVIDER_TOP_OHM: f32 = 10_000.0;
/// Volts per ADC code at gain 1 (±1.2 V over ±2²³; `adc::REFERENCE_V`).
const VOLTS_PER_CODE: f32 = crate::adc::REFERENCE_V / crate::adc::FULL_SCALE_COUNTS as f32;
/// Steinhart–Hart coefficients of the NCP18XH103 through the datasheet's
/// 0, 25 and 85 °C points (1/K, 1/K, 1/K).
const SH_A: f32 = 8.893_719e-4;
const SH_B: f32 = 2.509_26e-4;
const SH_C: f32 = 1.965_023e-7;
/// Codes from here up are an open thermistor (the divider's 1.25 V clips
/// at the ADC's 1.2 V full scale; −40 °C is 8 313 000).
const OPEN_CODE: f32 = 8_380_000.0;
/// The part's rated range, °C (a reading outside it is a broken divider).
pub const RANGE_C: (f32, f32) = (-40.0, 125.0);

/// The temperature for a CH3 code, °C; `None` for an open or shorted
/// thermistor (or a code outside the rated range).
pub fn temp_c_of_code(code: f32) -> Option<f32> {
    // At or near the clip: V_REF is above the ADC's full scale (open NTC).
    if !(code < OPEN_CODE) {
        return None;
    }
    let v = code * VOLTS_PER_CODE;
    if !(v > 0.0 && v < DIVIDER_REF_V) {
        return None;
    }
    let r_ohm = DIVIDER_TOP_OHM * v / (DIVIDER_REF_V - v);
    let l = libm::logf(r_ohm);
    let t_c = 1.0 / (SH_A + SH_B * l + SH_C * l * l * l) - 273.15;
    // A little margin: the part's tolerance moves the ends by ~0.5 °C.
    (t_c >= RANGE_C.0 - 2.0 && t_c <= RANGE_C.1 + 2.0).then_some(t_c)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    /// Murata NCP18XH103 R–T table (catalog R44E, "Temperature
    /// Characteristics (Center Value)", XH column), °C → kΩ. The 50, 85 and
    /// 100 °C rows agree with the datasheet's B25/50, B25/85 and B25/100
    /// constants (4.160, 1.452, 0.974 kΩ) to 1 Ω.
    const TABLE_C_KOHM: [(f64, f64); 11] =
        [(-20.0, 68.237), (-10.0, 42.506), (0.0, 27.219), (10.0, 17.926), (20.0, 12.081), (25.0, 10.0), (40.0, 5.834), (50.0, 4.161), (70.0, 2.228), (85.0, 1.452), (100.0, 0.974)];

    /// The code the divider gives for a resistance: physics written here,
    /// in f64, from the schematic (1.25 V, 10 kΩ, ±1.2 V over ±2²³).
    fn code_of_ohm(r: f64) -> f32 {
        let v = 1.25 * r / (r + 10_000.0);
        (v / 1.2 * 8_388_608.0).round() as f32
    }

    #[test]
    fn codes_convert_to_the_datasheet_temperatures() {
        // Measured: worst 0.093 °C from −10 to 100 °C (at −10), 0.20 °C at
        // −20 °C (the three-point fit bends away from the table there).
        for (t_c, r_kohm) in TABLE_C_KOHM {
            let got = temp_c_of_code(code_of_ohm(r_kohm * 1000.0)).unwrap();
            let tol = if t_c < -10.0 { 0.6 } else { 0.3 };
            assert!((f64::from(got) - t_c).abs() < tol, "{t_c} °C: got {got}");
        }
    }

    #[test]
    fn the_b_constants_agree_with_the_conversion() {
        // R(T) = R25 · exp(B25/T · (1/T − 1/298.15 K)) is exact at T by the
        // definition of B25/T.
        for (t_c, b_k) in [(50.0f64, 3380.0f64), (85.0, 3434.0), (100.0, 3455.0)] {
            let r = 10_000.0 * (b_k * (1.0 / (t_c + 273.15) - 1.0 / 298.15)).exp();
            let got = temp_c_of_code(code_of_ohm(r)).unwrap();
            assert!((f64::from(got) - t_c).abs() < 0.1, "{t_c} °C: got {got}");
        }
    }

    #[test]
    fn open_or_shorted_thermistor_is_no_temperature() {
        // Open: V → 1.25 V, beyond the ADC's 1.2 V: the code clips.
        assert_eq!(temp_c_of_code(8_388_607.0), None);
        // Shorted: V → 0.
        assert_eq!(temp_c_of_code(0.0), None);
        assert_eq!(temp_c_of_code(-5.0), None);
        // 1 Ω (a solder bridge) reads far beyond 125 °C.
        assert_eq!(temp_c_of_code(code_of_ohm(1.0)), None);
        assert_eq!(temp_c_of_code(f32::NAN), None);
    }
}
