//! The worst-case stack of a firmware ELF, by execution context, from its disassembly. Thread
//! mode, the I/O executor, the sample-path executor and each other exception handler preempt one
//! another on the one stack below the statics (flip-link, so that an overflow faults instead of
//! overwriting them); the worst case is each context's deepest call chain plus one exception frame
//! per preemption. Frames come from the prologues, calls from `bl`/`blx` and tail calls, and
//! indirect calls are bounded by the rules of `indirect`, recognised by the source line debug info
//! gives the call. Anything this cannot bound (recursion, sp moved by a register, an indirect call
//! no rule covers) is an error naming the function, not a guess. Bottom up: `context`, `names`,
//! `thumb` (one function's instructions), `graph`, `indirect`, `report`, `walk`, `elf`.

mod context;
mod elf;
mod graph;
mod indirect;
mod names;
mod report;
mod thumb;
mod walk;

#[cfg(test)]
mod tests;

use anyhow::{anyhow, bail};
use std::path::Path;
use std::process::Command;

use crate::{Result, install};

pub use report::Report;

/// The worst case of the ELF at `elf`.
pub fn analyse(elf: &Path) -> Result<Report> {
    let bytes = std::fs::read(elf).map_err(|e| anyhow!("{}: {e}", elf.display()))?;
    let objdump = install::ensure_llvm_objdump()?;
    let out = Command::new(&objdump)
        .args(["-d", "-C", "-l", "--no-show-raw-insn"])
        .arg(elf)
        .output()
        .map_err(|e| anyhow!("cannot run {}: {e}", objdump.display()))?;
    if !out.status.success() {
        bail!("{} -d {} failed: {}", objdump.display(), elf.display(), String::from_utf8_lossy(&out.stderr));
    }
    let graph = graph::Graph::parse(&String::from_utf8_lossy(&out.stdout), &elf::function_sizes(&bytes)?)?;
    let (handlers, region) = elf::vectors_and_region(&bytes, &graph)?;
    walk::worst_case(&graph, &handlers, region)
}
