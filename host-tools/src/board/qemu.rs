//! The QEMU board: the firmware ELF booted on QEMU's `netduinoplus2`
//! (STM32F405), with USART1 on a pseudo-terminal that `magcal` opens exactly
//! as it would open a real board's serial port.
//!
//! QEMU prints `char device redirected to /dev/pts/N (label serialK)` on its
//! stdout before the guest runs; after that line, stdout carries the
//! firmware's defmt frames (semihosting), which go to a log file, decoded by
//! `defmt-print` when it is installed, raw otherwise.

use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::Duration;

/// Why the QEMU board could not be started.
#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    /// The firmware ELF is not there.
    #[error("firmware ELF {0} not found (build it with `cargo build -p firmware --target thumbv7em-none-eabihf`)")]
    NoElf(PathBuf),
    /// QEMU could not be started.
    #[error("cannot start {program} ({source}); install it with `apt-get install qemu-system-arm`")]
    Spawn {
        /// The QEMU binary tried.
        program: String,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// QEMU did not announce its serial pseudo-terminals.
    #[error("QEMU did not announce its serial ports within {0:?}")]
    NoPty(Duration),
    /// Writing the log failed.
    #[error("log file: {0}")]
    Log(#[from] std::io::Error),
}

/// How to boot the QEMU board.
#[derive(Debug, Clone)]
pub struct QemuOptions {
    /// The firmware ELF (`target/thumbv7em-none-eabihf/<profile>/firmware`).
    pub elf: PathBuf,
    /// The QEMU binary.
    pub qemu: String,
    /// Where the firmware's decoded log goes (none: discarded).
    pub log: Option<PathBuf>,
    /// Put USART2 (the simulated sensor feed) on a pty too.
    pub sensor_port: bool,
    /// Run with `-icount shift=3,sleep=off` (deterministic instruction counts).
    pub icount: bool,
}

impl QemuOptions {
    /// Defaults for an ELF: `qemu-system-arm`, no log, USART2 unconnected.
    pub fn new(elf: impl Into<PathBuf>) -> Self {
        Self { elf: elf.into(), qemu: "qemu-system-arm".into(), log: None, sensor_port: false, icount: false }
    }
}

/// A running QEMU board. Killed when dropped.
pub struct QemuBoard {
    child: Child,
    link_port: String,
    sensor_port: Option<String>,
    log_thread: Option<JoinHandle<()>>,
}

impl QemuBoard {
    /// Boots the firmware and waits until QEMU has created its serial ports.
    pub fn boot(opts: &QemuOptions) -> Result<Self, QemuError> {
        if !opts.elf.is_file() {
            return Err(QemuError::NoElf(opts.elf.clone()));
        }
        let mut cmd = Command::new(&opts.qemu);
        cmd.args(["-machine", "netduinoplus2", "-display", "none", "-monitor", "none"])
            .args(["-serial", "pty", "-serial", if opts.sensor_port { "pty" } else { "null" }])
            .args(["-semihosting-config", "enable=on,target=native"])
            .arg("-kernel")
            .arg(&opts.elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        if opts.icount {
            cmd.args(["-icount", "shift=3,sleep=off"]);
        }
        let mut child = cmd.spawn().map_err(|source| QemuError::Spawn { program: opts.qemu.clone(), source })?;
        let expected = if opts.sensor_port { 2 } else { 1 };
        let stdout = child.stdout.take().ok_or(QemuError::NoPty(Duration::ZERO))?;
        let (tx, rx) = mpsc::channel::<(usize, String)>();
        let log = opts.log.clone();
        let elf = opts.elf.clone();
        let log_thread = std::thread::spawn(move || {
            let mut reader = BufReader::new(stdout);
            let mut seen = 0;
            let mut line = String::new();
            while seen < expected {
                line.clear();
                match reader.read_line(&mut line) {
                    Ok(0) | Err(_) => return,
                    Ok(_) => {}
                }
                if let Some(p) = parse_pty_line(&line) {
                    seen += 1;
                    if tx.send(p).is_err() {
                        return;
                    }
                }
            }
            forward_log(reader, log.as_deref(), &elf);
        });
        let wait = Duration::from_secs(10);
        let mut ports: Vec<Option<String>> = vec![None; 2];
        for _ in 0..expected {
            match rx.recv_timeout(wait) {
                Ok((idx, path)) if idx < 2 => ports[idx] = Some(path),
                Ok(_) => {}
                Err(_) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    return Err(QemuError::NoPty(wait));
                }
            }
        }
        let link_port = match ports[0].take() {
            Some(p) => p,
            None => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(QemuError::NoPty(wait));
            }
        };
        Ok(Self { child, link_port, sensor_port: ports[1].take(), log_thread: Some(log_thread) })
    }

    /// The pty carrying USART1 (the host link).
    pub fn link_port(&self) -> &str {
        &self.link_port
    }

    /// The pty carrying USART2 (the simulated sensor feed), when asked for.
    pub fn sensor_port(&self) -> Option<&str> {
        self.sensor_port.as_deref()
    }

    /// Whether QEMU is still running.
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Stops QEMU and waits for the log to be written out.
    pub fn shutdown(mut self) {
        self.stop();
    }

    fn stop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(t) = self.log_thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for QemuBoard {
    fn drop(&mut self) {
        self.stop();
    }
}

/// `char device redirected to /dev/pts/3 (label serial0)` → `(0, "/dev/pts/3")`.
fn parse_pty_line(line: &str) -> Option<(usize, String)> {
    let rest = line.trim().strip_prefix("char device redirected to ")?;
    let (path, label) = rest.split_once(" (label serial")?;
    let idx = label.strip_suffix(')')?.parse().ok()?;
    Some((idx, path.to_string()))
}

/// Copies the defmt stream to the log: through `defmt-print -e ELF` when it
/// is installed, raw (`.defmt` bytes) otherwise.
fn forward_log(mut reader: impl Read, log: Option<&Path>, elf: &Path) {
    let Some(log) = log else {
        let _ = std::io::copy(&mut reader, &mut std::io::sink());
        return;
    };
    let Ok(file) = std::fs::File::create(log) else {
        let _ = std::io::copy(&mut reader, &mut std::io::sink());
        return;
    };
    let printer = Command::new("defmt-print")
        .arg("-e")
        .arg(elf)
        .stdin(Stdio::piped())
        .stdout(Stdio::from(match file.try_clone() {
            Ok(f) => f,
            Err(_) => return,
        }))
        .stderr(Stdio::null())
        .spawn();
    match printer {
        Ok(mut p) => {
            if let Some(mut stdin) = p.stdin.take() {
                let _ = std::io::copy(&mut reader, &mut stdin);
                let _ = stdin.flush();
            }
            let _ = p.wait();
        }
        Err(_) => {
            let mut file = file;
            let _ = std::io::copy(&mut reader, &mut file);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pty_announcements_are_parsed() {
        assert_eq!(
            parse_pty_line("char device redirected to /dev/pts/12 (label serial1)\n"),
            Some((1, "/dev/pts/12".to_string()))
        );
        assert_eq!(parse_pty_line("something else"), None);
    }
}
