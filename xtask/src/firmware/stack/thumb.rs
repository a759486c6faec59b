//! Thumb-2 instructions as llvm-objdump prints them, decoded into what the stack walk needs of
//! a function: how far its prologue and body move sp, its direct calls and branches, the calls
//! through a register loaded from a literal pool, and its indirect calls.

use anyhow::{anyhow, bail};
use std::collections::{BTreeSet, HashMap};

use crate::Result;

/// One function of the disassembly, as its instructions say.
#[derive(Debug, Default)]
pub struct Function {
    pub name: String,
    pub start: u64,
    /// From the symbol's size: what follows is alignment padding, which may decode as anything.
    pub end: Option<u64>,
    pub instructions: usize,
    /// Bytes the prologue and body move sp down by.
    pub frame: u64,
    /// `bl`/`blx` targets and branches (resolved to tail calls once every function is known).
    pub calls: Vec<u64>,
    /// Calls through a register loaded from a literal pool: (where, the literal's address).
    pub literal_calls: Vec<(u64, u64)>,
    pub branches: Vec<u64>,
    /// Indirect calls: (address, source file of the line).
    pub indirect: Vec<(u64, Option<String>)>,
    /// Every source file the line info names in this function (inlined code included).
    pub sources: BTreeSet<String>,
    /// An instruction that moves sp by an amount known only at run time.
    pub dynamic: Option<String>,
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
pub fn register_list_bytes(ops: &str) -> Result<u64> {
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
    pub fn instruction(&mut self, mnemonic: &str, ops: &str, source: Option<&String>) -> Result<()> {
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
        } else if first == "sp"
            && !(m.starts_with("st")
                || m.starts_with("vst")
                || m.starts_with("ldm")
                || m.starts_with("vldm")
                || matches!(m, "cmp" | "cmn" | "tst" | "teq"))
        {
            // Stores and compares read sp, and so does a load of several registers from it
            // (`ldm.w sp, {r0, r1}`; with `sp!` it releases, as a pop); everything else named sp
            // first writes it.
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
pub fn literal_call(f: &mut Function, loaded: &mut HashMap<String, u64>, at: u64, mnemonic: &str, ops: &str, all: &str) -> bool {
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
    for stem in ["add", "addw", "sub", "subw"] {
        if let Some(c) = m.strip_prefix(stem)
            && CONDITIONS.contains(&c)
        {
            return stem;
        }
    }
    m
}
