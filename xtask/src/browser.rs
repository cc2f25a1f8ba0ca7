//! The report in a real browser: headless Chromium renders the page to a
//! PNG; the check fails when the screenshot is blank, when the page logged
//! anything to its console (errors, warnings, uncaught exceptions: Chromium's
//! `--enable-logging=stderr --v=0` prints each as a `CONSOLE` line), or when
//! the page refers to anything outside itself.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use anyhow::{bail, Context, Result};

/// The browsers tried, in order (Debian's package installs `chromium`).
const BROWSERS: [&str; 3] = ["chromium", "chromium-browser", "google-chrome"];

/// Debian's package that provides [`BROWSERS`]`[0]`.
pub const PACKAGE: &str = "chromium";

/// Screenshot size, px: the report's width and enough height for every section.
pub const WINDOW: (u32, u32) = (1000, 9000);

/// Below this share of non-white pixels a screenshot counts as blank.
/// A real report covers ~10 % (text, tables, figures); a page with one
/// line of text ~0.1 %.
pub const MIN_INK: f64 = 0.01;

/// The first browser found on the PATH.
pub fn find() -> Option<&'static str> {
    BROWSERS.into_iter().find(|b| super::have(b))
}

/// What the browser made of a page.
#[derive(Debug, Clone)]
pub struct Rendered {
    /// The screenshot.
    pub png: PathBuf,
    /// Wall-clock time of the browser run (start, load, render, screenshot), s.
    pub render_s: f64,
    /// The page's console messages.
    pub console: Vec<String>,
    /// Share of non-white pixels in the screenshot.
    pub ink: f64,
}

/// Renders `html` to `png` in headless Chromium and reads back the console
/// and the screenshot. Fails only when the browser cannot run; judging the
/// result is [`judge`]'s.
pub fn render(html: &Path, png: &Path, window: (u32, u32)) -> Result<Rendered> {
    let browser = find().with_context(|| format!("no headless browser ({}) on the PATH", BROWSERS.join(", ")))?;
    let html = html.canonicalize().with_context(|| format!("{}", html.display()))?;
    let _ = std::fs::remove_file(png);
    let start = Instant::now();
    let out = Command::new(browser)
        // --no-sandbox: CI runs as root; --disable-dev-shm-usage: containers
        // have a small /dev/shm.
        .args(["--headless", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu", "--hide-scrollbars", "--no-first-run", "--disable-extensions", "--enable-logging=stderr", "--v=0"])
        .arg(format!("--window-size={},{}", window.0, window.1))
        .arg(format!("--screenshot={}", png.display()))
        .arg(format!("file://{}", html.display()))
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("running {browser}"))?;
    let render_s = start.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() || !png.is_file() {
        bail!("{browser} failed ({}): {}", out.status, stderr.lines().rev().take(5).collect::<Vec<_>>().join(" | "));
    }
    let bytes = std::fs::read(png).with_context(|| format!("{}", png.display()))?;
    Ok(Rendered { png: png.to_path_buf(), render_s, console: console_messages(&stderr), ink: ink_share(&bytes)? })
}

/// The page's console messages among Chromium's log lines
/// (`[…:INFO:CONSOLE:12] "message", source: file:///… (12)`).
pub fn console_messages(stderr: &str) -> Vec<String> {
    stderr.lines().filter(|l| l.contains(":CONSOLE")).map(|l| l.split_once("] ").map_or(l, |(_, m)| m).to_string()).collect()
}

/// Share of pixels that are not white (any channel below 250) in a PNG.
pub fn ink_share(png_bytes: &[u8]) -> Result<f64> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().context("not a PNG")?;
    let mut buf = vec![0; reader.output_buffer_size().context("PNG too large")?];
    let info = reader.next_frame(&mut buf).context("decoding the PNG")?;
    let channels = info.color_type.samples();
    let colour = channels.min(3);
    let pixels = buf[..info.buffer_size()].chunks_exact(channels);
    let total = (info.width as usize * info.height as usize).max(1);
    let ink = pixels.filter(|p| p[..colour].iter().any(|&v| v < 250)).count();
    Ok(ink as f64 / total as f64)
}

/// References to anything outside the page (`src=`, `url(`, links to
/// `http(s)://` other than the SVG namespace): a self-contained report has none.
pub fn external_references(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for needle in ["src=", "url(", "href=\"http", "href='http", "@import"] {
        if let Some(i) = html.find(needle) {
            out.push(html[i..].chars().take(60).collect());
        }
    }
    out
}

/// The verdict on a rendered page: `Err` says everything that is wrong.
pub fn judge(r: &Rendered, html: &str) -> Result<()> {
    let mut wrong = Vec::new();
    if r.ink < MIN_INK {
        wrong.push(format!("the screenshot is blank ({:.3} % non-white, need ≥ {:.1} %)", r.ink * 100.0, MIN_INK * 100.0));
    }
    for m in &r.console {
        wrong.push(format!("console: {m}"));
    }
    for x in external_references(html) {
        wrong.push(format!("refers outside itself: {x}"));
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        bail!("{}: {}", r.png.display(), wrong.join("; "))
    }
}

/// Renders and judges a report page; the screenshot goes beside it.
pub fn check_report(html: &Path) -> Result<Rendered> {
    let text = std::fs::read_to_string(html).with_context(|| format!("{}", html.display()))?;
    let png = html.with_extension("png");
    let r = render(html, &png, WINDOW)?;
    judge(&r, &text)?;
    Ok(r)
}

/// The check must fail on a bad page: a blank page and a page that logs a
/// console error, each rendered for real. `Ok` when both are caught.
#[cfg(test)]
fn self_test(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)?;
    let cases = [
        ("blank", "<!doctype html><html><head><meta charset=\"utf-8\"><link rel=\"icon\" href=\"data:,\"></head><body></body></html>", "blank"),
        ("console", "<!doctype html><html><head><meta charset=\"utf-8\"><link rel=\"icon\" href=\"data:,\"></head><body><h1 style=\"font-size:200px\">report</h1><div style=\"height:3000px;background:#369\"></div><script>console.error('deliberately broken')</script></body></html>", "deliberately broken"),
    ];
    for (name, page, expect) in cases {
        let html = dir.join(format!("{name}.html"));
        std::fs::write(&html, page)?;
        match check_report(&html) {
            Ok(_) => bail!("the browser check passed a {name} page"),
            Err(e) if format!("{e:#}").contains(expect) => {}
            Err(e) => bail!("the browser check failed the {name} page for another reason: {e:#}"),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w`×`h` RGB PNG, white but for `dark` black pixels.
    fn png(w: u32, h: u32, dark: usize) -> Vec<u8> {
        let mut data = vec![255u8; (w * h * 3) as usize];
        for px in data.chunks_exact_mut(3).take(dark) {
            px.copy_from_slice(&[0, 0, 0]);
        }
        let mut out = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut out, w, h);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.write_header().unwrap().write_image_data(&data).unwrap();
        }
        out
    }

    #[test]
    fn ink_is_the_share_of_non_white_pixels() {
        assert_eq!(ink_share(&png(10, 10, 0)).unwrap(), 0.0);
        assert!((ink_share(&png(10, 10, 25)).unwrap() - 0.25).abs() < 1e-12);
        assert!(ink_share(b"not a png").is_err());
    }

    #[test]
    fn a_blank_page_or_a_console_message_fails_the_check() {
        let dir = tempfile::tempdir().unwrap();
        let good = Rendered { png: dir.path().join("x.png"), render_s: 1.0, console: vec![], ink: ink_share(&png(100, 100, 1500)).unwrap() };
        judge(&good, "<html><body><svg xmlns=\"http://www.w3.org/2000/svg\"></svg></body></html>").unwrap();
        // Blank: 5 dark pixels of 10 000 = 0.05 % < 1 %.
        let blank = Rendered { ink: ink_share(&png(100, 100, 5)).unwrap(), ..good.clone() };
        assert!(format!("{:#}", judge(&blank, "").unwrap_err()).contains("blank"));
        // Chromium's stderr as it prints a page's console.error (captured from
        // Debian's chromium 13x with --enable-logging=stderr --v=0).
        let stderr = "[5613:5613:1123/094933.573586:WARNING:ui/base/idle/idle_linux.cc:111] None of the known D-Bus ScreenSaver services could be used.\n\
                      [5613:5613:1123/094934.366715:INFO:CONSOLE:1] \"deliberate error\", source: file:///tmp/broken.html (1)\n";
        let noisy = Rendered { console: console_messages(stderr), ..good.clone() };
        assert_eq!(noisy.console, vec!["\"deliberate error\", source: file:///tmp/broken.html (1)".to_string()]);
        assert!(format!("{:#}", judge(&noisy, "").unwrap_err()).contains("deliberate error"));
        // An external fetch.
        assert!(judge(&good, "<img src=\"https://example.org/x.png\">").is_err());
    }

    /// The real browser on deliberately broken pages (skipped, saying so,
    /// where no Chromium is installed; `cargo xtask test` installs it before
    /// the unit tests run).
    #[test]
    fn the_real_browser_catches_broken_pages() {
        if find().is_none() {
            eprintln!("SKIPPED: no chromium on the PATH (cargo xtask test installs it)");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        self_test(dir.path()).unwrap();
    }
}
