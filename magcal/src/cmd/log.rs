//! `magcal log`: the board's raw stream to a board log on the board's clock
//! (`host_tools::board::log_board`), for `magcal merge`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Result;
use host_tools::board::{create_log_file, log_board, LogEnd, LogError, LogOptions, LogSummary, LOGGED_SAMPLES};
use host_tools::doc::{integrity_text, recalibrate_text};
use host_tools::board::BoardClient;
use host_tools::session::Progress;

use super::hinted;

/// Arguments of `magcal log`.
#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the board, e.g. /dev/ttyUSB0 or QEMU's /dev/pts/N.
    #[arg(long)]
    port: String,
    /// The board log to write (CSV: t, mx, my, mz, temp_c, health).
    #[arg(long)]
    out: PathBuf,
    /// Stop after this many seconds, 0.1 s to 30 days (default: until Ctrl-C).
    #[arg(long, value_parser = super::number_in(0.1..=2_592_000.0, "s"))]
    duration_s: Option<f64>,
    /// The board's output rate, Hz (1–100).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u8).range(1..=100))]
    rate_hz: u8,
    /// Overwrite --out if it exists.
    #[arg(long)]
    force: bool,
    /// Print the summary as one JSON document on stdout.
    #[arg(long)]
    json: bool,
}

/// Set by SIGINT, SIGTERM and SIGHUP (the terminal closed): the log ends
/// cleanly at the next sample, keeping what it logged.
static STOP: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
}

fn catch_interrupts() {
    let handler = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
    // SAFETY: the handler only stores to an atomic (async-signal-safe).
    // It replaces the handler that removes temporaries on these signals
    // (`host_tools::files`): the log's own file is ended by `finish`.
    unsafe {
        libc::signal(libc::SIGINT, handler);
        libc::signal(libc::SIGTERM, handler);
        libc::signal(libc::SIGHUP, handler);
    }
}

/// Runs `magcal log`.
pub fn run(a: Args) -> Result<()> {
    // (Both in range: their parsers.)
    let duration = a.duration_s.map(Duration::from_secs_f64);
    let mut file = create_log_file(&a.out, a.force).map_err(|e| hinted(e, |e| matches!(e, LogError::Exists(_)).then_some("give another --out, or --force to overwrite it")))?;
    let opts = LogOptions { duration, rate_hz: a.rate_hz, interactive: std::io::stderr().is_terminal(), ..LogOptions::default() };
    catch_interrupts();
    let total = duration.map_or(0, |d| (d.as_secs_f64() * f64::from(a.rate_hz)) as usize);
    let mut progress = Progress::new("log", total, opts.interactive);
    let port = a.port.clone();
    let mut connect = move || BoardClient::open(&port);
    let result = log_board(&mut connect, &mut file, a.out.clone(), &opts, &STOP, |p| {
        let line = if p.link_down {
            format!("link down, reconnecting (drops {}, gaps {})", p.link_drops, p.gaps)
        } else {
            format!("t {:.1} s, {} gaps, {} drops", p.last_t_s, p.gaps, p.link_drops)
        };
        progress.update((p.samples as usize).saturating_sub(1), &line);
    });
    progress.finish();
    // The file ends first: a log that holds samples is kept (a replacing
    // one renamed over the old log), one that does not never replaces it.
    let (replaces, samples) = (file.replaces(), file.holds_samples());
    let ended = file.finish(result.is_ok());
    let s = result?;
    ended?;
    if replaces && !samples {
        eprintln!("note: no samples were logged: {} is kept as it was", a.out.display());
    }
    eprintln!("{}", describe(&s));
    eprintln!("integrity: {}", integrity_text(&s.integrity));
    if let Some(e) = &s.recalibrate {
        eprintln!("{}", recalibrate_text(e, LOGGED_SAMPLES));
    }
    if s.ended == LogEnd::BoardRestarted {
        eprintln!("warning: the board restarted (its clock went back): the log ends there; start another log for what follows");
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&s)?);
    }
    Ok(())
}

/// The summary in words.
fn describe(s: &LogSummary) -> String {
    let span = match (s.first_t_s, s.last_t_s) {
        (Some(a), Some(b)) => format!("board t {a:.3}…{b:.3} s"),
        _ => "no samples".into(),
    };
    let longest = s.gaps.iter().map(|g| g.length_s).fold(0.0, f64::max);
    let board = match (s.board_samples_produced, s.board_tx_dropped) {
        (Some(p), Some(d)) => format!("; the board produced {p} samples and dropped {d} frames meanwhile"),
        _ => String::new(),
    };
    format!(
        "wrote {} ({} samples, {span}; {} gaps, {:.3} s in all, longest {:.3} s, {} samples missing; {} link drops; {} saturated; {} damaged frames, {} queue drops{board}; ended: {:?})",
        s.out.display(),
        s.samples,
        s.gaps.len(),
        s.gap_total_s,
        longest,
        s.missing_samples,
        s.link_drops,
        s.saturated_samples,
        s.host_discarded_frames,
        s.host_queue_dropped,
        s.ended
    )
}

