//! The page being built: its sections, figures and the parts left out, the
//! stylesheet, and the HTML around them.

use std::fmt::Write as _;

use super::plot::PlotError;
use super::error::ReportError;

/// HTML-escapes text.
pub(crate) fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A value with its unit, or "not available".
pub(crate) fn fmt_opt(v: Option<f64>, prec: usize, unit: &str) -> String {
    match v {
        Some(v) if v.is_finite() => format!("{v:.prec$}{unit}"),
        _ => "not available".into(),
    }
}

/// The page being built: sections, figures counted, missing parts noted.
pub(crate) struct Page {
    pub(crate) body: String,
    pub(crate) figures: usize,
    pub(crate) missing: Vec<String>,
}

impl Page {
    pub(crate) fn new() -> Self {
        Self { body: String::new(), figures: 0, missing: Vec::new() }
    }
    pub(crate) fn h2(&mut self, id: &str, title: &str) {
        let _ = writeln!(self.body, "<section id=\"{id}\"><h2>{}</h2>", escape(title));
    }
    pub(crate) fn end(&mut self) {
        self.body.push_str("</section>\n");
    }
    pub(crate) fn figure(&mut self, svg: Result<String, PlotError>, caption: &str) -> Result<(), ReportError> {
        let svg = svg?;
        let _ = writeln!(self.body, "<figure>{svg}<figcaption>{}</figcaption></figure>", escape(caption));
        self.figures += 1;
        Ok(())
    }
    pub(crate) fn missing(&mut self, section: &str, why: &str) {
        let _ = writeln!(self.body, "<p class=\"missing\">Not available: {}</p>", escape(why));
        self.missing.push(format!("{section}: {why}"));
    }
    pub(crate) fn p(&mut self, html: &str) {
        let _ = writeln!(self.body, "<p>{html}</p>");
    }
    /// The whole self-contained document around the body.
    pub(crate) fn html(&self, title: &str) -> String {
        let nav = "<p class=\"sub\">magcal · <a href=\"#headline\">headline</a> · <a href=\"#card\">deviation card</a> · <a href=\"#coverage\">coverage</a> · <a href=\"#field\">field</a> · <a href=\"#heading\">heading</a> · <a href=\"#integrity\">integrity</a> · <a href=\"#backstep\">back-stepping</a> · <a href=\"#residuals\">residuals</a> · <a href=\"#coefficients\">coefficients</a></p>";
        format!(
            "<!doctype html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><link rel=\"icon\" href=\"data:,\"><title>{t}</title><style>{CSS}</style></head>\n<body><h1>{t}</h1>{nav}\n{}</body></html>\n",
            self.body,
            t = escape(title)
        )
    }
}

const CSS: &str = r#"
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;max-width:960px;margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:.2em}h2{font-size:1.25em;border-bottom:2px solid #1f77b4;padding-bottom:.15em;margin-top:1.6em}
.sub{color:#555;margin-top:0}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #bbb;padding:.25em .6em;text-align:right}th{background:#eef3f8}td.l,th.l{text-align:left}
.headline td{font-size:1.05em}.headline td.big{font-weight:bold;font-size:1.2em}
figure{margin:.8em 0;page-break-inside:avoid;break-inside:avoid}figure svg{width:100%;height:auto;display:block}
figcaption{font-size:.88em;color:#444;margin-top:.2em}
.missing{color:#8a5300;background:#fff6e5;border-left:4px solid #e0a030;padding:.3em .6em}
.ok{color:#176d17;font-weight:bold}.bad{color:#b00;font-weight:bold}
.cols{display:flex;gap:1.5em;flex-wrap:wrap}
@media print{body{max-width:none;margin:0;font-size:10.5pt}h2{page-break-after:avoid;break-after:avoid}section{page-break-inside:auto}a{color:inherit;text-decoration:none}}
@page{size:A4;margin:14mm}
"#;
