//! `magcal identify`: ask the board (or the QEMU board) who it is.

use anyhow::{Context, Result};
use host_tools::board::BoardClient;
use magcal_protocol::Platform;
use serde_json::json;

/// Arguments of `magcal identify`.
#[derive(clap::Args)]
pub struct Args {
    /// Serial port of the board, e.g. /dev/ttyUSB0 or QEMU's /dev/pts/N.
    #[arg(long)]
    port: String,
    /// Print one JSON document on stdout.
    #[arg(long)]
    json: bool,
}

/// Runs `magcal identify`.
pub fn run(a: Args) -> Result<()> {
    let mut link = BoardClient::open(&a.port)?;
    let id = link.identify().with_context(|| format!("identify on {}", a.port))?;
    let platform = match id.platform {
        Platform::Qemu => "qemu",
        Platform::Silicon => "silicon",
    };
    if a.json {
        let doc = json!({
            "name": id.name.as_str(),
            "firmware_version": id.firmware_version.as_str(),
            "protocol_version": id.protocol_version,
            "platform": platform,
            "uptime_ms": id.uptime_ms,
        });
        println!("{doc}");
    } else {
        println!("{} {} (protocol {}) on {}, up {} ms", id.name, id.firmware_version, id.protocol_version, platform, id.uptime_ms);
    }
    Ok(())
}
