//! Reports: plain SVG figures and an HTML page tying them together, with the
//! papers' figures — field magnitude across the turnaround for each set of
//! coefficients (paper 000 Figs 7–12), heading error against the reference
//! before and after swinging (Fig 13), and the swing test's attitude coverage
//! (Fig 6). No plotting dependency: the SVG is written directly.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use calib_core::heading::wrap_pi;

use crate::data::caldoc::CalDoc;
use crate::data::recording::Recording;

/// One line of a plot.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points; non-finite points break the line.
    pub points: Vec<(f64, f64)>,
    /// Draw dots instead of a line.
    pub dots: bool,
}

const COLORS: [&str; 6] = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b"];

fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// A line plot as an SVG document.
pub fn line_plot(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> String {
    let (w, h, ml, mr, mt, mb) = (900.0, 420.0, 80.0, 20.0, 40.0, 50.0);
    let finite = series.iter().flat_map(|s| s.points.iter()).filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in finite {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 - x0 < 1e-12 {
        x1 = x0 + 1.0;
    }
    let pad = ((y1 - y0) * 0.05).max(1e-9);
    (y0, y1) = (y0 - pad, y1 + pad);
    let sx = |x: f64| ml + (x - x0) / (x1 - x0) * (w - ml - mr);
    let sy = |y: f64| mt + (y1 - y) / (y1 - y0) * (h - mt - mb);
    let mut svg = String::new();
    let _ = writeln!(svg, r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" font-family="sans-serif" font-size="12">"#);
    let _ = writeln!(svg, r#"<rect width="100%" height="100%" fill="white"/><text x="{}" y="22" font-size="15" text-anchor="middle">{}</text>"#, w / 2.0, escape(title));
    let _ = writeln!(svg, r##"<rect x="{ml}" y="{mt}" width="{}" height="{}" fill="none" stroke="#444"/>"##, w - ml - mr, h - mt - mb);
    for k in 0..=5 {
        let (fx, fy) = (x0 + (x1 - x0) * k as f64 / 5.0, y0 + (y1 - y0) * k as f64 / 5.0);
        let _ = writeln!(svg, r##"<line x1="{0}" y1="{mt}" x2="{0}" y2="{1}" stroke="#ddd"/><text x="{0}" y="{2}" text-anchor="middle">{3}</text>"##, sx(fx), h - mb, h - mb + 16.0, fmt_tick(fx));
        let _ = writeln!(svg, r##"<line x1="{ml}" y1="{0}" x2="{1}" y2="{0}" stroke="#ddd"/><text x="{2}" y="{3}" text-anchor="end">{4}</text>"##, sy(fy), w - mr, ml - 6.0, sy(fy) + 4.0, fmt_tick(fy));
    }
    let _ = writeln!(svg, r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#, (ml + w - mr) / 2.0, h - 10.0, escape(x_label));
    let _ = writeln!(svg, r#"<text transform="translate(16,{}) rotate(-90)" text-anchor="middle">{}</text>"#, (mt + h - mb) / 2.0, escape(y_label));
    for (i, s) in series.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        if s.dots {
            for &(x, y) in s.points.iter().filter(|p| p.0.is_finite() && p.1.is_finite()) {
                let _ = write!(svg, r#"<circle cx="{:.1}" cy="{:.1}" r="1.5" fill="{color}"/>"#, sx(x), sy(y));
            }
        } else {
            let mut d = String::new();
            let mut pen_up = true;
            for &(x, y) in &s.points {
                if !(x.is_finite() && y.is_finite()) {
                    pen_up = true;
                    continue;
                }
                let _ = write!(d, "{}{:.1},{:.1} ", if pen_up { "M" } else { "L" }, sx(x), sy(y));
                pen_up = false;
            }
            let _ = writeln!(svg, r#"<path d="{d}" fill="none" stroke="{color}" stroke-width="1.2"/>"#);
        }
        let ly = mt + 16.0 + 16.0 * i as f64;
        let _ = writeln!(svg, r#"<rect x="{}" y="{}" width="12" height="3" fill="{color}"/><text x="{}" y="{}">{}</text>"#, ml + 10.0, ly - 4.0, ml + 28.0, ly, escape(&s.name));
    }
    svg.push_str("</svg>\n");
    svg
}

fn fmt_tick(v: f64) -> String {
    if v.abs() >= 1000.0 || v == 0.0 {
        format!("{v:.0}")
    } else if v.abs() >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.3}")
    }
}

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Writing failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A recording lacks what a figure needs.
    #[error("{0}")]
    Data(String),
}

/// What to put in a report.
pub struct ReportInputs<'a> {
    /// The out-and-back run (for the field and heading figures).
    pub run: Option<&'a Recording>,
    /// The swing test (for the attitude figure).
    pub swing: Option<&'a Recording>,
    /// Calibrations to compare, with their labels.
    pub cals: Vec<(String, &'a CalDoc)>,
    /// Reference intensity for the field figure, nT.
    pub field_nt: Option<f64>,
}

fn write(path: &Path, text: &str) -> Result<(), ReportError> {
    std::fs::write(path, text).map_err(|source| ReportError::Io { path: path.into(), source })
}

/// Writes `fig_field.svg`, `fig_heading.svg`, `fig_attitude.svg` (those the
/// inputs allow) and `index.html` into `dir`; returns the figure files.
pub fn write_report(dir: &Path, inputs: &ReportInputs<'_>) -> Result<Vec<PathBuf>, ReportError> {
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io { path: dir.into(), source })?;
    let mut figures = Vec::new();
    if let Some(run) = inputs.run {
        let t = run.t_s.as_ref().ok_or_else(|| ReportError::Data("the run has no `t` column".into()))?;
        let stride = (run.len() / 4000).max(1);
        let mut field = Vec::new();
        for (label, doc) in &inputs.cals {
            let cal = doc.field_cal();
            let points = (0..run.len()).step_by(stride).map(|i| {
                let h = cal.apply(run.mag[i]);
                (t[i], (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt())
            });
            field.push(Series { name: label.clone(), points: points.collect(), dots: false });
        }
        if let Some(f) = inputs.field_nt {
            field.push(Series { name: format!("IGRF {f:.0} nT"), points: vec![(t[0], f), (t[t.len() - 1], f)], dots: false });
        }
        let p = dir.join("fig_field.svg");
        write(&p, &line_plot("Field magnitude along the run (paper 000 Figs 7–12)", "time, s", "|H|, nT", &field))?;
        figures.push(p);
        if let (Some(reference), Some(roll), Some(pitch)) = (run.ref_heading_deg.as_ref(), run.roll_deg.as_ref(), run.pitch_deg.as_ref()) {
            let mut heading = Vec::new();
            for (label, doc) in &inputs.cals {
                let cal = doc.calibration();
                let points = (0..run.len()).filter(|&i| reference[i].is_finite()).map(|i| {
                    let out = cal.apply(run.mag[i], roll[i].to_radians(), pitch[i].to_radians());
                    (t[i], wrap_pi(out.true_heading_rad - reference[i].to_radians()).to_degrees())
                });
                heading.push(Series { name: label.clone(), points: points.collect(), dots: true });
            }
            let p = dir.join("fig_heading.svg");
            write(&p, &line_plot("Heading − reference (GPS course) at the surface (paper 000 Fig 13)", "time, s", "error, °", &heading))?;
            figures.push(p);
        }
    }
    if let Some(swing) = inputs.swing {
        let (Some(t), Some(roll), Some(pitch)) = (swing.t_s.as_ref(), swing.roll_deg.as_ref(), swing.pitch_deg.as_ref()) else {
            return Err(ReportError::Data("the swing test needs t, roll_deg and pitch_deg".into()));
        };
        let stride = (swing.len() / 4000).max(1);
        let mut series = vec![
            Series { name: "roll".into(), points: (0..swing.len()).step_by(stride).map(|i| (t[i], roll[i])).collect(), dots: false },
            Series { name: "pitch".into(), points: (0..swing.len()).step_by(stride).map(|i| (t[i], pitch[i])).collect(), dots: false },
        ];
        if let Some((label, doc)) = inputs.cals.first() {
            let cal = doc.field_cal();
            let points = (0..swing.len()).step_by(stride).map(|i| {
                let psi = calib_core::heading::magnetic_heading_rad(cal.apply(swing.mag[i]), roll[i].to_radians(), pitch[i].to_radians());
                (t[i], wrap_pi(psi).to_degrees())
            });
            series.push(Series { name: format!("heading ({label})"), points: points.collect(), dots: true });
        }
        let p = dir.join("fig_attitude.svg");
        write(&p, &line_plot("Swing test attitude coverage (paper 000 Fig 6)", "time, s", "degrees", &series))?;
        figures.push(p);
    }
    let mut html = String::from("<!doctype html><meta charset=\"utf-8\"><title>magcal report</title><h1>magcal report</h1>\n<table border=1 cellpadding=4><tr><th>calibration</th><th>model</th><th>bias</th><th>field_nt</th><th>swing</th></tr>\n");
    for (label, doc) in &inputs.cals {
        let swing = doc.swing.map(|s| format!("A={:.4} B={:.4} C={:.4} D={:.4} E={:.4}", s.a, s.b, s.c, s.d, s.e)).unwrap_or_else(|| "—".into());
        let _ = writeln!(html, "<tr><td>{}</td><td>{}</td><td>{:.1}, {:.1}, {:.1}</td><td>{:.1}</td><td>{}</td></tr>", escape(label), doc.model.name(), doc.bias[0], doc.bias[1], doc.bias[2], doc.field_nt, swing);
    }
    html.push_str("</table>\n");
    for f in &figures {
        if let Some(name) = f.file_name().and_then(|n| n.to_str()) {
            let _ = writeln!(html, "<p><img src=\"{name}\" alt=\"{name}\"></p>");
        }
    }
    let index = dir.join("index.html");
    write(&index, &html)?;
    Ok(figures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_scale_points_into_the_frame_and_break_on_gaps() {
        let svg = line_plot("t", "x", "y", &[Series { name: "a<b".into(), points: vec![(0.0, 0.0), (1.0, 10.0), (f64::NAN, 0.0), (2.0, 5.0)], dots: false }]);
        assert!(svg.starts_with("<svg"));
        assert!(svg.contains("a&lt;b"));
        // First point at the left edge (x = 80), bottom of the padded range.
        assert!(svg.contains("M80.0,"), "{svg}");
        // The NaN lifts the pen: two M commands.
        let path = svg.lines().find(|l| l.starts_with("<path")).unwrap();
        assert_eq!(path.matches('M').count(), 2);
        assert!(svg.trim_end().ends_with("</svg>"));
    }
}
