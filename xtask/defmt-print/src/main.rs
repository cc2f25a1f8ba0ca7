//! `defmt-print -e ELF`: decodes the defmt frames on stdin with the ELF's
//! `.defmt` table and prints one line per log message (`LEVEL message`).
//! `cargo xtask` builds it into `target/tools/debug/` and puts it on the PATH
//! of the QEMU suites, where host-tools' QEMU board finds it by name, so the
//! firmware logs are text without a `cargo install defmt-print`.

use std::io::{Read, Write};

use anyhow::{bail, Context, Result};
use defmt_decoder::{DecodeError, Table};

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let elf = match args.as_slice() {
        [flag, elf] if flag == "-e" => elf,
        _ => bail!("usage: defmt-print -e ELF < frames"),
    };
    let bytes = std::fs::read(elf).with_context(|| format!("reading {elf}"))?;
    let table = Table::parse(&bytes)?.with_context(|| format!("{elf} has no .defmt table"))?;
    let mut decoder = table.new_stream_decoder();
    let (stdin, stdout) = (std::io::stdin(), std::io::stdout());
    let (mut input, mut out) = (stdin.lock(), stdout.lock());
    let mut buf = [0u8; 4096];
    loop {
        let n = input.read(&mut buf)?;
        if n == 0 {
            return Ok(());
        }
        decoder.received(&buf[..n]);
        loop {
            match decoder.decode() {
                Ok(frame) => writeln!(out, "{}", frame.display(false))?,
                Err(DecodeError::UnexpectedEof) => break,
                Err(DecodeError::Malformed) if table.encoding().can_recover() => writeln!(out, "(malformed frame skipped)")?,
                Err(DecodeError::Malformed) => bail!("malformed defmt frame, and this encoding cannot resynchronise"),
            }
        }
        out.flush()?;
    }
}
