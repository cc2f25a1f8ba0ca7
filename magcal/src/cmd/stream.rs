//! `magcal stream`: choose what the board streams on its host link — framed
//! samples for `magcal log` and the session, or NMEA 0183 sentences for a
//! navigation computer (`docs/INTERFACES.md`, "The board's NMEA 0183 output").

use anyhow::{Context, Result};
use host_tools::board::BoardClient;
use magcal_protocol::StreamMode;

/// What the board streams.
#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Mode {
    /// Nothing.
    Off,
    /// Framed raw counts.
    Raw,
    /// Framed calibrated field, heading, σ and integrity.
    Calibrated,
    /// Framed raw and calibrated.
    Both,
    /// NMEA 0183: `$HCHDG`, `$HCHDT` and `$PMAGI` (σ, integrity) per output sample.
    Nmea,
}

impl From<Mode> for StreamMode {
    fn from(m: Mode) -> Self {
        match m {
            Mode::Off => StreamMode::Off,
            Mode::Raw => StreamMode::Raw,
            Mode::Calibrated => StreamMode::Calibrated,
            Mode::Both => StreamMode::Both,
            Mode::Nmea => StreamMode::Nmea,
        }
    }
}

/// Arguments of `magcal stream`.
#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the board, e.g. /dev/ttyUSB0 or QEMU's /dev/pts/N.
    #[arg(long)]
    port: String,
    /// What the board streams from now on (until it is told otherwise or restarts).
    #[arg(long, value_enum)]
    mode: Mode,
    /// Output rate, Hz (1–100); the board's current rate when not given.
    #[arg(long, value_parser = clap::value_parser!(u8).range(1..=100))]
    rate_hz: Option<u8>,
}

/// Runs `magcal stream`.
pub fn run(a: Args) -> Result<()> {
    let mut link = BoardClient::open(&a.port)?;
    if let Some(hz) = a.rate_hz {
        link.set_output_rate(hz).with_context(|| format!("setting the output rate on {}", a.port))?;
    }
    link.set_stream(a.mode.into()).with_context(|| format!("choosing the stream on {}", a.port))?;
    eprintln!("{}: streaming {}", a.port, match a.mode {
        Mode::Off => "nothing",
        Mode::Raw => "framed raw samples",
        Mode::Calibrated => "framed calibrated samples",
        Mode::Both => "framed raw and calibrated samples",
        Mode::Nmea => "NMEA 0183 ($HCHDG, $HCHDT, $PMAGI); `magcal stream --mode calibrated` goes back",
    });
    Ok(())
}
