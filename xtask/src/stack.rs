//! The worst-case stack of a firmware ELF, by execution context, from its disassembly.
//!
//! Contexts nest on the one stack (flip-link puts it below the statics, so an overflow faults
//! instead of overwriting them): thread mode, preempted by the I/O interrupt executor, preempted
//! by the sample-path executor, preempted by the other exception handlers. The worst case is
//! the sum of each context's deepest call chain plus one exception frame per preemption.
//!
//! Frames come from the prologues (`push`, `vpush`, `sub sp`), calls from `bl`/`blx` and from
//! branches that leave their function (tail calls). Indirect calls are bounded by the rules of
//! [`indirect_rule`], recognised by the source line that debug info gives the call (release
//! builds keep debug info). Anything this cannot bound (recursion, an sp moved by a register, an
//! indirect call no rule covers) is an error naming the function, not a guess.
//!
//! The exception handlers' priorities are not read: each handler counts as a level of its own
//! (the sum of their depths, a frame each), which holds whatever the NVIC says.

use anyhow::{anyhow, bail};
use object::{Object, ObjectSection, ObjectSymbol};
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt;
use std::path::Path;
use std::process::Command;

use crate::{Result, install};

/// Cortex-M4F with the FPU in use: the extended frame (8 core + 17 FPU words, 1 reserved,
/// aligned to 8) is what each preemption pushes.
const EXCEPTION_FRAME: u64 = 104;
const RAM: std::ops::Range<u64> = 0x2000_0000..0x2001_8000;

/// Where a task's code runs. The executors: src/main.rs spawns each task on one of them, and
/// src/board/executors.rs binds the two interrupt executors to UART4 (sample) and UART5 (I/O).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Context {
    Thread,
    Io,
    Sample,
    /// The other exception handlers: no executor runs there.
    Exception,
}

impl Context {
    /// The function where the context starts (cortex-m-rt's `main` calls the thread executor).
    fn root(self) -> Option<&'static str> {
        match self {
            Context::Thread => Some("main"),
            Context::Io => Some("UART5"),
            Context::Sample => Some("UART4"),
            Context::Exception => None,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Context::Thread => "thread",
            Context::Io => "io",
            Context::Sample => "sample",
            Context::Exception => "exceptions",
        }
    }
}

struct Task {
    name: &'static str,
    /// The file of the task's `async fn`, relative to the firmware crate: the closure is usually
    /// inlined into its `TaskStorage::poll`, leaving only its source lines to name it.
    source: &'static str,
    context: Context,
}

/// Which executor polls which task (src/main.rs spawns them; src/board/executors.rs).
const TASKS: [Task; 5] = [
    Task { name: "sample_task", source: "src/app/sample_path.rs", context: Context::Sample },
    Task { name: "humidity_task", source: "src/app/humidity.rs", context: Context::Io },
    Task { name: "report_task", source: "src/app/report.rs", context: Context::Io },
    Task { name: "retune_task", source: "src/app/retune.rs", context: Context::Thread },
    Task { name: "fit_task", source: "src/app/hygrometer.rs", context: Context::Thread },
];

#[derive(Clone, Copy)]
enum IndirectKind {
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

#[derive(Debug, Default)]
struct Function {
    name: String,
    start: u64,
    /// From the symbol's size: what follows is alignment padding, which may decode as anything.
    end: Option<u64>,
    instructions: usize,
    /// Bytes the prologue and body move sp down by.
    frame: u64,
    /// `bl`/`blx` targets and branches (resolved to tail calls once every function is known).
    calls: Vec<u64>,
    /// Calls through a register loaded from a literal pool: (where, the literal's address).
    literal_calls: Vec<(u64, u64)>,
    branches: Vec<u64>,
    /// Indirect calls: (address, source file of the line).
    indirect: Vec<(u64, Option<String>)>,
    /// Every source file the line info names in this function (inlined code included).
    sources: BTreeSet<String>,
    /// An instruction that moves sp by an amount known only at run time.
    dynamic: Option<String>,
}

/// The disassembly as functions, in address order.
#[derive(Debug)]
pub struct Graph {
    functions: Vec<Function>,
    /// Direct callees (calls and tail calls) of each function, by index.
    callees: Vec<Vec<usize>>,
    by_name: HashMap<String, usize>,
}

fn parse_imm(s: &str) -> Option<u64> {
    let s = s.trim().trim_start_matches('#');
    let (neg, s) = match s.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, s),
    };
    let v = match s.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16).ok()?,
        None => s.parse().ok()?,
    };
    Some(if neg { v.wrapping_neg() } else { v })
}

/// Bytes of a register list `{r4, r5, lr}`, `{r4-r7}`, `{d8, d9}`, `{s16-s17}`.
fn register_list_bytes(ops: &str) -> Result<u64> {
    let inner =
        ops.split_once('{').and_then(|(_, r)| r.split_once('}')).map(|(l, _)| l).ok_or_else(|| anyhow!("no register list in `{ops}`"))?;
    let mut bytes = 0;
    for reg in inner.split(',').map(str::trim).filter(|r| !r.is_empty()) {
        let size = if reg.starts_with('d') { 8 } else { 4 };
        let count = match reg.split_once('-') {
            Some((lo, hi)) => {
                let n = |r: &str| r.trim().trim_start_matches(|c: char| c.is_ascii_alphabetic()).parse::<u64>();
                match (n(lo), n(hi)) {
                    (Ok(lo), Ok(hi)) if hi >= lo => hi - lo + 1,
                    _ => bail!("register range `{reg}` in `{ops}`"),
                }
            }
            None => 1,
        };
        bytes += size * count;
    }
    Ok(bytes)
}

const CONDITIONS: [&str; 16] = ["eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le"];

/// `base` or `base` + a condition code (IT blocks and conditional branches).
fn is(mnemonic: &str, base: &str) -> bool {
    mnemonic.strip_prefix(base).is_some_and(|cc| cc.is_empty() || cc == "al" || CONDITIONS.contains(&cc))
}

impl Function {
    fn instruction(&mut self, mnemonic: &str, ops: &str, source: Option<&String>) -> Result<()> {
        self.instructions += 1;
        let m = mnemonic.trim_end_matches(".w").trim_end_matches(".n");
        let target = ops.split_whitespace().next().and_then(|t| t.strip_prefix("0x")).and_then(|h| u64::from_str_radix(h, 16).ok());
        let first = ops.split(',').next().unwrap_or("").trim();
        let dynamic = |f: &mut Function| {
            f.dynamic.get_or_insert_with(|| format!("{mnemonic} {ops}"));
        };
        if m == "push" || m == "vpush" || ((m == "stmdb" || m == "vstmdb") && first == "sp!") {
            self.frame += register_list_bytes(ops)?;
        } else if (is(m, "bl") || is(m, "blx")) && target.is_some() {
            self.calls.extend(target);
        } else if is(m, "blx") || is(m, "bx") && first != "lr" {
            self.indirect.push((0, source.cloned()));
        } else if is(m, "b") || m == "cbz" || m == "cbnz" {
            // cbz/cbnz name the register first, the target second.
            let t = if m.starts_with("cb") { ops.split(',').nth(1).and_then(|t| parse_imm(t.split_whitespace().next()?)) } else { target };
            self.branches.extend(t);
        } else if first == "pc" && m != "pop" {
            // `ldr pc, [sp], #4` is a one-register pop; anything else writing pc jumps indirectly.
            if !(m == "ldr" && ops.contains("[sp]")) {
                self.indirect.push((0, source.cloned()));
            }
        } else if first == "sp" && !(m.starts_with("st") || m.starts_with("vst") || matches!(m, "cmp" | "cmn" | "tst" | "teq")) {
            // Stores and compares read sp; everything else named sp first writes it.
            let rest: Vec<&str> = ops.split(',').map(str::trim).collect();
            // In an IT block an instruction carries its condition (`addlo`): on the path that
            // skips it sp is as before, so counting it as if it always ran (an allocation) or
            // never ran (a release) bounds the depth from above either way.
            let m = without_condition(m);
            match (m, rest.as_slice()) {
                ("sub" | "subw", ["sp", imm] | ["sp", "sp", imm]) if imm.starts_with('#') => {
                    self.frame += parse_imm(imm).ok_or_else(|| anyhow!("immediate in `{mnemonic} {ops}`"))?
                }
                // Restoring sp from the frame pointer, or releasing the frame.
                ("sub" | "subw", ["sp", base, imm]) if *base != "sp" && imm.starts_with('#') => {}
                ("add" | "addw", _) => {}
                _ => dynamic(self),
            }
        } else if m.starts_with("str") && ops.contains("[sp, #-") && ops.ends_with("]!") {
            // `str r8, [sp, #-4]!`: a push of its own.
            let imm = ops
                .rsplit_once("#-")
                .and_then(|(_, r)| parse_imm(r.trim_end_matches("]!")))
                .ok_or_else(|| anyhow!("`{mnemonic} {ops}`"))?;
            self.frame += imm;
        }
        Ok(())
    }
}

/// Built for the least size, a function that calls another several times loads its address from
/// a literal pool into a register once and calls through that (`ldr r8, [pc, #80]` … `blx r8`):
/// such a call is a direct one, resolved once the pools' words are read. Tracks the registers
/// loaded so in `loaded`, forgetting one when an instruction writes it (or a call may), in
/// address order: LLVM loads the register in the function's entry and keeps it, a callee-saved
/// one, for the calls. Returns whether the instruction was such a call (recorded in `f`).
fn literal_call(f: &mut Function, loaded: &mut HashMap<String, u64>, at: u64, mnemonic: &str, ops: &str, all: &str) -> bool {
    let m = mnemonic.trim_end_matches(".w").trim_end_matches(".n");
    let first = ops.split(',').next().unwrap_or("").trim();
    if (is(m, "blx") || is(m, "bx"))
        && let Some(&literal) = loaded.get(first)
    {
        f.literal_calls.push((at, literal));
        f.instructions += 1;
        return true;
    }
    if m == "ldr"
        && ops.contains("[pc, #")
        && let Some(literal) = all.split(" @ 0x").nth(1).and_then(|r| u64::from_str_radix(r.split_whitespace().next()?, 16).ok())
    {
        loaded.insert(first.to_string(), literal);
        return false;
    }
    if is(m, "bl") || is(m, "blx") {
        for r in ["r0", "r1", "r2", "r3", "r12", "lr"] {
            loaded.remove(r);
        }
    } else if m == "pop" || m.starts_with("ldm") {
        loaded.retain(|r, _| !ops.contains(r.as_str()));
    } else if !(m.starts_with("st")
        || m.starts_with("vst")
        || m.starts_with("push")
        || m.starts_with("it")
        || matches!(m, "cmp" | "cmn" | "tst" | "teq"))
    {
        loaded.remove(first);
    }
    false
}

/// `m` without an IT block's condition suffix (`addlo` → `add`), for the instructions that
/// write sp.
fn without_condition(m: &str) -> &str {
    const CONDITIONS: [&str; 16] = ["eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le"];
    for stem in ["add", "addw", "sub", "subw"] {
        if let Some(c) = m.strip_prefix(stem)
            && CONDITIONS.contains(&c)
        {
            return stem;
        }
    }
    m
}

impl Graph {
    /// Parses `llvm-objdump -d -l --no-show-raw-insn` output; `sizes`: function start → size.
    pub fn parse(text: &str, sizes: &HashMap<u64, u64>) -> Result<Graph> {
        let mut functions: Vec<Function> = Vec::new();
        let mut source: Option<String> = None;
        // The literal pools' words, and the registers last loaded from one in this function.
        let mut words: HashMap<u64, u64> = HashMap::new();
        let mut loaded: HashMap<String, u64> = HashMap::new();
        for line in text.lines() {
            if let Some((addr, name)) = label(line) {
                // Mapping symbols ($t, $d, $a) mark code and data inside a function.
                if name.starts_with('$') {
                    continue;
                }
                let end = sizes.get(&addr).map(|size| addr + size);
                functions.push(Function { name: name.to_string(), start: addr, end, ..Function::default() });
                source = None;
                loaded.clear();
                continue;
            }
            if let Some(path) = line.strip_prefix("; /").or_else(|| line.strip_prefix("; ")).filter(|l| l.contains(".rs:")) {
                let file = path.rsplit_once(".rs:").map(|(f, _)| format!("/{f}.rs")).unwrap_or_default();
                if let Some(f) = functions.last_mut() {
                    f.sources.insert(file.clone());
                }
                source = Some(file);
                continue;
            }
            let Some((addr, rest)) = line.trim_start().split_once(':') else { continue };
            let Ok(at) = u64::from_str_radix(addr, 16) else { continue };
            let fields: Vec<&str> = rest.split('\t').collect();
            let (Some(f), Some(mnemonic)) = (functions.last_mut(), fields.get(1).map(|m| m.trim())) else { continue };
            if mnemonic == ".word"
                && let Some(v) = fields.get(2).and_then(|v| v.trim().strip_prefix("0x")).and_then(|h| u64::from_str_radix(h, 16).ok())
            {
                words.insert(at, v);
            }
            if f.end.is_some_and(|end| at >= end) {
                continue;
            }
            // Literal pools (`.word`) and undecodable bytes.
            if mnemonic.is_empty() || mnemonic.starts_with('.') || mnemonic.starts_with('<') {
                continue;
            }
            let all = fields[2..].join("\t");
            let ops = all.split(" @").next().unwrap_or("").split("\t@").next().unwrap_or("").trim();
            if literal_call(f, &mut loaded, at, mnemonic, ops, &all) {
                continue;
            }
            f.instruction(mnemonic, ops, source.as_ref()).map_err(|e| anyhow!("{} at {at:#x}: {e}", f.name))?;
            if let Some(last) = f.indirect.last_mut().filter(|i| i.0 == 0) {
                last.0 = at;
            }
        }
        // Labels with no code of their own are aliases of what follows.
        functions.retain(|f| f.instructions > 0);
        if functions.is_empty() {
            bail!("no functions in the disassembly");
        }
        let starts: Vec<u64> = functions.iter().map(|f| f.start).collect();
        let containing = |addr: u64| starts.partition_point(|&s| s <= addr).checked_sub(1);
        let mut callees = Vec::new();
        for (i, f) in functions.iter().enumerate() {
            let mut c = BTreeSet::new();
            for &t in &f.calls {
                c.insert(containing(t).ok_or_else(|| anyhow!("{}: call to {t:#x}, outside every function", f.name))?);
            }
            for &(at, literal) in &f.literal_calls {
                let target = words.get(&literal).map(|w| w & !1);
                match target.and_then(|t| starts.binary_search(&t).ok()) {
                    Some(j) => c.insert(j),
                    None => bail!("{} at {at:#x}: a call through the literal at {literal:#x}, which is no function's address", f.name),
                };
            }
            // A branch out of the function is a tail call (to a start) or a jump into shared code;
            // either way the function holding the target runs on this frame's behalf.
            for &t in &f.branches {
                if let Some(j) = containing(t).filter(|&j| j != i) {
                    c.insert(j);
                }
            }
            callees.push(c.into_iter().collect());
        }
        let by_name = functions.iter().enumerate().map(|(i, f)| (f.name.clone(), i)).collect();
        Ok(Graph { functions, callees, by_name })
    }

    fn index(&self, name: &str) -> Result<usize> {
        self.by_name.get(name).copied().ok_or_else(|| anyhow!("no function `{name}` in the disassembly"))
    }

    fn at(&self, addr: u64) -> Option<usize> {
        self.functions.iter().position(|f| f.start == addr & !1)
    }

    /// The `TaskStorage<F>::poll` of each task, by the task's closure it calls or the task's
    /// source lines inlined into it. A poll that matches several tasks counts for each of them.
    fn task_polls(&self) -> Result<BTreeMap<&'static str, Vec<usize>>> {
        let mut polls: BTreeMap<&str, Vec<usize>> = TASKS.iter().map(|t| (t.name, Vec::new())).collect();
        for (i, f) in self.functions.iter().enumerate() {
            if !(f.name.contains("TaskStorage") && f.name.contains("::poll")) {
                continue;
            }
            let closure_called = |t: &Task| self.callees[i].iter().any(|&c| self.functions[c].name.contains(&format!("__{}_task", t.name)));
            let matched: Vec<&Task> =
                TASKS.iter().filter(|t| closure_called(t) || f.sources.iter().any(|s| s.ends_with(&format!("/{}", t.source)))).collect();
            if matched.is_empty() {
                bail!("{} at {:#x}: a task poll of no known task (add it to stack.rs's TASKS)", short(&f.name), f.start);
            }
            for t in matched {
                polls.get_mut(t.name).expect("every task has an entry").push(i);
            }
        }
        if let Some((task, _)) = polls.iter().find(|(_, p)| p.is_empty()) {
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
    fn formatting_bound(&self) -> Result<u64> {
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
                match self.rule(f, *at, source)? {
                    IndirectKind::Formatting => {}
                    IndirectKind::Functions(accepts, what) => next.extend(self.matching(accepts, what)?),
                    IndirectKind::Dispatch => bail!("{} at {at:#x}: an executor dispatch reached from formatting", short(&f.name)),
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

    fn rule(&self, f: &Function, at: u64, source: &Option<String>) -> Result<IndirectKind> {
        if source.is_none() && f.name.starts_with("OUTLINED_FUNCTION_") {
            return self.outlined_rule(f, at);
        }
        source.as_deref().and_then(indirect_rule).ok_or_else(|| {
            anyhow!(
                "{} at {at:#x}: indirect call matches no rule of stack.rs (source {})",
                short(&f.name),
                source.as_deref().unwrap_or("unknown")
            )
        })
    }

    /// LLVM's machine outliner (code built for the least size) moves a sequence that several
    /// places share into an `OUTLINED_FUNCTION_n` of its own, with no line of source: an indirect
    /// call there is its callers' (defmt-rtt's channel write, an executor's dispatch), ruled by
    /// the one source among theirs that a rule names.
    fn outlined_rule(&self, f: &Function, at: u64) -> Result<IndirectKind> {
        let me = self.index(&f.name)?;
        let ruled: BTreeSet<&str> = (0..self.functions.len())
            .filter(|&c| self.callees[c].contains(&me))
            .flat_map(|c| self.functions[c].sources.iter().map(String::as_str))
            .filter(|s| indirect_rule(s).is_some())
            .collect();
        match ruled.len() {
            1 => Ok(indirect_rule(ruled.first().expect("one")).expect("ruled")),
            _ => bail!(
                "{} at {at:#x}: an outlined indirect call whose callers' sources name {} rules of stack.rs ({ruled:?})",
                f.name,
                ruled.len()
            ),
        }
    }

    fn matching(&self, accepts: fn(&str) -> bool, what: &str) -> Result<Vec<usize>> {
        let found: Vec<usize> = (0..self.functions.len()).filter(|&i| accepts(&short(&self.functions[i].name))).collect();
        if found.is_empty() {
            bail!("no function {what} to bound an indirect call by");
        }
        Ok(found)
    }
}

/// `08000400 <name>:`
fn label(line: &str) -> Option<(u64, &str)> {
    let (addr, rest) = line.split_once(' ')?;
    let name = rest.strip_prefix('<')?.strip_suffix(">:")?;
    Some((u64::from_str_radix(addr, 16).ok()?, name))
}

/// A name for people: no `::h<hash>` suffix, legacy mangling escapes decoded.
pub fn short(name: &str) -> String {
    let name = match name.rsplit_once("::h") {
        Some((head, hash)) if hash.len() == 16 && hash.chars().all(|c| c.is_ascii_hexdigit()) => head,
        _ => name,
    };
    let mut s = name.to_string();
    for (from, to) in [
        ("$LT$", "<"),
        ("$GT$", ">"),
        ("$RF$", "&"),
        ("$BP$", "*"),
        ("$SP$", "@"),
        ("$C$", ","),
        ("$u20$", " "),
        ("$u27$", "'"),
        ("$u5b$", "["),
        ("$u5d$", "]"),
        ("$u7b$", "{"),
        ("$u7d$", "}"),
        ("$u7e$", "~"),
        ("..", "::"),
    ] {
        s = s.replace(from, to);
    }
    s.strip_prefix("_<").map(|r| format!("<{r}")).unwrap_or(s)
}

/// The `#[panic_handler]`'s symbol.
const PANIC_HANDLER: &str = "rust_begin_unwind";

/// What a call chain ends in when it leaves the direct-call graph.
#[derive(Clone, Debug)]
enum Next {
    Call(usize),
    Formatting,
}

#[derive(Clone, Debug)]
struct Depth {
    bytes: u64,
    next: Option<Next>,
}

/// Depth of every function reached from one context: indirect dispatch depends on it.
struct Walk<'a> {
    graph: &'a Graph,
    context: Context,
    polls: &'a BTreeMap<&'static str, Vec<usize>>,
    formatting: u64,
    memo: HashMap<usize, Depth>,
    path: Vec<usize>,
}

impl Walk<'_> {
    fn depth(&mut self, i: usize) -> Result<Depth> {
        if let Some(d) = self.memo.get(&i) {
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
        for (at, source) in &f.indirect {
            match g.rule(f, *at, source)? {
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
        self.memo.insert(i, d.clone());
        Ok(d)
    }

    /// `name (frame) → …` down the deepest path from `i`.
    fn chain(&self, i: usize) -> String {
        let mut parts = Vec::new();
        let mut at = Some(Next::Call(i));
        while let Some(next) = at {
            match next {
                Next::Call(j) => {
                    let f = &self.graph.functions[j];
                    parts.push(format!("{} ({} B)", short(&f.name), f.frame));
                    at = self.memo.get(&j).and_then(|d| d.next.clone());
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
    // Exception handlers may each sit at a priority of its own: all of them nest, each with a frame.
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

/// The exception handlers of the vector table but Reset (thread mode) and the executors'
/// interrupts (their own contexts), and the stack region below the statics.
fn vectors_and_region(elf_bytes: &[u8], graph: &Graph) -> Result<(Vec<u64>, u64)> {
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
fn function_sizes(elf_bytes: &[u8]) -> Result<HashMap<u64, u64>> {
    let file = object::File::parse(elf_bytes).map_err(|e| anyhow!("not an ELF file: {e}"))?;
    let mut sizes = HashMap::new();
    for sym in file.symbols().filter(|s| s.kind() == object::SymbolKind::Text && s.size() > 0) {
        let size = sizes.entry(sym.address() & !1).or_insert(0);
        *size = sym.size().max(*size);
    }
    Ok(sizes)
}

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
    let graph = Graph::parse(&String::from_utf8_lossy(&out.stdout), &function_sizes(&bytes)?)?;
    let (handlers, region) = vectors_and_region(&bytes, &graph)?;
    worst_case(&graph, &handlers, region)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A disassembly in llvm-objdump's layout: `label:` lines, `; /file.rs:line` lines, and
    /// ` addr:      \tmnemonic\toperands`.
    fn dis(body: &str) -> String {
        body.lines()
            .map(|l| l.trim())
            .filter(|l| !l.is_empty())
            .map(|l| match l.split_once(' ') {
                Some((a, rest)) if a.ends_with(':') => {
                    let (m, ops) = rest.trim().split_once(' ').unwrap_or((rest.trim(), ""));
                    format!(" {a}      \t{m}\t{}", ops.trim())
                }
                _ => l.to_string(),
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    fn graph(body: &str) -> Graph {
        Graph::parse(&dis(body), &HashMap::new()).unwrap()
    }

    fn depth_of(g: &Graph, name: &str) -> Result<u64> {
        let polls = BTreeMap::new();
        let mut w = Walk { graph: g, context: Context::Exception, polls: &polls, formatting: 0, memo: HashMap::new(), path: Vec::new() };
        Ok(w.depth(g.index(name)?)?.bytes)
    }

    #[test]
    fn frame_sums_push_vpush_and_sub() {
        let g = graph(
            "
            08000100 <f>:
            8000100: push {r4, r5, r6, r7, lr}
            8000102: push.w {r8, r9, r10, r11}
            8000106: vpush {d8, d9, d10}
            800010a: sub.w sp, sp, #0x1000
            800010e: sub sp, #0x10
            8000110: subw sp, sp, #0x4
            8000112: str r8, [sp, #-4]!
            8000113: stm.w sp, {r0, r1, r2, r3}
            8000114: add sp, #0x10
            8000116: pop {r4, r5, r6, r7, pc}
        ",
        );
        assert_eq!(g.functions[0].frame, 20 + 16 + 24 + 0x1000 + 0x10 + 4 + 4);
    }

    #[test]
    fn register_ranges() {
        assert_eq!(register_list_bytes("{r4-r7, lr}").unwrap(), 20);
        assert_eq!(register_list_bytes("{d8-d15}").unwrap(), 64);
        assert_eq!(register_list_bytes("{s16-s17}").unwrap(), 8);
    }

    #[test]
    fn depth_follows_the_deepest_call() {
        let g = graph(
            "
            08000100 <top>:
            8000100: push {r7, lr}
            8000102: bl 0x8000200 <shallow>
            8000106: bl 0x8000300 <deep>
            800010a: pop {r7, pc}
            08000200 <shallow>:
            8000200: sub sp, #0x8
            8000202: bx lr
            08000300 <deep>:
            8000300: push {r4, lr}
            8000302: sub sp, #0x100
            8000304: blx 0x8000400 <leaf>
            8000308: pop {r4, pc}
            08000400 <leaf>:
            8000400: sub sp, #0x20
            8000402: bx lr
        ",
        );
        assert_eq!(depth_of(&g, "top").unwrap(), 8 + 8 + 0x100 + 0x20);
    }

    #[test]
    fn a_branch_to_another_function_is_a_tail_call_a_branch_inside_is_not() {
        let g = graph(
            "
            08000100 <f>:
            8000100: push {r7, lr}
            8000102: beq 0x8000108 <f+0x8>
            8000104: cbz r0, 0x8000100 <f>
            8000106: pop.w {r7, lr}
            800010a: b.w 0x8000200 <g>
            08000200 <g>:
            8000200: sub sp, #0x40
            8000202: bx lr
        ",
        );
        assert_eq!(g.callees[0], vec![1]);
        assert_eq!(depth_of(&g, "f").unwrap(), 8 + 0x40);
        assert_eq!(depth_of(&g, "g").unwrap(), 0x40);
    }

    #[test]
    fn a_call_through_a_register_loaded_from_a_literal_is_a_direct_call() {
        let g = graph(
            "
            08000100 <f>:
            8000100: push {r4, r8, lr}
            8000102: ldr.w r8, [pc, #0xc] @ 0x8000110 <f+0x10>
            8000106: blx r8
            8000108: mov r0, r4
            800010a: blx r8
            800010c: pop {r4, r8, pc}
            8000110: .word 0x08000201
            08000200 <g>:
            8000200: sub sp, #0x40
            8000202: bx lr
        ",
        );
        assert_eq!(g.callees[0], vec![1]);
        assert!(g.functions[0].indirect.is_empty());
        assert_eq!(depth_of(&g, "f").unwrap(), 12 + 0x40);
        // Once written, the register holds something else: an indirect call again.
        let g = graph(
            "
            08000100 <f>:
            8000102: ldr r1, [pc, #0xc] @ 0x8000110 <f+0x10>
            8000104: ldr r1, [r0, #0x24]
            8000106: bx r1
            8000110: .word 0x08000201
            08000200 <g>:
            8000200: bx lr
        ",
        );
        assert!(g.callees[0].is_empty());
        assert_eq!(g.functions[0].indirect.len(), 1);
    }

    #[test]
    fn mapping_symbols_do_not_split_a_function() {
        let g = graph(
            "
            08000100 <f>:
            8000100: push {r7, lr}
            8000102 <$d.1>:
            8000102: .word 0x12345678
            8000106 <$t.2>:
            8000106: sub sp, #0x8
            8000108: b 0x8000100 <f>
        ",
        );
        assert_eq!(g.functions.len(), 1);
        assert_eq!(g.functions[0].frame, 16);
        assert!(g.callees[0].is_empty());
    }

    #[test]
    fn padding_after_the_symbol_s_end_is_not_code() {
        let text = dis("
            08000100 <f>:
            8000100: push {r7, lr}
            8000102: pop {r7, pc}
            8000104: bmi 0x8000200 <g+0x10>
            08000200 <g>:
            8000200: sub sp, #0x40
        ");
        let g = Graph::parse(&text, &HashMap::from([(0x800_0100, 4)])).unwrap();
        assert!(g.callees[0].is_empty());
        assert!(!graph(&text).callees[0].is_empty());
    }

    #[test]
    fn recursion_is_an_error_naming_the_cycle() {
        let g = graph(
            "
            08000100 <a>:
            8000100: push {r7, lr}
            8000102: bl 0x8000200 <b>
            08000200 <b>:
            8000200: push {r7, lr}
            8000202: b.w 0x8000100 <a>
        ",
        );
        let e = depth_of(&g, "a").unwrap_err().to_string();
        assert!(e.contains("recursion: a → b → a"), "{e}");
    }

    /// A panic inside the panic handler's logging: the handler's guard stops the second turn.
    #[test]
    fn a_panic_while_panicking_costs_one_more_turn() {
        let g = graph(
            "
            08000100 <core::panicking::panic_fmt>:
            8000100: push {r7, lr}
            8000102: bl 0x8000200 <__rustc::rust_begin_unwind>
            08000200 <__rustc::rust_begin_unwind>:
            8000200: push {r4, r5, r7, lr}
            8000202: bl 0x8000300 <_defmt_acquire>
            08000300 <_defmt_acquire>:
            8000300: sub sp, #0x20
            8000302: bl 0x8000100 <core::panicking::panic_fmt>
        ",
        );
        assert_eq!(depth_of(&g, "core::panicking::panic_fmt").unwrap(), 2 * (8 + 16 + 0x20));
    }

    #[test]
    fn an_indirect_call_without_a_rule_is_an_error() {
        let g = graph(
            "
            08000100 <f>:
            ; /src/app/thing.rs:10
            8000100: push {r7, lr}
            8000102: blx r3
            8000104: pop {r7, pc}
        ",
        );
        let e = depth_of(&g, "f").unwrap_err().to_string();
        assert!(e.contains("f at 0x8000102: indirect call matches no rule"), "{e}");
        // `bx lr` is a return, `bx r2` a jump through a pointer.
        let g = graph(
            "
            08000100 <f>:
            8000100: bx lr
            8000102: bx r2
        ",
        );
        assert_eq!(g.functions[0].indirect.len(), 1);
    }

    #[test]
    fn dynamic_allocation_is_an_error() {
        let g = graph(
            "
            08000100 <f>:
            8000100: push {r7, lr}
            8000102: sub.w sp, sp, r0
            8000106: sub.w sp, r7, #0x8
        ",
        );
        let e = depth_of(&g, "f").unwrap_err().to_string();
        assert!(e.contains("f: dynamic stack allocation (`sub.w sp, sp, r0`)"), "{e}");
        // In an IT block: a conditional release is no allocation, a conditional allocation counts.
        let g = graph(
            "
            08000100 <f>:
            8000100: push {r7, lr}
            8000102: sub sp, #0x18
            8000104: it lo
            8000106: addlo sp, #0x18
            8000108: it hs
            800010a: subhs sp, #0x8
        ",
        );
        assert_eq!(depth_of(&g, "f").unwrap(), 8 + 0x18 + 0x8);
    }

    /// Two executors, a waker call in a task: each context counts only its own tasks.
    #[test]
    fn dispatch_resolves_to_the_context_s_tasks_and_wakers_to_the_waker() {
        let g = graph(
            "
            08000100 <main>:
            ; /x/embassy-executor-0.10.0/src/raw/mod.rs:479
            8000100: push {r7, lr}
            8000102: blx r1
            08000200 <UART4>:
            ; /x/embassy-executor-0.10.0/src/raw/mod.rs:479
            8000200: push {r7, lr}
            8000202: blx r1
            08000280 <UART5>:
            ; /x/embassy-executor-0.10.0/src/raw/mod.rs:479
            8000280: push {r7, lr}
            8000282: blx r1
            08000300 <embassy_executor::raw::TaskStorage$LT$F$GT$::poll::h0123456789abcdef>:
            ; /w/src/app/hygrometer.rs:12
            8000300: sub.w sp, sp, #0x4000
            ; /rustc/abc/library/core/src/task/wake.rs:448
            8000304: blx r1
            08000400 <embassy_executor::raw::TaskStorage$LT$F$GT$::poll::h1123456789abcdef>:
            8000400: sub sp, #0x100
            8000402: bl 0x8000500 <app::__sample_task_task::{{closure}}>
            08000500 <app::__sample_task_task::{{closure}}>:
            8000500: sub sp, #0x200
            8000502: bx lr
            08000600 <embassy_executor::raw::TaskStorage$LT$F$GT$::poll::h2123456789abcdef>:
            ; /w/src/app/humidity.rs:1
            8000600: sub sp, #0x10
            08000640 <embassy_executor::raw::TaskStorage$LT$F$GT$::poll::h3123456789abcdef>:
            ; /w/src/app/report.rs:1
            8000640: sub sp, #0x20
            08000680 <embassy_executor::raw::TaskStorage$LT$F$GT$::poll::h4123456789abcdef>:
            ; /w/src/app/retune.rs:1
            8000680: sub sp, #0x30
            08000700 <embassy_executor::raw::waker::wake::h5123456789abcdef>:
            8000700: sub sp, #0x18
            8000702: bx lr
            08000800 <SysTick>:
            ; /rustc/abc/library/core/src/task/wake.rs:463
            8000800: push {r4, lr}
            8000802: blx r1
        ",
        );
        let r = worst_case(&g, &[0x800_0801], 0x4000).unwrap();
        let bytes: Vec<u64> = r.contexts.iter().map(|c| c.bytes).collect();
        assert_eq!(bytes, vec![8 + 0x4000 + 0x18, 8 + 0x20, 8 + 0x100 + 0x200, 8 + 0x18]);
        assert_eq!(r.preemptions, 3);
        assert_eq!(r.total, bytes.iter().sum::<u64>() + 3 * 104);
        assert!(r.over());
        assert!(
            r.contexts[0]
                .chain
                .starts_with("main (8 B) → embassy_executor::raw::TaskStorage<F>::poll (16384 B) → embassy_executor::raw::waker::wake")
        );
        // An executor dispatch in an exception handler has no tasks to resolve to.
        let e = worst_case(&g, &[0x800_0201], 0x4000).unwrap_err().to_string();
        assert!(e.contains("dispatch outside the executor contexts"), "{e}");
    }

    #[test]
    fn short_names_drop_the_hash_and_decode_escapes() {
        assert_eq!(short("_$LT$$RF$T$u20$as$u20$core..fmt..Display$GT$::fmt::h650b9dd4f442b2b6"), "<&T as core::fmt::Display>::fmt");
        assert_eq!(short("ipmc_core::humidity::strip::strip_rh::h0123456789abcdef"), "ipmc_core::humidity::strip::strip_rh");
    }
}
