//! The calibration document ↔ the coefficients the board stores and applies
//! (f32 on the wire; the board validates them again before storing).

use calib_core::cal::{FieldCal, ModelKind};
use magcal_protocol::Coefficients;

use crate::doc::results::Quality;
use calib_core::cal::Swing;

use crate::doc::caldoc::{CurrentBlock, TemperatureBlock};
use crate::doc::reference::{Reference, ReferenceSource};
use crate::doc::CalDoc;

/// The board's coefficients for a calibration document, with its current and
/// temperature blocks (absent blocks: no terms, [`CalDoc::env_terms`]) and
/// its reference inclination
/// ([`crate::compute::apply::document_inclination_deg`];
/// [`Coefficients::NO_INCLINATION`] without one: the board then learns it
/// and calls no sample ok).
pub fn to_coefficients(doc: &CalDoc) -> Coefficients {
    let s = doc.swing.map(|s| [s.a, s.b, s.c, s.d, s.e]).unwrap_or([0.0; 5]);
    let env = doc.env_terms();
    Coefficients {
        bias: doc.bias.map(|v| v as f32),
        matrix: doc.matrix.map(|r| r.map(|v| v as f32)),
        swing: s.map(|v| v as f32),
        declination_rad: doc.declination_deg.unwrap_or(0.0).to_radians() as f32,
        field_nt: doc.field_nt as f32,
        current_bias_per_a: env.bias_per_a.map(|v| v as f32),
        temp_ref_c: env.ref_c as f32,
        temp_gain_per_c: env.gain_per_c.map(|v| v as f32),
        inclination_rad: crate::compute::apply::document_inclination_deg(doc, doc.field_nt).map_or(Coefficients::NO_INCLINATION, |d| d.to_radians() as f32),
    }
}

/// A calibration document for coefficients read from the board (model
/// `full`, no quality report: the board keeps none).
pub fn doc_from_coefficients(c: &Coefficients) -> CalDoc {
    let field = FieldCal { bias: c.bias.map(f64::from), matrix: c.matrix.map(|r| r.map(f64::from)) };
    let mut doc = CalDoc::new(ModelKind::Full, &field, f64::from(c.field_nt), Quality::default());
    doc.declination_deg = Some(f64::from(c.declination_rad).to_degrees());
    let [a, b, c_, d, e] = c.swing.map(f64::from);
    if [a, b, c_, d, e].iter().any(|v| *v != 0.0) {
        doc.swing = Some(Swing { a, b, c: c_, d, e });
    }
    // Zero terms are an absent block (what the board does with them).
    if c.current_bias_per_a.iter().any(|v| *v != 0.0) {
        doc.current = Some(CurrentBlock { bias_per_a: c.current_bias_per_a.map(f64::from) });
    }
    if c.temp_gain_per_c.iter().any(|v| *v != 0.0) {
        doc.temperature = Some(TemperatureBlock { ref_c: f64::from(c.temp_ref_c), gain_per_c: c.temp_gain_per_c.map(f64::from) });
    }
    if let Some(i) = c.inclination() {
        let f = f64::from(c.field_nt);
        doc.reference = Some(Reference {
            source: ReferenceSource::Board,
            site: None,
            field_nt: f,
            field_sigma_nt: crate::doc::reference::LOCAL_INTENSITY_SIGMA_REL * f,
            inclination_deg: Some(f64::from(i).to_degrees()),
            inclination_sigma_deg: None,
            check: None,
            constraint: None,
        });
    }
    doc
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficients_survive_the_round_trip_to_f32_precision() {
        let field = FieldCal { bias: [1500.5, -2300.25, 800.0], matrix: [[0.028, 1e-4, 0.0], [1e-4, 0.0279, -2e-5], [0.0, -2e-5, 0.0281]] };
        let mut doc = CalDoc::new(ModelKind::Full, &field, 48_730.0, Quality::default());
        doc.declination_deg = Some(5.25);
        doc.swing = Some(Swing { a: 0.01, b: -0.002, c: 0.003, d: 0.0, e: 0.0005 });
        let back = doc_from_coefficients(&to_coefficients(&doc));
        for k in 0..3 {
            assert!((back.bias[k] - doc.bias[k]).abs() <= doc.bias[k].abs() * 1e-7);
            for j in 0..3 {
                assert!((back.matrix[k][j] - doc.matrix[k][j]).abs() <= 1e-9);
            }
        }
        assert!((back.declination_deg.unwrap() - 5.25).abs() < 1e-5);
        let (s, t) = (back.swing.unwrap(), doc.swing.unwrap());
        assert!((s.a - t.a).abs() < 1e-8 && (s.e - t.e).abs() < 1e-8);
        // No blocks: zero terms on the board, no blocks back.
        assert_eq!((back.current, back.temperature), (None, None));
    }

    #[test]
    fn current_and_temperature_blocks_reach_the_board_and_come_back() {
        let field = FieldCal { bias: [1500.5, -2300.25, 800.0], matrix: [[0.028, 0.0, 0.0], [0.0, 0.0279, 0.0], [0.0, 0.0, 0.0281]] };
        let mut doc = CalDoc::new(ModelKind::Full, &field, 48_730.0, Quality::default());
        doc.current = Some(CurrentBlock { bias_per_a: [12.5, -3.25, 40.0] });
        doc.temperature = Some(TemperatureBlock { ref_c: 18.5, gain_per_c: [-0.003, -0.0028, -0.0031] });
        let c = to_coefficients(&doc);
        assert_eq!(c.current_bias_per_a, [12.5, -3.25, 40.0]);
        assert_eq!(c.temp_ref_c, 18.5);
        assert_eq!(c.temp_gain_per_c, [-0.003f32, -0.0028, -0.0031]);
        let back = doc_from_coefficients(&c);
        assert_eq!(back.current, doc.current);
        let (t, u) = (back.temperature.unwrap(), doc.temperature.unwrap());
        assert_eq!(t.ref_c, u.ref_c);
        for k in 0..3 {
            // f32 on the wire: 7 significant digits.
            assert!((t.gain_per_c[k] - u.gain_per_c[k]).abs() < 1e-10);
        }
        // The board applies what the document says: the same sample through
        // the document's f64 formula and the board's f32 coefficients.
        let raw = [60_000.0, -20_000.0, 90_000.0];
        let env = calib_core::cal::Environment { current_a: 25.0, temp_c: 31.0 };
        let tilt = calib_core::heading::Tilt::new(0.1, -0.05);
        let host = doc.calibration().apply_tilt_env(raw, &tilt, &env);
        let board_cal = calib_core::cal::Calibration::<f32> {
            field: FieldCal { bias: c.bias, matrix: c.matrix },
            swing: Swing::from_array(c.swing),
            declination_rad: c.declination_rad,
            env: c.env_terms(),
        };
        let board = board_cal.apply_tilt_env(raw.map(|v| v as f32), &calib_core::heading::Tilt::new(0.1f32, -0.05), &calib_core::cal::Environment { current_a: 25.0f32, temp_c: 31.0 });
        for k in 0..3 {
            // Measured: 0.0006 nT (f32 rounding).
            assert!((f64::from(board.field_nt[k]) - host.field_nt[k]).abs() < 0.01, "{k}");
        }
    }
}
