//! `magcal`: the command-line front end. See `docs/INTERFACES.md` for the
//! contract: every subcommand takes `--json` and then prints one JSON document
//! on stdout and nothing else there; progress and warnings go to stderr; on
//! failure the exit status is non-zero with a one-line reason on stderr.
//!
//! One module per subcommand under `cmd/`; each parses its arguments,
//! calls the `host-tools` library (or `magcal-sim` for `simulate` and the
//! simulated vehicle) and formats the output.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

mod cmd;

#[derive(Parser)]
#[command(name = "magcal", version, about = "AUV magnetometer calibration tools")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

// Parsed once per run; boxing the big variants would only add noise.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand)]
enum Cmd {
    /// Simulate a field test (writes FILE.csv and FILE.truth.json).
    Simulate(cmd::simulate::Args),
    /// A field calibration session over the serial link: swing test,
    /// out-and-back run, back-stepping and swing fits, verified upload.
    /// The vehicle is either the simulator, played into the QEMU board's
    /// sensor feed (`--sim-feed`), or a real one whose navigation arrives as
    /// CSV streams (`--nav-swing`, `--nav-run`: files or FIFOs).
    Session(cmd::session::Args),
    /// Figures (SVG) and an HTML page comparing calibrations on recordings.
    Report(cmd::report::Args),
    /// A calibration applied to any recording: calibrated field, heading,
    /// its 1σ and integrity per row, by the board's own per-sample code.
    Apply(cmd::apply::Args),
    /// Back-stepping refinement on an out-and-back run.
    Backstep(cmd::backstep::Args),
    /// Reference field (IGRF-14 or WMM2025) at a place and date.
    Igrf(cmd::igrf::Args),
    /// Ask the board (or the QEMU board) who it is.
    Identify(cmd::identify::Args),
    /// Choose what the board streams: framed samples, or NMEA 0183 sentences
    /// ($HCHDG, $HCHDT, $PMAGI with the heading's σ and integrity).
    Stream(cmd::stream::Args),
    /// Field (ellipsoid) calibration from a recording.
    Fit(cmd::fit::Args),
    /// Fourier (swinging) heading calibration against a reference heading.
    Swing(cmd::swing::Args),
    /// Non-orthogonality and gain identification (paper 001).
    Ortho(cmd::ortho::Args),
    /// A calibration as ArduPilot's or PX4's magnetometer parameters.
    Export(cmd::export::Args),
    /// The compass deviation card: heading error by heading and compass
    /// point, before and after the calibration.
    Card(cmd::card::Args),
    /// A recording from a vehicle's own log (ArduPilot/ArduSub DataFlash) or
    /// an NMEA 0183 log (heading compass and GPS).
    Import(cmd::import::Args),
    /// One recording from the board's field log and the navigation log on
    /// another clock: the clock offset and drift estimated from the turns
    /// both see (or given), navigation interpolated to the board's samples.
    Merge(cmd::merge::Args),
    /// The board's raw stream to a board log on the board's clock (for
    /// `merge`): t, mx, my, mz, temp_c, health, flushed as it goes; link
    /// drops reopened and kept as gaps; Ctrl-C ends it cleanly.
    Log(cmd::log::Args),
}

/// The command line, parsed: every subcommand takes a negative number as
/// an option's value (`--max-delay-s -2`, `--lat -33.9`), so its own range
/// check answers instead of clap's "unexpected argument".
/// A value out of its stated range is a failure like any other: one line
/// on stderr and status 1 (clap's usage errors, help and version as clap
/// gives them).
fn parse() -> Cli {
    let command = Cli::command().mut_subcommands(|s| s.allow_negative_numbers(true));
    let parsed = command.try_get_matches().and_then(|m| Cli::from_arg_matches(&m));
    parsed.unwrap_or_else(|e| {
        use clap::error::ErrorKind;
        if matches!(e.kind(), ErrorKind::ValueValidation | ErrorKind::InvalidValue) {
            let text = e.to_string();
            let line = text.lines().next().unwrap_or_default();
            eprintln!("magcal: {}", line.strip_prefix("error: ").unwrap_or(line));
            std::process::exit(1);
        }
        e.exit()
    })
}

/// The process's signals, set once before any work.
fn set_signals() {
    #[cfg(unix)]
    {
        // A closed stdout (`magcal card --json | head -c 10`) ends the
        // command as it ends any Unix tool, quietly by SIGPIPE: Rust
        // ignores SIGPIPE, so the next print panicked. Files are written
        // before anything is printed, so none is left half done.
        // SAFETY: restoring a signal's default action, before any thread.
        unsafe {
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
        // Temporaries removed on SIGINT, SIGTERM and SIGHUP.
        if let Err(e) = host_tools::files::remove_temporaries_on_signals() {
            eprintln!("warning: temporary files would not be removed on a signal: {e}");
        }
    }
}

fn main() {
    set_signals();
    let cli = parse();
    let result = match cli.command {
        Cmd::Simulate(a) => cmd::simulate::run(a),
        Cmd::Session(a) => cmd::session::run(a),
        Cmd::Report(a) => cmd::report::run(a),
        Cmd::Apply(a) => cmd::apply::run(a),
        Cmd::Backstep(a) => cmd::backstep::run(a),
        Cmd::Igrf(a) => cmd::igrf::run(a),
        Cmd::Identify(a) => cmd::identify::run(a),
        Cmd::Stream(a) => cmd::stream::run(a),
        Cmd::Fit(a) => cmd::fit::run(a),
        Cmd::Swing(a) => cmd::swing::run(a),
        Cmd::Ortho(a) => cmd::ortho::run(a),
        Cmd::Export(a) => cmd::export::run(a),
        Cmd::Card(a) => cmd::card::run(a),
        Cmd::Import(a) => cmd::import::run(a),
        Cmd::Merge(a) => cmd::merge::run(a),
        Cmd::Log(a) => cmd::log::run(a),
    };
    if let Err(e) = result {
        // One line: the chain of causes, each said once.
        let mut msg = String::new();
        for cause in e.chain() {
            let text = cause.to_string();
            if !msg.contains(&text) {
                if !msg.is_empty() {
                    msg.push_str(": ");
                }
                msg.push_str(&text);
            }
        }
        eprintln!("magcal: {}", msg.replace('\n', " "));
        std::process::exit(1);
    }
}
