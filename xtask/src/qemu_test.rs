//! The on-target suite's runner: `cargo xtask qemu-test [--timeout S] ELF
//! [libtest args]`, which `tests/thumb-runner` calls for each embedded-test
//! binary that cargo builds for the Cortex-M4F.
//!
//! It does what `embedded-test-qemu-runner` did, without a `cargo install`:
//! the embedded-test protocol, the test discovery in the ELF and the
//! libtest-style output come from the `embedded-test-runner-core` library;
//! this module is the venue. Each test boots the ELF on QEMU's
//! `netduinoplus2` (an STM32F405) with semihosting carrying the test's
//! invocation (`run_addr <entry>`); the exit code QEMU returns is the test's
//! verdict.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Termination};
use std::time::Duration;

use anyhow::{bail, Result};
use clap::Parser;
use embedded_test_runner_core::process::{self, ProcessStatus};
use embedded_test_runner_core::{elf, CommonArgs, Invocation, Observation, Outcome, TestMeta, Venue};

/// The emulator.
const QEMU: &str = "qemu-system-arm";

/// The board, with no display, monitor or UARTs on the host: a test talks
/// only through semihosting.
const BOARD_ARGS: [&str; 10] = ["-machine", "netduinoplus2", "-display", "none", "-monitor", "none", "-serial", "null", "-serial", "null"];

/// The command line (cargo appends the ELF and libtest's arguments).
#[derive(Parser, Debug)]
#[command(name = "cargo xtask qemu-test", about = "Run an embedded-test binary's tests on QEMU's netduinoplus2 (STM32F405)")]
struct Cli {
    #[command(flatten)]
    common: CommonArgs,
}

/// QEMU booting one ELF, a test at a time.
struct Qemu {
    elf: PathBuf,
}

impl Venue for Qemu {
    fn run(&self, test: TestMeta, timeout: Duration) -> Observation {
        let mut cmd = Command::new(QEMU);
        cmd.args(qemu_args(&self.elf, &test.invocation));
        match process::run(cmd, Some(timeout)) {
            Ok(outcome) => {
                let output = outcome.captured.to_string();
                match outcome.status {
                    ProcessStatus::Exited(code) => Observation::from_exit_code(code, output),
                    ProcessStatus::TimedOut => Observation::TimedOut { after: timeout, output },
                    ProcessStatus::Terminated => Observation::harness_error("QEMU ended without an exit code", &output),
                }
            }
            Err(e) => e.into(),
        }
    }
}

/// QEMU's arguments for one test: the board, the invocation as semihosting
/// arguments, the ELF as the kernel.
fn qemu_args(elf: &Path, invocation: &Invocation) -> Vec<String> {
    let mut args: Vec<String> = BOARD_ARGS.iter().map(|s| s.to_string()).collect();
    args.push("-semihosting-config".into());
    args.push(format!("enable=on,target=native,arg={},arg={}", invocation.command(), invocation.operand()));
    args.push("-kernel".into());
    args.push(elf.display().to_string());
    args
}

/// Runs the tests of the ELF named in `args` (the arguments after
/// `qemu-test`) and exits as libtest would: 0 when all passed, 1 when a test
/// failed, 2 when the runner itself failed.
pub fn main(args: &[String]) -> ExitCode {
    let cli = Cli::parse_from(std::iter::once("cargo xtask qemu-test".to_string()).chain(args.iter().cloned()));
    embedded_test_runner_core::main(|| run(&cli)).report()
}

fn run(cli: &Cli) -> Result<Outcome> {
    if cli.common.debug {
        bail!("a debugger session is not supported here: run the test binary with embedded-test-qemu-runner --gdb PORT --debug");
    }
    if !super::have(QEMU) {
        bail!("{QEMU} is missing: install it (Debian/Ubuntu: apt-get install -y qemu-system-arm), or run `cargo xtask test` as root, which does");
    }
    let tests = elf::discover_tests(&cli.common.elf)?;
    embedded_test_runner_core::run(&cli.common, tests, Qemu { elf: cli.common.elf.clone() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_test_boots_the_elf_with_its_invocation_over_semihosting() {
        let args = qemu_args(Path::new("t.elf"), &Invocation::RunAddr(0x0800_0400));
        assert_eq!(args[..2], ["-machine", "netduinoplus2"]);
        // 0x0800_0400 = 134 218 752: the entry point as embedded-test's runners pass it (decimal).
        assert!(args.contains(&"enable=on,target=native,arg=run_addr,arg=134218752".to_string()), "{args:?}");
        assert_eq!(args[args.len() - 2..], ["-kernel", "t.elf"]);
    }

    #[test]
    fn the_timeout_and_libtest_arguments_are_read() {
        let cli = Cli::parse_from(["x", "--timeout", "60", "target/t", "--exact", "a::b"]);
        assert_eq!(cli.common.timeout, 60);
        assert_eq!(cli.common.elf, PathBuf::from("target/t"));
        assert_eq!(cli.common.libtest, ["--exact", "a::b"]);
    }
}
