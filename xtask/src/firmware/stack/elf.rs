//! What the ELF itself says: the exception handlers of the vector table, the stack region below
//! the statics, and each function symbol's size.

use anyhow::anyhow;
use object::{Object, ObjectSection, ObjectSymbol};
use std::collections::HashMap;

use super::context::Context;
use super::graph::Graph;
use crate::Result;

const RAM: std::ops::Range<u64> = 0x2000_0000..0x2001_8000;

/// The exception handlers of the vector table but Reset (thread mode) and the executors'
/// interrupts (their own contexts), and the stack region below the statics.
pub fn vectors_and_region(elf_bytes: &[u8], graph: &Graph) -> Result<(Vec<u64>, u64)> {
    let file = object::File::parse(elf_bytes).map_err(|e| anyhow!("not an ELF file: {e}"))?;
    let table = file.section_by_name(".vector_table").ok_or_else(|| anyhow!("no .vector_table section"))?;
    let data = table.data().map_err(|e| anyhow!(".vector_table: {e}"))?;
    let executors: Vec<usize> = [Context::Io, Context::Sample]
        .iter()
        .map(|c| graph.index(c.root().expect("executor contexts have a root")))
        .collect::<Result<_>>()?;
    let mut handlers = Vec::new();
    // Word 0 is the initial stack pointer, word 1 Reset.
    for word in data.chunks_exact(4).skip(2) {
        let addr = u64::from(u32::from_le_bytes(word.try_into().expect("4 bytes")));
        if addr == 0 || graph.at(addr).is_some_and(|i| executors.contains(&i)) {
            continue;
        }
        handlers.push(addr & !1);
    }
    let lowest = file.sections().filter(|s| RAM.contains(&s.address()) && s.size() > 0).map(|s| s.address()).min();
    let lowest = lowest.ok_or_else(|| anyhow!("no section in RAM"))?;
    Ok((handlers, lowest - RAM.start))
}

/// Start (without the Thumb bit) → size of every function symbol that has one.
pub fn function_sizes(elf_bytes: &[u8]) -> Result<HashMap<u64, u64>> {
    let file = object::File::parse(elf_bytes).map_err(|e| anyhow!("not an ELF file: {e}"))?;
    let mut sizes = HashMap::new();
    for sym in file.symbols().filter(|s| s.kind() == object::SymbolKind::Text && s.size() > 0) {
        let size = sizes.entry(sym.address() & !1).or_insert(0);
        *size = sym.size().max(*size);
    }
    Ok(sizes)
}
