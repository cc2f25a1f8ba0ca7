//! Progress display: indicatif bars on a terminal, plain lines otherwise.

use std::time::{Duration, Instant};

/// A manoeuvre's progress on stderr.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    label: String,
    total: usize,
    last_line: Instant,
}

impl Progress {
    /// A progress display for `total` steps (0: not known).
    pub fn new(label: &str, total: usize, interactive: bool) -> Self {
        let bar = interactive.then(|| {
            // A stream of unknown length (a real vehicle) gets a spinner.
            let b = if total == 0 { indicatif::ProgressBar::new_spinner() } else { indicatif::ProgressBar::new(total as u64) };
            if let Ok(style) = indicatif::ProgressStyle::with_template("{msg:>14} [{bar:40}] {pos}/{len} {wide_msg}") {
                b.set_style(style);
            }
            b.set_message(label.to_string());
            b
        });
        Self { bar, label: label.to_string(), total, last_line: Instant::now() - Duration::from_secs(10) }
    }

    /// Step `i` done; `detail` is the current guidance or state.
    pub fn update(&mut self, i: usize, detail: &str) {
        match &self.bar {
            Some(b) => {
                b.set_position(i as u64 + 1);
                b.set_message(format!("{} {detail}", self.label));
            }
            None => {
                if self.last_line.elapsed() > Duration::from_secs(2) || i + 1 == self.total {
                    if self.total == 0 {
                        eprintln!("  {} {}: {detail}", self.label, i + 1);
                    } else {
                        eprintln!("  {} {}/{}: {detail}", self.label, i + 1, self.total);
                    }
                    self.last_line = Instant::now();
                }
            }
        }
    }

    /// Done.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish();
        }
    }
}


/// A spinner with the elapsed time, for work of unknown length (a fit over
/// millions of rows, a back-stepping over a long run): on a terminal only —
/// hidden when `show` is false (`--json`, stderr not a terminal), so logs
/// and pipes stay clean. Cleared when dropped, whatever ends the work.
pub struct Working(indicatif::ProgressBar);

impl Working {
    /// Starts the spinner saying `what` is being done.
    pub fn start(what: &str, show: bool) -> Self {
        let bar = if show { indicatif::ProgressBar::new_spinner() } else { indicatif::ProgressBar::hidden() };
        if let Ok(style) = indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})") {
            bar.set_style(style);
        }
        bar.set_message(what.to_string());
        if show {
            bar.enable_steady_tick(Duration::from_millis(250));
        }
        Working(bar)
    }

    /// Clears the spinner (before the command prints what it found).
    pub fn done(&self) {
        self.0.finish_and_clear();
    }

    /// Whether nothing is drawn.
    pub fn is_hidden(&self) -> bool {
        self.0.is_hidden()
    }
}

impl Drop for Working {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn working_is_silent_when_not_shown() {
        let w = Working::start("fitting", false);
        assert!(w.is_hidden());
    }
}
