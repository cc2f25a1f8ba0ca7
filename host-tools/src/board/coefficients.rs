//! The calibration document ↔ the coefficients the board stores and applies
//! (f32 on the wire; the board validates them again before storing).

use calib_core::cal::{FieldCal, ModelKind};
use magcal_protocol::Coefficients;

use crate::data::results::Quality;
use calib_core::cal::Swing;

use crate::data::CalDoc;

/// The board's coefficients for a calibration document.
pub fn to_coefficients(doc: &CalDoc) -> Coefficients {
    let s = doc.swing.map(|s| [s.a, s.b, s.c, s.d, s.e]).unwrap_or([0.0; 5]);
    Coefficients {
        bias: doc.bias.map(|v| v as f32),
        matrix: doc.matrix.map(|r| r.map(|v| v as f32)),
        swing: s.map(|v| v as f32),
        declination_rad: doc.declination_deg.unwrap_or(0.0).to_radians() as f32,
        field_nt: doc.field_nt as f32,
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
    }
}
