//! The report's figures, drawn with `plotters`' SVG backend (no fonts: text
//! is emitted as SVG `<text>` and laid out with plotters' built-in estimate,
//! so the browser's own sans-serif draws it). Axis ticks are plotters' round
//! key points; every axis label carries its unit.

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One line (or scatter) of a plot.
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points; non-finite points break the line.
    pub points: Vec<(f64, f64)>,
    /// Draw dots instead of a line.
    pub dots: bool,
}

/// Why a figure could not be drawn (plotters' message).
#[derive(Debug, thiserror::Error)]
#[error("drawing {figure}: {message}")]
pub struct PlotError {
    /// The figure's title.
    pub figure: String,
    /// What plotters said.
    pub message: String,
}

/// Figure width and height, px (the SVG scales to the page width).
pub const SIZE_PX: (u32, u32) = (900, 380);

const COLORS: [RGBColor; 8] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0x17, 0xbe, 0xcf),
    RGBColor(0x7f, 0x7f, 0x7f),
];

/// The colour of the `i`-th series.
pub fn color(i: usize) -> RGBColor {
    COLORS[i % COLORS.len()]
}

/// The legend box every chart uses: upper right, on a light background.
fn legend<'a, 'b: 'a>(chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>>, title: &str) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(0x88, 0x88, 0x88))
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| err(title, e))
}

fn err(figure: &str, e: impl std::fmt::Display) -> PlotError {
    PlotError { figure: figure.into(), message: e.to_string() }
}

/// The range of the finite values, padded by 5 % (and widened when flat).
fn padded_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    let pad = if span > 1e-12 { span * 0.05 } else { lo.abs().max(1.0) * 0.05 };
    (lo - pad, hi + pad)
}

/// Round ticks over `lo…hi`: a step of 1, 2 or 5 × 10ⁿ giving at most
/// `max_count` ticks; returns the ticks, the minor ticks (a fifth of the
/// step) and the decimals the labels need.
pub fn nice_ticks(lo: f64, hi: f64, max_count: usize) -> (Vec<f64>, Vec<f64>, usize) {
    let span = (hi - lo).abs().max(1e-12);
    let raw = span / max_count.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw * (1.0 - 1e-9)).unwrap_or(10.0 * mag);
    let ticks = |step: f64| -> Vec<f64> {
        let first = (lo / step).ceil() as i64;
        let last = (hi / step).floor() as i64;
        (first..=last).map(|k| k as f64 * step).map(|v| if v.abs() < step * 1e-9 { 0.0 } else { v }).collect()
    };
    let decimals = if step >= 1.0 { 0 } else { (-step.log10().floor()) as usize };
    (ticks(step), ticks(step / 5.0), decimals)
}

/// Ticks at whole numbers over `0..=last` (iteration numbers): every one
/// when they are few, else every 2, 5, 10, 20, 50, … — the smallest such
/// step that gives at most `max_count` ticks.
pub fn integer_ticks(last: u32, max_count: usize) -> Vec<f64> {
    let max_count = max_count.max(2) as u64;
    let mut step: u64 = 1;
    for m in [2, 5, 10].iter().cycle().scan(1u64, |decade, &k| {
        let s = *decade * k;
        if k == 10 {
            *decade *= 10;
        }
        Some(s)
    }) {
        if u64::from(last) / step < max_count {
            break;
        }
        step = m;
    }
    (0..=u64::from(last)).step_by(step as usize).map(|v| v as f64).collect()
}

fn tick_label(v: f64, decimals: usize) -> String {
    let s = format!("{v:.decimals$}");
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') { s[1..].to_string() } else { s }
}

/// A value axis with our own round ticks and labels.
struct Axis {
    inner: RangedCoordf64,
    bold: Vec<f64>,
    light: Vec<f64>,
    decimals: usize,
}

impl Ranged for Axis {
    type ValueType = f64;
    type FormatOption = NoDefaultFormatting;
    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }
    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.light.clone()
        } else {
            self.bold.clone()
        }
    }
}

impl ValueFormatter<f64> for Axis {
    fn format(value: &f64) -> String {
        format!("{value}")
    }
    fn format_ext(&self, value: &f64) -> String {
        tick_label(*value, self.decimals)
    }
}

/// A value axis over `lo…hi` with round ticks (or the given ticks).
fn axis(lo: f64, hi: f64, max_count: usize, fixed: Option<&[f64]>) -> Axis {
    let (mut bold, mut light, mut decimals) = nice_ticks(lo, hi, max_count);
    if let Some(f) = fixed {
        bold = f.to_vec();
        light = Vec::new();
        decimals = f.iter().map(|v| if v.fract() == 0.0 { 0 } else { 2 }).max().unwrap_or(0);
    }
    Axis { inner: (lo..hi).into(), bold, light, decimals }
}

/// Runs `draw` on a white SVG canvas and returns the SVG text.
fn svg(figure: &str, draw: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> Result<(), PlotError>) -> Result<String, PlotError> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, SIZE_PX).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(figure, e))?;
        draw(&root)?;
        root.present().map_err(|e| err(figure, e))?;
    }
    Ok(text)
}

/// The frame every figure shares: caption, margins, the two value axes with
/// their round ticks and unit labels, and (unless `mesh` is false) light
/// grid lines at the ticks.
fn framed<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, Shift>,
    title: &str,
    (ax, ay): (Axis, Axis),
    (x_label, y_label): (&str, &str),
    mesh: bool,
) -> Result<ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>>, PlotError> {
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(70)
        .build_cartesian_2d(ax, ay)
        .map_err(|e| err(title, e))?;
    let mut m = chart.configure_mesh();
    m.x_desc(x_label).y_desc(y_label).x_labels(100).y_labels(100).axis_desc_style(("sans-serif", 15)).label_style(("sans-serif", 13));
    if mesh {
        m.light_line_style(RGBColor(0xee, 0xee, 0xee)).bold_line_style(RGBColor(0xcc, 0xcc, 0xcc));
    } else {
        m.disable_mesh();
    }
    m.draw().map_err(|e| err(title, e))?;
    Ok(chart)
}

/// A line/scatter plot with a legend. `x_range`/`y_range` fix the axes
/// (else the data's range, padded).
pub fn try_line_plot(title: &str, x_label: &str, y_label: &str, series: &[Series], x_range: Option<(f64, f64)>, y_range: Option<(f64, f64)>) -> Result<String, PlotError> {
    try_line_plot_ticks(title, x_label, y_label, series, x_range, y_range, None)
}

/// [`try_line_plot`] with the x ticks given (e.g. every 45° of heading).
pub fn try_line_plot_ticks(title: &str, x_label: &str, y_label: &str, series: &[Series], x_range: Option<(f64, f64)>, y_range: Option<(f64, f64)>, x_ticks: Option<&[f64]>) -> Result<String, PlotError> {
    let all = || series.iter().flat_map(|s| s.points.iter()).filter(|p| p.0.is_finite() && p.1.is_finite());
    let (x0, x1) = x_range.unwrap_or_else(|| padded_range(all().map(|p| p.0)));
    // Headroom above the data for the legend box (a line a series), so the
    // legend hides no data.
    let (y0, y1) = y_range.unwrap_or_else(|| {
        let (lo, hi) = padded_range(all().map(|p| p.1));
        (lo, hi + (hi - lo) * 0.075 * series.len() as f64)
    });
    let (ax, ay) = (axis(x0, x1, 10, x_ticks), axis(y0, y1, 8, None));
    svg(title, |root| {
        let mut chart = framed(root, title, (ax, ay), (x_label, y_label), true)?;
        draw_series(&mut chart, title, series, &|i| color(i), (x0, x1, y0, y1))?;
        Ok(())
    })
}

/// Draws each series (dots or lines, `colour(i)` for the `i`-th) inside
/// `x0…x1 × y0…y1`, with the shared legend.
fn draw_series<'a, 'b: 'a>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<Axis, Axis>>,
    title: &str,
    series: &[Series],
    colour: &dyn Fn(usize) -> RGBColor,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
) -> Result<(), PlotError> {
    for (i, s) in series.iter().enumerate() {
        let c = colour(i);
        let inside = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite() && p.1 >= y0 && p.1 <= y1 && p.0 >= x0 && p.0 <= x1;
        let anno = if s.dots {
            // A few points (a trace) get markers one can see; a cloud, small dots.
            let r = if s.points.len() < 50 { 5 } else { 2 };
            chart.draw_series(s.points.iter().filter(inside).map(move |&p| Circle::new(p, r, c.mix(0.8).filled()))).map_err(|e| err(title, e))?
        } else {
            // A non-finite point lifts the pen: one path per stretch.
            let mut stretches: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
            for p in &s.points {
                if p.0.is_finite() && p.1.is_finite() {
                    if let Some(v) = stretches.last_mut() {
                        v.push(*p);
                    }
                } else if stretches.last().is_some_and(|v| !v.is_empty()) {
                    stretches.push(Vec::new());
                }
            }
            chart.draw_series(stretches.into_iter().filter(|v| !v.is_empty()).map(|v| PathElement::new(v, c.stroke_width(2)))).map_err(|e| err(title, e))?
        };
        if s.dots {
            anno.label(s.name.as_str()).legend(move |(x, y)| Circle::new((x + 9, y), 4, c.filled()));
        } else {
            anno.label(s.name.as_str()).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(3)));
        }
    }
    if !series.is_empty() {
        legend(chart, title)?;
    }
    Ok(())
}

/// A scatter over a shaded band `±σ(x)` about zero (an error against its
/// predicted 1σ): `band` is `(x, σ)` in x order, `band_name` its legend
/// text; `series` are drawn over it in `colours` (one each, by index).
/// The y axis spans the data and the band, padded, within ±`y_cap`.
#[allow(clippy::too_many_arguments)]
pub fn try_band_plot(title: &str, x_label: &str, y_label: &str, band_name: &str, band: &[(f64, f64)], series: &[Series], colours: &[RGBColor], y_cap: f64) -> Result<String, PlotError> {
    let band: Vec<(f64, f64)> = band.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
    let points = || series.iter().flat_map(|s| s.points.iter()).filter(|p| p.0.is_finite() && p.1.is_finite());
    let (x0, x1) = padded_range(points().map(|p| p.0).chain(band.iter().map(|p| p.0)));
    let (lo, hi) = padded_range(points().map(|p| p.1).chain(band.iter().flat_map(|p| [p.1, -p.1])));
    let (lo, hi) = (lo.max(-y_cap), hi.min(y_cap));
    // Headroom for the legend (a line a series and the band's).
    let (y0, y1) = (lo, hi + (hi - lo) * 0.075 * (series.len() + 1) as f64);
    let (ax, ay) = (axis(x0, x1, 10, None), axis(y0, y1, 8, None));
    svg(title, |root| {
        let mut chart = framed(root, title, (ax, ay), (x_label, y_label), true)?;
        if !band.is_empty() {
            let shade = RGBColor(0x1f, 0x77, 0xb4);
            let upper = band.iter().map(|p| (p.0, p.1.clamp(y0, y1)));
            let lower = band.iter().rev().map(|p| (p.0, (-p.1).clamp(y0, y1)));
            chart
                .draw_series(std::iter::once(Polygon::new(upper.chain(lower).collect::<Vec<_>>(), shade.mix(0.18).filled())))
                .map_err(|e| err(title, e))?
                .label(band_name)
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], shade.mix(0.3).filled()));
        }
        let colour = |i: usize| colours.get(i).copied().unwrap_or_else(|| color(i));
        draw_series(&mut chart, title, series, &colour, (x0, x1, y0, y1))?;
        if series.is_empty() && !band.is_empty() {
            legend(&mut chart, title)?;
        }
        Ok(())
    })
}

/// [`try_line_plot`] with the data's ranges; a figure that cannot be drawn
/// becomes an SVG saying why.
pub fn line_plot(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> String {
    try_line_plot(title, x_label, y_label, series, None, None).unwrap_or_else(|e| error_svg(&e.to_string()))
}

/// A small SVG with a message in place of a figure.
pub fn error_svg(message: &str) -> String {
    let m = message.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
    format!(r##"<svg xmlns="http://www.w3.org/2000/svg" width="900" height="60" viewBox="0 0 900 60"><text x="10" y="35" font-family="sans-serif" font-size="14" fill="#a00">{m}</text></svg>"##)
}

/// Histograms of several samples on shared bins, as % of each sample, drawn
/// as translucent fills under step outlines (earlier series wider, so equal
/// distributions stay distinguishable), with a legend. Values outside `range` are left out (their
/// count goes in the legend).
pub fn try_histogram(title: &str, x_label: &str, samples: &[(String, Vec<f64>)], range: (f64, f64), bins: usize) -> Result<String, PlotError> {
    let bins = bins.max(1);
    let width = (range.1 - range.0) / bins as f64;
    let mut hists = Vec::new();
    let mut y_max: f64 = 1.0;
    for (name, values) in samples {
        let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let mut counts = vec![0usize; bins];
        let mut outside = 0;
        for v in &finite {
            let k = ((v - range.0) / width).floor();
            if k >= 0.0 && (k as usize) < bins {
                counts[k as usize] += 1;
            } else {
                outside += 1;
            }
        }
        let n = finite.len().max(1) as f64;
        let pct: Vec<f64> = counts.iter().map(|&c| 100.0 * c as f64 / n).collect();
        y_max = pct.iter().copied().fold(y_max, f64::max);
        let label = if outside > 0 { format!("{name} (n = {}, {outside} outside the axis)", finite.len()) } else { format!("{name} (n = {})", finite.len()) };
        hists.push((label, pct));
    }
    let (ax, ay) = (axis(range.0, range.1, 10, None), axis(0.0, y_max * (1.1 + 0.08 * samples.len() as f64), 6, None));
    svg(title, |root| {
        let mut chart = framed(root, title, (ax, ay), (x_label, "share of samples, %"), true)?;
        // Every fill first, light enough that overlaps show through; then
        // every outline on top, the earlier series drawn wider, so that
        // coinciding outlines (equal distributions) keep both colours: a
        // core of the later one inside a border of the earlier.
        for (i, (_, pct)) in hists.iter().enumerate() {
            let c = color(i);
            let bars = pct.iter().enumerate().filter(|(_, p)| **p > 0.0).map(move |(k, p)| {
                let x0 = range.0 + k as f64 * width;
                Rectangle::new([(x0, 0.0), (x0 + width, *p)], c.mix(HIST_FILL_ALPHA).filled())
            });
            chart.draw_series(bars).map_err(|e| err(title, e))?;
        }
        let n = hists.len();
        for (i, (label, pct)) in hists.iter().enumerate() {
            let (c, w) = (color(i), hist_outline_px(i, n));
            let outlines = histogram_outlines(pct, range.0, width).into_iter().map(move |v| PathElement::new(v, c.stroke_width(w)));
            chart.draw_series(outlines).map_err(|e| err(title, e))?.label(label.as_str()).legend(move |(x, y)| {
                EmptyElement::at((x, y)) + Rectangle::new([(0, -5), (14, 5)], c.mix(HIST_FILL_ALPHA * 2.0).filled()) + Rectangle::new([(0, -5), (14, 5)], c.stroke_width(2))
            });
        }
        legend(&mut chart, title)?;
        Ok(())
    })
}

/// Opacity of a histogram's fill.
const HIST_FILL_ALPHA: f64 = 0.15;

/// Outline width of the `i`-th of `n` histograms, px: 2 for the last, 2 more
/// for each earlier one.
fn hist_outline_px(i: usize, n: usize) -> u32 {
    2 + 2 * (n.saturating_sub(i + 1)).min(3) as u32
}

/// A histogram's outline as step paths, one per run of non-empty bins
/// (up from the axis, across the bin tops, back down).
fn histogram_outlines(pct: &[f64], x0: f64, width: f64) -> Vec<Vec<(f64, f64)>> {
    let mut paths: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for (k, &p) in pct.iter().enumerate() {
        let (a, b) = (x0 + k as f64 * width, x0 + (k + 1) as f64 * width);
        if p > 0.0 {
            if !open {
                paths.push(vec![(a, 0.0)]);
                open = true;
            }
            if let Some(v) = paths.last_mut() {
                v.extend([(a, p), (b, p)]);
            }
        } else if open {
            if let Some(v) = paths.last_mut() {
                v.push((a, 0.0));
            }
            open = false;
        }
    }
    if open {
        if let Some(v) = paths.last_mut() {
            v.push((x0 + pct.len() as f64 * width, 0.0));
        }
    }
    paths
}

/// Samples per cell of a heading × tilt grid.
pub struct CoverageGrid {
    /// Cell edges along x (heading), degrees.
    pub x_edges_deg: Vec<f64>,
    /// Cell edges along y (roll or pitch), degrees.
    pub y_edges_deg: Vec<f64>,
    /// `counts[ix][iy]`.
    pub counts: Vec<Vec<u32>>,
    /// The tilt the swing test should reach, ± degrees: empty cells within
    /// it are gaps.
    pub wanted_deg: f64,
}

impl CoverageGrid {
    /// Bins `(heading, tilt)` pairs (degrees) into `x_step` × `y_step` cells
    /// over 0…360 and ±`y_max`.
    pub fn new(pairs: impl Iterator<Item = (f64, f64)>, x_step_deg: f64, y_max_deg: f64, y_step_deg: f64, wanted_deg: f64) -> Self {
        let nx = (360.0 / x_step_deg).round().max(1.0) as usize;
        let ny = (2.0 * y_max_deg / y_step_deg).round().max(1.0) as usize;
        let mut counts = vec![vec![0u32; ny]; nx];
        for (h, t) in pairs.filter(|p| p.0.is_finite() && p.1.is_finite()) {
            let ix = ((h.rem_euclid(360.0) / x_step_deg) as usize).min(nx - 1);
            let iy = ((t + y_max_deg) / y_step_deg).floor();
            if iy >= 0.0 && (iy as usize) < ny {
                counts[ix][iy as usize] += 1;
            }
        }
        Self {
            x_edges_deg: (0..=nx).map(|i| i as f64 * x_step_deg).collect(),
            y_edges_deg: (0..=ny).map(|i| -y_max_deg + i as f64 * y_step_deg).collect(),
            counts,
            wanted_deg,
        }
    }

    /// Empty cells lying wholly within the wanted tilt.
    pub fn gaps(&self) -> usize {
        let mut n = 0;
        for col in &self.counts {
            for (iy, c) in col.iter().enumerate() {
                if *c == 0 && self.y_edges_deg[iy] >= -self.wanted_deg - 1e-9 && self.y_edges_deg[iy + 1] <= self.wanted_deg + 1e-9 {
                    n += 1;
                }
            }
        }
        n
    }
}

/// The coverage grid as a map: cells shaded by samples (log scale), gaps
/// (empty cells within the wanted tilt) crossed in red, the wanted tilt
/// dashed. The key is the figure's caption (a legend box would hide cells).
pub fn try_coverage_map(title: &str, y_label: &str, grid: &CoverageGrid) -> Result<String, PlotError> {
    let (x0, x1) = (grid.x_edges_deg[0], grid.x_edges_deg[grid.x_edges_deg.len() - 1]);
    let (y0, y1) = (grid.y_edges_deg[0], grid.y_edges_deg[grid.y_edges_deg.len() - 1]);
    let max = grid.counts.iter().flatten().copied().max().unwrap_or(0).max(1) as f64;
    let heading_ticks: Vec<f64> = (0..=12).map(|k| k as f64 * 30.0).collect();
    let (ax, ay) = (axis(x0, x1, 8, Some(&heading_ticks)), axis(y0, y1, 8, None));
    svg(title, |root| {
        let mut chart = framed(root, title, (ax, ay), ("heading, ° from magnetic north", y_label), false)?;
        let base = RGBColor(0x1f, 0x77, 0xb4);
        let mut cells = Vec::new();
        let mut gaps = Vec::new();
        for (ix, col) in grid.counts.iter().enumerate() {
            for (iy, &c) in col.iter().enumerate() {
                let (a, b) = ((grid.x_edges_deg[ix], grid.y_edges_deg[iy]), (grid.x_edges_deg[ix + 1], grid.y_edges_deg[iy + 1]));
                if c > 0 {
                    let shade = 0.15 + 0.85 * (1.0 + c as f64).ln() / (1.0 + max).ln();
                    cells.push(Rectangle::new([a, b], base.mix(shade).filled()));
                } else if a.1 >= -grid.wanted_deg - 1e-9 && b.1 <= grid.wanted_deg + 1e-9 {
                    gaps.push((a, b));
                }
            }
        }
        chart.draw_series(cells).map_err(|e| err(title, e))?.label("samples (darker = more, log scale)").legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], base.mix(0.7).filled()));
        let red = RGBColor(0xd6, 0x27, 0x28);
        let gap_count = gaps.len();
        chart
            .draw_series(gaps.into_iter().flat_map(|(a, b)| {
                [Rectangle::new([a, b], red.mix(0.12).filled()).into_dyn(), PathElement::new(vec![a, b], red.stroke_width(1)).into_dyn(), PathElement::new(vec![(a.0, b.1), (b.0, a.1)], red.stroke_width(1)).into_dyn()]
            }))
            .map_err(|e| err(title, e))?
            .label(format!("gap: no sample ({gap_count} cells)"))
            .legend(move |(x, y)| PathElement::new(vec![(x, y - 5), (x + 14, y + 5)], red.stroke_width(2)));
        let grey = RGBColor(0x44, 0x44, 0x44);
        for w in [-grid.wanted_deg, grid.wanted_deg] {
            chart.draw_series(DashedLineSeries::new(vec![(x0, w), (x1, w)], 6, 4, grey.stroke_width(1))).map_err(|e| err(title, e))?;
        }
        chart.draw_series(std::iter::once(PathElement::new(vec![(x0, grid.wanted_deg)], grey))).map_err(|e| err(title, e))?.label(format!("wanted ±{:.0}°", grid.wanted_deg)).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 14, y)], grey.stroke_width(1)));
Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_plots_are_svg_with_text_legends_and_round_ticks() {
        let svg = try_line_plot("t", "time, s", "|H|, nT", &[Series { name: "a<b".into(), points: vec![(0.0, 0.0), (1.0, 10.0), (f64::NAN, 0.0), (2.0, 5.0)], dots: false }], None, None).unwrap();
        std::fs::write(std::env::temp_dir().join("magcal_plot_test.svg"), &svg).unwrap();
        assert!(svg.starts_with("<svg"), "{svg}");
        assert!(svg.contains("a&lt;b"), "legend text is escaped SVG text");
        assert!(svg.contains("time, s") && svg.contains("|H|, nT"));
        // The NaN lifts the pen: two polylines for the one series.
        // (Series 0 is drawn in #1F77B4; one more polyline is its legend swatch.)
        assert_eq!(svg.lines().filter(|l| l.starts_with("<polyline") && l.contains("stroke=\"#1F77B4\"")).count(), 3, "{svg}");
        // Ticks: plotters' key points over 0…2 (padded −0.1…2.1) are round:
        // 0.0, 0.2, … — no long decimals.
        let texts: Vec<&str> = svg.split("<text").skip(1).filter_map(|t| t.split('>').nth(1)).filter_map(|t| t.split('<').next()).map(str::trim).collect();
        for tick in ["0.0", "0.5", "1.0", "1.5", "2.0", "0", "2", "4", "6", "8", "10"] {
            assert!(texts.contains(&tick), "{tick} in {texts:?}");
        }
        assert!(texts.iter().all(|t| t.len() < 24), "{texts:?}");
    }

    #[test]
    fn ticks_are_round() {
        // By hand: 0…1600 in ≤ 10 ticks → raw step 160 → 200; −0.1…2.1 →
        // raw 0.22 → 0.5 (0.2 is too small); 48 000…49 400 in ≤ 8 → 175 → 200.
        assert_eq!(nice_ticks(0.0, 1600.0, 10).0, vec![0.0, 200.0, 400.0, 600.0, 800.0, 1000.0, 1200.0, 1400.0, 1600.0]);
        let (t, _, d) = nice_ticks(-0.1, 2.1, 10);
        assert_eq!((t, d), (vec![0.0, 0.5, 1.0, 1.5, 2.0], 1));
        let (t, _, d) = nice_ticks(48_000.0, 49_400.0, 8);
        assert_eq!((t.first().copied(), t.last().copied(), d), (Some(48_000.0), Some(49_400.0), 0));
        assert_eq!(tick_label(-0.0001, 2), "0.00");
    }

    #[test]
    fn iteration_ticks_stay_few_and_whole() {
        // A paper trace of 95 iterations: every 10th (0, 10, …, 90), not 96 labels.
        assert_eq!(integer_ticks(95, 12), (0..=9).map(|k| f64::from(k) * 10.0).collect::<Vec<_>>());
        // A joint trace (start and end) or a short one: every iteration.
        assert_eq!(integer_ticks(1, 12), vec![0.0, 1.0]);
        assert_eq!(integer_ticks(11, 12).len(), 12);
        // 12 → 13 ticks would be too many: every 2nd.
        assert_eq!(integer_ticks(12, 12), vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0]);
        assert_eq!(integer_ticks(1000, 12).len(), 11, "every 100th");
        assert_eq!(integer_ticks(0, 12), vec![0.0]);
    }

    #[test]
    fn coverage_grid_counts_and_finds_gaps() {
        // Two headings only, roll 0…10: 12 × 6 cells of 30° × 10° over ±30°;
        // wanted ±20° → 12 × 4 = 48 cells, 2 filled.
        let grid = CoverageGrid::new([(15.0, 5.0), (15.0, 6.0), (200.0, -15.0)].into_iter(), 30.0, 30.0, 10.0, 20.0);
        assert_eq!(grid.counts[0][3], 2);
        assert_eq!(grid.counts[6][1], 1);
        assert_eq!(grid.gaps(), 46);
        let svg = try_coverage_map("c", "roll, °", &grid).unwrap();
        assert!(svg.matches("<polyline").count() >= 2 * 46, "two strokes a crossed gap");
    }

    #[test]
    fn histogram_outlines_step_over_runs_of_bins() {
        // Bins of 1 from 0: [2, 3, 0, 1] → two runs.
        let paths = histogram_outlines(&[2.0, 3.0, 0.0, 1.0], 0.0, 1.0);
        assert_eq!(paths, vec![vec![(0.0, 0.0), (0.0, 2.0), (1.0, 2.0), (1.0, 3.0), (2.0, 3.0), (2.0, 0.0)], vec![(3.0, 0.0), (3.0, 1.0), (4.0, 1.0), (4.0, 0.0)]]);
        assert_eq!((hist_outline_px(0, 3), hist_outline_px(1, 3), hist_outline_px(2, 3)), (6, 4, 2));
    }

    #[test]
    fn equal_histograms_keep_both_colours() {
        let v: Vec<f64> = (0..100).map(|i| f64::from(i) / 100.0).collect();
        let svg = try_histogram("h", "e", &[("a".into(), v.clone()), ("b".into(), v)], (-1.0, 1.0), 10).unwrap();
        // Each colour outlines the data (plus its legend swatch), the first wider.
        let outline = |colour: &str, w: u32| svg.lines().filter(|l| l.starts_with("<polyline") && l.contains(&format!("stroke=\"{colour}\"")) && l.contains(&format!("stroke-width=\"{w}\""))).count();
        assert_eq!(outline("#1F77B4", 4), 1, "{svg}");
        assert_eq!(outline("#D62728", 2), 1, "{svg}");
    }

    #[test]
    fn histograms_count_outside_values() {
        let svg = try_histogram("h", "error, °", &[("x".into(), vec![0.1, 0.2, 5.0, f64::NAN])], (-1.0, 1.0), 10).unwrap();
        assert!(svg.contains("n = 3, 1 outside the axis"), "{svg}");
    }
}
