//! The analog front end as the datasheets give it: the HMC100x bridges
//! and the board's amplifier (field to ADC codes), and the thermistor
//! divider on channel 3 (temperature to a code).

/// HMC1001/1002 sensitivity, V per V of bridge supply per gauss (datasheet typ).
const HMC_SENSITIVITY_V_PER_V_PER_GAUSS: f64 = 3.2e-3;
/// Bridge supply on the board, V.
const HMC_BRIDGE_SUPPLY_V: f64 = 5.0;
/// Instrumentation amplifier gain on the board.
const BOARD_AMP_GAIN: f64 = 32.0;
/// ADS131M04 full scale at gain 1, V (SBAS890 §8.5.1.3).
const ADS_FULL_SCALE_V: f64 = 1.2;
/// Codes per volt at gain 1: 2²³ / 1.2 V.
const ADS_CODES_PER_V: f64 = 8_388_608.0 / ADS_FULL_SCALE_V;
/// Largest and smallest 24-bit codes.
pub(super) const ADS_CODE_MAX: i32 = 0x7F_FFFF;
pub(super) const ADS_CODE_MIN: i32 = -0x80_0000;
/// The thermistor divider: reference (V) and top resistor (Ω).
const NTC_DIVIDER_REF_V: f32 = 1.25;
const NTC_DIVIDER_TOP_OHM: f32 = 10_000.0;
/// NCP18XH103 R–T table (Murata catalog R44E, XH column): °C, kΩ.
const NTC_TABLE: [(f32, f32); 19] = [
    (-40.0, 195.652),
    (-30.0, 113.347),
    (-20.0, 68.237),
    (-10.0, 42.506),
    (0.0, 27.219),
    (10.0, 17.926),
    (20.0, 12.081),
    (25.0, 10.0),
    (30.0, 8.315),
    (40.0, 5.834),
    (50.0, 4.161),
    (60.0, 3.014),
    (70.0, 2.228),
    (80.0, 1.669),
    (85.0, 1.452),
    (90.0, 1.268),
    (100.0, 0.974),
    (110.0, 0.7576),
    (125.0, 0.531),
];

/// The NTC's resistance at `temp_c`, Ω (clamped to the table's ends).
pub fn model_ntc_ohm(temp_c: f32) -> f32 {
    let inv_t = |c: f32| 1.0 / (c + 273.15);
    let t = temp_c.clamp(-40.0, 125.0);
    let mut lo = NTC_TABLE[0];
    let mut hi = NTC_TABLE[1];
    for w in NTC_TABLE.windows(2) {
        if let [a, b] = w {
            lo = *a;
            hi = *b;
            if t <= b.0 {
                break;
            }
        }
    }
    let x = (inv_t(t) - inv_t(lo.0)) / (inv_t(hi.0) - inv_t(lo.0));
    let ln_r = libm::logf(lo.1 * 1000.0) + x * (libm::logf(hi.1 * 1000.0) - libm::logf(lo.1 * 1000.0));
    libm::expf(ln_r)
}

/// Channel 3's code for the sensor at `temp_c` (NaN: open thermistor).
pub(super) fn ntc_code(temp_c: f32) -> i32 {
    let v = if temp_c.is_nan() {
        NTC_DIVIDER_REF_V
    } else {
        let r = model_ntc_ohm(temp_c);
        NTC_DIVIDER_REF_V * r / (r + NTC_DIVIDER_TOP_OHM)
    };
    let code = libm::roundf(v * (ADS_CODES_PER_V as f32));
    code.clamp(ADS_CODE_MIN as f32, ADS_CODE_MAX as f32) as i32
}

/// Field to ADC code through the modelled chain, codes per nT.
pub const fn model_codes_per_nt() -> f64 {
    HMC_SENSITIVITY_V_PER_V_PER_GAUSS * HMC_BRIDGE_SUPPLY_V * BOARD_AMP_GAIN * ADS_CODES_PER_V / 1e5
}

/// [`model_codes_per_nt`] rounded to `f32` at compile time: the model
/// converts in `f32` (the Cortex-M4F's FPU; `f64` would link ~2.6 KiB of
/// software arithmetic into the board image). A code is 0.028 nT; `f32`'s
/// roundings (the constant, the product, the sum with the offset) stay
/// under one code (0.03 nT) at 100 000 nT.
pub(super) const CODES_PER_NT_F32: f32 = model_codes_per_nt() as f32;
