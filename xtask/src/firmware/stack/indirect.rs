//! What an indirect call may call: the rules, by the source file of the call, that bound each
//! kind; the task polls an executor's dispatch resolves to; and the bound of formatting's calls.

use anyhow::{anyhow, bail};
use std::collections::{BTreeMap, BTreeSet};

use super::context::{TASKS, Task};
use super::graph::Graph;
use super::names::short;
use super::thumb::Function;
use crate::Result;

#[derive(Clone, Copy)]
pub enum IndirectKind {
    /// An executor calling a task's `poll_fn`.
    Dispatch,
    /// One of the functions whose (short) name the predicate accepts; the text names them.
    Functions(fn(&str) -> bool, &'static str),
    /// `core::fmt`'s `dyn Write` and `Display`/`Debug` calls.
    Formatting,
}

/// What an indirect call calls, from the source file debug info gives it. Each rule is sound
/// for the code it names, not for indirect calls in general:
/// - embassy-executor's raw/mod.rs: its only indirect call is the run queue calling
///   `task.poll_fn`, which spawn set to the `TaskStorage<F>::poll` of that task; a context's
///   executor runs only the tasks spawned on it, so the call resolves to those polls. Its
///   raw/run_queue.rs too: the queue's loop calls what it is handed in line, so the only
///   indirect call within it is that one (found there when outlined, see `outlined_rule`).
/// - core's task/wake.rs: `Waker` methods call through the `RawWakerVTable`. Every task runs on
///   an embassy executor, whose wakers all come from `embassy_executor::raw::waker`; so the
///   deepest of those functions bounds the call.
/// - defmt-rtt's channel.rs: `write_all` calls the blocking or the non-blocking write through a
///   function pointer it chose from the two.
/// - core's fmt/: formatting calls `dyn Write` and the `Display`/`Debug` impls; it runs only on
///   panic paths (defmt logs without core::fmt). Bounded by [`Graph::formatting_bound`].
fn indirect_rule(source: &str) -> Option<IndirectKind> {
    if source.contains("embassy-executor") && (source.ends_with("/src/raw/mod.rs") || source.ends_with("/src/raw/run_queue.rs")) {
        Some(IndirectKind::Dispatch)
    } else if source.ends_with("/core/src/task/wake.rs") {
        Some(IndirectKind::Functions(|name| name.contains("embassy_executor::raw::waker::"), "embassy_executor::raw::waker::*"))
    } else if source.contains("defmt-rtt") && source.ends_with("/src/channel.rs") {
        Some(IndirectKind::Functions(
            |name| name.contains("defmt_rtt::channel::Channel::") && name.ends_with("blocking_write"),
            "defmt_rtt::channel::Channel::{blocking_write, nonblocking_write}",
        ))
    } else if source.contains("/defmt-") && source.ends_with("/src/export/mod.rs") {
        // Built for the least size, defmt's encoders call the logger's `extern` functions through
        // a register loaded with their address, once per function.
        Some(IndirectKind::Functions(
            |name| matches!(name, "_defmt_write" | "_defmt_acquire" | "_defmt_release"),
            "_defmt_{write, acquire, release}",
        ))
    } else if source.contains("/core/src/fmt/") {
        Some(IndirectKind::Formatting)
    } else {
        None
    }
}

impl Graph {
    /// The `TaskStorage<F>::poll` of each task, by the task's closure it calls or the task's
    /// source lines inlined into it. A poll that matches several tasks counts for each of them.
    pub fn task_polls(&self) -> Result<BTreeMap<&'static str, Vec<usize>>> {
        let mut polls: BTreeMap<&str, Vec<usize>> = TASKS.iter().map(|t| (t.name, Vec::new())).collect();
        for (i, f) in self.functions.iter().enumerate() {
            if !(f.name.contains("TaskStorage") && f.name.contains("::poll")) {
                continue;
            }
            let closure_called = |t: &Task| self.callees[i].iter().any(|&c| self.functions[c].name.contains(&format!("__{}_task", t.name)));
            let matched: Vec<&Task> =
                TASKS.iter().filter(|t| closure_called(t) || f.sources.iter().any(|s| s.ends_with(&format!("/{}", t.source)))).collect();
            if matched.is_empty() {
                bail!("{} at {:#x}: a task poll of no known task (add it to stack/context.rs's TASKS)", short(&f.name), f.start);
            }
            for t in matched {
                polls.get_mut(t.name).expect("every task has an entry").push(i);
            }
        }
        let built_everywhere = |name: &str| TASKS.iter().any(|t| t.name == name && !t.hardware_only);
        if let Some((task, _)) = polls.iter().find(|(name, p)| p.is_empty() && built_everywhere(name)) {
            bail!("no TaskStorage::poll found for task {task}");
        }
        Ok(polls)
    }

    /// Formatting calls back and forth between `core::fmt::write`, the impls and `dyn Write`
    /// through pointers: the set of everything reachable from a function named `fmt`, closed
    /// under direct calls, holds every target. A chain that enters none of them twice is
    /// bounded by the sum of all their frames, which is what this returns. Formatting that
    /// re-enters itself (a `Display` impl writing another through `write!`) could go deeper;
    /// the impls linked here do not, and formatting runs only on panic paths.
    pub fn formatting_bound(&self) -> Result<u64> {
        let mut seen: BTreeSet<usize> = (0..self.functions.len()).filter(|&i| short(&self.functions[i].name).contains("fmt")).collect();
        let mut todo: Vec<usize> = seen.iter().copied().collect();
        let mut total = 0;
        while let Some(i) = todo.pop() {
            let f = &self.functions[i];
            if let Some(insn) = &f.dynamic {
                bail!("{}: dynamic stack allocation (`{insn}`)", short(&f.name));
            }
            total += f.frame;
            let mut next = self.callees[i].clone();
            for (at, source) in &f.indirect {
                let kinds = self.rules(f, *at, source)?;
                let shared = kinds.len() > 1;
                for kind in kinds {
                    match kind {
                        IndirectKind::Formatting => {}
                        IndirectKind::Functions(accepts, what) => next.extend(self.matching(accepts, what)?),
                        // Formatting runs inside a task or a handler, never as the executor's loop.
                        IndirectKind::Dispatch if shared => {}
                        IndirectKind::Dispatch => bail!("{} at {at:#x}: an executor dispatch reached from formatting", short(&f.name)),
                    }
                }
            }
            for c in next {
                if seen.insert(c) {
                    todo.push(c);
                }
            }
        }
        Ok(total)
    }

    /// What an indirect call may call: its source's rule, or for a call the machine outliner
    /// shared between callers of several rules, each of theirs ([`Self::outlined_rules`]; more
    /// than one: the walk takes an executor's dispatch among them only where one can be).
    pub fn rules(&self, f: &Function, at: u64, source: &Option<String>) -> Result<Vec<IndirectKind>> {
        if source.is_none() && f.name.starts_with("OUTLINED_FUNCTION_") {
            return self.outlined_rules(f, at);
        }
        let rule = source.as_deref().and_then(indirect_rule).ok_or_else(|| {
            anyhow!(
                "{} at {at:#x}: indirect call matches no rule of stack/indirect.rs (source {})",
                short(&f.name),
                source.as_deref().unwrap_or("unknown")
            )
        })?;
        Ok(vec![rule])
    }

    /// LLVM's machine outliner (code built for the least size) moves a sequence that several
    /// places share into an `OUTLINED_FUNCTION_n` of its own, with no line of source: an indirect
    /// call there is its callers' (defmt-rtt's channel write, an executor's dispatch, a waker),
    /// ruled by the sources among theirs that a rule names. Where they name several (the same
    /// instructions shared by defmt's encoders, the executor's loop and a waker's call), the call
    /// is one of theirs: every one of their rules together bounds it.
    fn outlined_rules(&self, f: &Function, at: u64) -> Result<Vec<IndirectKind>> {
        let me = self.index(&f.name)?;
        let ruled: BTreeSet<&str> = (0..self.functions.len())
            .filter(|&c| self.callees[c].contains(&me))
            .flat_map(|c| self.functions[c].sources.iter().map(String::as_str))
            .filter(|s| indirect_rule(s).is_some())
            .collect();
        if ruled.is_empty() {
            bail!("{} at {at:#x}: an outlined indirect call whose callers' sources name no rule of stack/indirect.rs", f.name);
        }
        Ok(ruled.into_iter().filter_map(indirect_rule).collect())
    }

    pub fn matching(&self, accepts: fn(&str) -> bool, what: &str) -> Result<Vec<usize>> {
        let found: Vec<usize> = (0..self.functions.len()).filter(|&i| accepts(&short(&self.functions[i].name))).collect();
        if found.is_empty() {
            bail!("no function {what} to bound an indirect call by");
        }
        Ok(found)
    }
}
