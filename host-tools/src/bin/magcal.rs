//! `magcal`: the command-line front end. See `docs/INTERFACES.md` for the
//! contract (every subcommand takes `--json`; stdout carries only the result,
//! stderr the progress and the one-line reason on failure).

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use host_tools::link::Link;
use magcal_protocol::Platform;

#[derive(Parser)]
#[command(name = "magcal", version, about = "AUV magnetometer calibration tools")]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Ask the board (or the QEMU board) who it is.
    Identify {
        /// Serial port of the board, e.g. /dev/ttyUSB0 or QEMU's /dev/pts/N.
        #[arg(long)]
        port: String,
        /// Print one JSON document on stdout.
        #[arg(long)]
        json: bool,
    },
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("magcal: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Cmd::Identify { port, json } => {
            let mut link = Link::open(&port)?;
            let id = link.identify().with_context(|| format!("identify on {port}"))?;
            let platform = match id.platform {
                Platform::Qemu => "qemu",
                Platform::Silicon => "silicon",
            };
            if json {
                let doc = serde_json::json!({
                    "name": id.name.as_str(),
                    "firmware_version": id.firmware_version.as_str(),
                    "protocol_version": id.protocol_version,
                    "platform": platform,
                    "uptime_ms": id.uptime_ms,
                });
                println!("{doc}");
            } else {
                println!(
                    "{} {} (protocol {}) on {}, up {} ms",
                    id.name, id.firmware_version, id.protocol_version, platform, id.uptime_ms
                );
            }
            Ok(())
        }
    }
}
