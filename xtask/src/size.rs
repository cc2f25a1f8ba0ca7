//! Flash and RAM use of the firmware ELF, from its section headers.

use std::path::Path;

use anyhow::{bail, Context, Result};
use object::{Object, ObjectSection, SectionFlags};

/// The firmware's flash budget on the STM32F405: 80 KiB (the
/// application sectors hold 128 KiB beside the coefficient store's). The
/// image is 75 636 B with the integrity monitor, NMEA, the wire's endpoint
/// table and the stored calibration's re-check while an on-line hard iron is
/// applied (72 836 B before the last two). The size gate fails above it.
pub const FLASH_BUDGET_BYTES: u64 = 80 * 1024;
/// RAM budget (statics; the stack takes what is left of the 128 KiB SRAM).
pub const RAM_BUDGET_BYTES: u64 = 64 * 1024;

const FLASH: std::ops::Range<u64> = 0x0800_0000..0x0810_0000;
const RAM: std::ops::Range<u64> = 0x2000_0000..0x2002_0000;

/// Bytes the image occupies.
#[derive(Debug, Clone, Copy)]
pub struct Usage {
    /// Flash: code, read-only data, vector table and `.data`'s initial image.
    pub flash_bytes: u64,
    /// RAM: `.data`, `.bss` and `.uninit` (static allocation, no stack).
    pub ram_bytes: u64,
}

impl Usage {
    /// Prints the report.
    pub fn print(&self) {
        eprintln!(
            "   firmware (board release build): flash {} B ({:.1} KiB of {} KiB budget), static RAM {} B ({:.1} KiB of {} KiB budget)",
            self.flash_bytes,
            self.flash_bytes as f64 / 1024.0,
            FLASH_BUDGET_BYTES / 1024,
            self.ram_bytes,
            self.ram_bytes as f64 / 1024.0,
            RAM_BUDGET_BYTES / 1024
        );
    }

    /// Fails when over budget.
    pub fn check_budget(&self) -> Result<()> {
        if self.flash_bytes > FLASH_BUDGET_BYTES || self.ram_bytes > RAM_BUDGET_BYTES {
            bail!("firmware over budget: {self:?}");
        }
        Ok(())
    }
}

/// Measures an ELF.
pub fn measure(elf: &Path) -> Result<Usage> {
    let data = std::fs::read(elf).with_context(|| format!("reading {}", elf.display()))?;
    let file = object::File::parse(&*data).context("parsing the firmware ELF")?;
    let (mut flash, mut ram) = (0, 0);
    for s in file.sections() {
        let alloc = matches!(s.flags(), SectionFlags::Elf { sh_flags, .. } if sh_flags.contains(object::elf::SHF_ALLOC));
        if !alloc || s.size() == 0 {
            continue;
        }
        let name = s.name().unwrap_or("");
        if FLASH.contains(&s.address()) {
            flash += s.size();
        } else if RAM.contains(&s.address()) {
            ram += s.size();
            if name == ".data" {
                flash += s.size(); // its initial values live in flash
            }
        }
    }
    Ok(Usage { flash_bytes: flash, ram_bytes: ram })
}
