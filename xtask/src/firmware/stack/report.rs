//! The worst case, context by context with its deepest chain, and the sum against the stack
//! region, as `cargo xtask size` prints it.

use std::fmt;

use super::context::{Context, EXCEPTION_FRAME};

#[derive(Debug)]
pub struct ContextDepth {
    pub context: Context,
    pub bytes: u64,
    /// The deepest chain (one line per handler for the exceptions).
    pub chain: String,
}

#[derive(Debug)]
pub struct Report {
    pub contexts: Vec<ContextDepth>,
    /// Preemptions counted (each pushes an [`EXCEPTION_FRAME`]).
    pub preemptions: u64,
    pub total: u64,
    pub region: u64,
}

impl Report {
    pub fn over(&self) -> bool {
        self.total > self.region
    }
}

fn kib(b: u64) -> String {
    format!("{:.1} KiB", b as f64 / 1024.0)
}

impl fmt::Display for Report {
    fn fmt(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        for c in &self.contexts {
            writeln!(out, "  {:>10} {:>7} B  {}", c.context.name(), c.bytes, c.chain)?;
        }
        writeln!(
            out,
            "  {:>10} {:>7} B  {} preemptions × {EXCEPTION_FRAME} B (FPU extended frame)",
            "frames",
            self.preemptions * EXCEPTION_FRAME,
            self.preemptions
        )?;
        let parts: Vec<String> = self.contexts.iter().map(|c| format!("{} {}", c.context.name(), kib(c.bytes))).collect();
        write!(
            out,
            "  stack worst case: {}, frames {}: {} ({} B) of {} ({} B) — {}",
            parts.join(", "),
            kib(self.preemptions * EXCEPTION_FRAME),
            kib(self.total),
            self.total,
            kib(self.region),
            self.region,
            if self.over() { "OVER" } else { "fits" }
        )
    }
}
