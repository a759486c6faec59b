//! The deepest call chain from a function, context by context (an executor's dispatch reaches
//! only the tasks of its context), and the worst case: every context's depth plus a frame per
//! preemption.

use anyhow::{anyhow, bail};
use std::collections::{BTreeMap, BTreeSet, HashMap};

use super::context::{Context, EXCEPTION_FRAME, TASKS};
use super::graph::Graph;
use super::indirect::IndirectKind;
use super::names::short;
use super::report::{ContextDepth, Report};
use crate::Result;

/// The `#[panic_handler]`'s symbol.
const PANIC_HANDLER: &str = "rust_begin_unwind";

/// An embassy task's poll (`TaskStorage<F>::poll`), inside which no executor loop runs.
fn is_task_poll(name: &str) -> bool {
    name.contains("TaskStorage") && name.contains("::poll")
}

/// What a call chain ends in when it leaves the direct-call graph.
#[derive(Clone, Debug)]
enum Next {
    Call(usize),
    Formatting,
}

#[derive(Clone, Debug)]
pub struct Depth {
    pub bytes: u64,
    next: Option<Next>,
}

/// Depth of every function reached from one context: indirect dispatch depends on it.
pub struct Walk<'a> {
    pub graph: &'a Graph,
    pub context: Context,
    pub polls: &'a BTreeMap<&'static str, Vec<usize>>,
    pub formatting: u64,
    /// By function and whether the chain to it runs inside a task's poll (where an executor's
    /// dispatch is never among a shared call's targets).
    pub memo: HashMap<(usize, bool), Depth>,
    pub path: Vec<usize>,
}

impl Walk<'_> {
    /// Whether the chain being walked runs inside a task's poll.
    fn in_task(&self) -> bool {
        self.path.iter().any(|&p| is_task_poll(&self.graph.functions[p].name))
    }

    pub fn depth(&mut self, i: usize) -> Result<Depth> {
        let in_task = self.in_task();
        if let Some(d) = self.memo.get(&(i, in_task)) {
            return Ok(d.clone());
        }
        let g = self.graph;
        let f = &g.functions[i];
        if let Some(pos) = self.path.iter().position(|&p| p == i) {
            let cycle = &self.path[pos..];
            // A panic while panicking (the defmt logger taken re-entrantly): each board's
            // handler checks its own flag first and faults (hardware) or exits (QEMU) without
            // logging, so a second turn stops in the handler
            // and one more turn of the cycle bounds it.
            if cycle.iter().any(|&p| short(&g.functions[p].name).ends_with(PANIC_HANDLER)) {
                return Ok(Depth { bytes: cycle.iter().map(|&p| g.functions[p].frame).sum(), next: None });
            }
            let names: Vec<String> = cycle.iter().chain([&i]).map(|&p| short(&g.functions[p].name)).collect();
            bail!("recursion: {}", names.join(" → "));
        }
        if let Some(insn) = &f.dynamic {
            bail!("{}: dynamic stack allocation (`{insn}`): its depth has no static bound", short(&f.name));
        }
        self.path.push(i);
        let mut targets: Vec<usize> = g.callees[i].clone();
        let mut formatting = false;
        // Inside this function's own poll too, once it is one.
        let in_task_here = in_task || is_task_poll(&f.name);
        for (at, source) in &f.indirect {
            let kinds = g.rules(f, *at, source)?;
            let shared = kinds.len() > 1;
            for kind in kinds {
                match kind {
                    // A call the outliner shared with the executor's loop, reached in a task's poll
                    // or a handler: there it is the other callers' (a waker, defmt), never a
                    // dispatch, which runs only as an executor's loop.
                    IndirectKind::Dispatch if shared && (in_task_here || self.context == Context::Exception) => {}
                    IndirectKind::Dispatch => {
                        if self.context == Context::Exception {
                            bail!("{} at {at:#x}: an executor dispatch outside the executor contexts", short(&f.name));
                        }
                        let context = self.context;
                        targets.extend(TASKS.iter().filter(|t| t.context == context).flat_map(|t| self.polls[t.name].iter().copied()));
                    }
                    IndirectKind::Functions(accepts, what) => targets.extend(g.matching(accepts, what)?),
                    IndirectKind::Formatting => formatting = true,
                }
            }
        }
        let mut best = Depth { bytes: 0, next: None };
        if formatting {
            best = Depth { bytes: self.formatting, next: Some(Next::Formatting) };
        }
        for t in targets {
            let d = self.depth(t)?;
            if d.bytes > best.bytes || best.next.is_none() {
                best = Depth { bytes: d.bytes, next: Some(Next::Call(t)) };
            }
        }
        self.path.pop();
        let d = Depth { bytes: f.frame + best.bytes, next: best.next };
        self.memo.insert((i, in_task), d.clone());
        Ok(d)
    }

    /// `name (frame) → …` down the deepest path from `i`.
    pub fn chain(&self, i: usize) -> String {
        let mut parts = Vec::new();
        let mut at = Some(Next::Call(i));
        let mut in_task = false;
        while let Some(next) = at {
            match next {
                Next::Call(j) => {
                    let f = &self.graph.functions[j];
                    parts.push(format!("{} ({} B)", short(&f.name), f.frame));
                    at = self.memo.get(&(j, in_task)).and_then(|d| d.next.clone());
                    in_task |= is_task_poll(&f.name);
                }
                Next::Formatting => {
                    parts.push(format!("[core::fmt dyn call, bound {} B]", self.formatting));
                    at = None;
                }
            }
        }
        parts.join(" → ")
    }
}

/// The contexts' depths in `graph`; `handlers`: the other exception handlers' addresses.
pub fn worst_case(graph: &Graph, handlers: &[u64], region: u64) -> Result<Report> {
    let polls = graph.task_polls()?;
    let formatting = graph.formatting_bound()?;
    let walk = |context| Walk { graph, context, polls: &polls, formatting, memo: HashMap::new(), path: Vec::new() };
    let mut contexts = Vec::new();
    for context in [Context::Thread, Context::Io, Context::Sample] {
        let root = graph.index(context.root().expect("executor contexts have a root"))?;
        let mut w = walk(context);
        let d = w.depth(root)?;
        contexts.push(ContextDepth { context, bytes: d.bytes, chain: w.chain(root) });
    }
    // The handlers' priorities are not read: each counts as a level of its own (the sum of their
    // depths, a frame each), which holds whatever the NVIC says.
    let mut w = walk(Context::Exception);
    let mut seen = BTreeSet::new();
    let (mut bytes, mut chains) = (0, Vec::new());
    for &h in handlers {
        let i = graph.at(h).ok_or_else(|| anyhow!("exception handler at {h:#x} is not a function start"))?;
        if !seen.insert(i) {
            continue;
        }
        bytes += w.depth(i)?.bytes;
        chains.push(w.chain(i));
    }
    let handler_count = seen.len() as u64;
    contexts.push(ContextDepth { context: Context::Exception, bytes, chain: chains.join(" + ") });
    // I/O over thread, sample over I/O, then each handler over the one below.
    let preemptions = 2 + handler_count;
    let total = contexts.iter().map(|c| c.bytes).sum::<u64>() + preemptions * EXCEPTION_FRAME;
    Ok(Report { contexts, preemptions, total, region })
}
