//! Shared set-up for the end-to-end tests: where the firmware ELF and the
//! `magcal` binary are, and a booted QEMU board with a log file.
//!
//! `cargo xtask test` builds both and passes their paths in
//! `MAGCAL_FIRMWARE_ELF` and `MAGCAL_BIN`.

use host_tools::board::{QemuBoard, QemuOptions};
use std::path::PathBuf;

fn env_path(var: &str) -> PathBuf {
    match std::env::var_os(var) {
        Some(p) => PathBuf::from(p),
        None => panic!("{var} is not set: run the end-to-end suite through `cargo xtask test`"),
    }
}

/// The firmware ELF under test.
pub fn firmware_elf() -> PathBuf {
    env_path("MAGCAL_FIRMWARE_ELF")
}

/// The `magcal` binary under test.
pub fn magcal_bin() -> PathBuf {
    env_path("MAGCAL_BIN")
}

/// Boots the firmware in QEMU; its decoded defmt log goes to
/// `target/e2e-logs/<name>.log`.
pub fn boot(name: &str) -> QemuBoard {
    boot_with(name, false)
}

/// Boots the firmware in QEMU with USART2 (the sensor feed) on a pty too.
pub fn boot_with_feed(name: &str) -> QemuBoard {
    boot_with(name, true)
}

fn boot_with(name: &str, sensor_port: bool) -> QemuBoard {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/e2e-logs");
    let _ = std::fs::create_dir_all(&dir);
    let mut opts = QemuOptions::new(firmware_elf());
    opts.sensor_port = sensor_port;
    opts.log = Some(dir.join(format!("{name}.log")));
    match QemuBoard::boot(&opts) {
        Ok(b) => b,
        Err(e) => panic!("cannot boot the QEMU board: {e}"),
    }
}
