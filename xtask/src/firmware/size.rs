//! `cargo xtask size`: flash and static RAM of the release firmware, against the budget, and
//! the worst-case stack against the region the statics leave it.

use anyhow::{anyhow, bail};
use object::{Object, ObjectSection, SectionKind};

use super::{Variant, build, stack};
use crate::Result;

/// The STM32L475VG has 1 MiB of flash and 128 KiB of SRAM; the budget leaves most of both to
/// what a user adds. It holds the estimate's band (its coefficients and polyphase history) and the
/// strip's own hygrometer (its packed model table and running spectrum), with the firmware library
/// and its dependencies built for the least size and a panic handler without `core::fmt`'s writer
/// (`firmware-bin`, src/main.rs says why); none of these changes a number the firmware computes or
/// a speed budget.
const FLASH_BUDGET: u64 = 128 * 1024;
const RAM_BUDGET: u64 = 40 * 1024;
/// Stretch goal: fits the 64 KiB / 16 KiB parts.
const FLASH_STRETCH: u64 = 64 * 1024;
const RAM_STRETCH: u64 = 16 * 1024;
const FLASH_REGION: std::ops::Range<u64> = 0x0800_0000..0x0810_0000;
const RAM_REGIONS: [std::ops::Range<u64>; 2] = [0x2000_0000..0x2001_8000, 0x1000_0000..0x1000_8000];

#[derive(Debug, PartialEq)]
struct Footprint {
    flash: u64,
    /// Statics (.data + .bss + .uninit); the stack takes what is left (flip-link).
    ram: u64,
}

/// Flash = sections placed in flash + the flash copy of .data; RAM = sections placed in RAM.
fn footprint(elf_bytes: &[u8]) -> Result<Footprint> {
    let file = object::File::parse(elf_bytes).map_err(|e| anyhow!("not an ELF file: {e}"))?;
    let mut fp = Footprint { flash: 0, ram: 0 };
    for s in file.sections() {
        // Sections that are not loaded (debug info, defmt's symbol table) sit at address 0,
        // outside both regions.
        let addr = s.address();
        if FLASH_REGION.contains(&addr) {
            fp.flash += s.size();
        } else if RAM_REGIONS.iter().any(|r| r.contains(&addr)) {
            fp.ram += s.size();
            // Initialised data is stored in flash and copied at start-up.
            if s.kind() != SectionKind::UninitializedData {
                fp.flash += s.size();
            }
        }
    }
    Ok(fp)
}

pub fn command() -> Result<()> {
    let mut over = Vec::new();
    for variant in Variant::ALL {
        let elf = build(variant)?;
        let bytes = std::fs::read(&elf).map_err(|e| anyhow!("{}: {e}", elf.display()))?;
        let fp = footprint(&bytes)?;
        let kib = |b: u64| b as f64 / 1024.0;
        println!(
            "{:>14}: flash {:7.1} KiB / {} KiB ({:4.1} %), RAM {:6.1} KiB / {} KiB ({:4.1} %){}",
            variant.name(),
            kib(fp.flash),
            FLASH_BUDGET / 1024,
            100.0 * fp.flash as f64 / FLASH_BUDGET as f64,
            kib(fp.ram),
            RAM_BUDGET / 1024,
            100.0 * fp.ram as f64 / RAM_BUDGET as f64,
            if fp.flash <= FLASH_STRETCH && fp.ram <= RAM_STRETCH { "  (within the 64/16 KiB stretch)" } else { "" }
        );
        if fp.flash > FLASH_BUDGET || fp.ram > RAM_BUDGET {
            over.push(variant.name());
        }
        let report = stack::analyse(&elf)?;
        println!("{report}");
        if report.over() {
            over.push(variant.name());
        }
    }
    if over.is_empty() { Ok(()) } else { Err(anyhow!("over the size or stack budget: {}", over.join(", "))) }
}

/// The test step: flash and static RAM of each variant as the build step left it within the
/// budget, and the worst-case stack within what the statics leave.
pub fn within_budget() -> Result<()> {
    let mut over = Vec::new();
    for v in Variant::ALL {
        let bytes = std::fs::read(v.elf()).map_err(|e| anyhow!("{} (build step failed?): {e}", v.elf().display()))?;
        let fp = footprint(&bytes)?;
        println!("{}: flash {} B, RAM {} B", v.name(), fp.flash, fp.ram);
        if fp.flash > FLASH_BUDGET || fp.ram > RAM_BUDGET {
            bail!("{} over budget: {fp:?}", v.name());
        }
        let report = stack::analyse(&v.elf())?;
        println!("{report}");
        if report.over() {
            over.push(v.name());
        }
    }
    if over.is_empty() { Ok(()) } else { Err(anyhow!("worst-case stack over the stack region: {}", over.join(", "))) }
}
