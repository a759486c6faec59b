//! The disassembly as a call graph: `llvm-objdump` output split into functions at their labels,
//! each decoded, and every direct call, literal-pool call and tail call resolved to the function
//! it enters.

use anyhow::{anyhow, bail};
use std::collections::{BTreeSet, HashMap};

use super::thumb::{Function, literal_call};
use crate::Result;

/// The disassembly as functions, in address order.
#[derive(Debug)]
pub struct Graph {
    pub functions: Vec<Function>,
    /// Direct callees (calls and tail calls) of each function, by index.
    pub callees: Vec<Vec<usize>>,
    pub by_name: HashMap<String, usize>,
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

    pub fn index(&self, name: &str) -> Result<usize> {
        self.by_name.get(name).copied().ok_or_else(|| anyhow!("no function `{name}` in the disassembly"))
    }

    pub fn at(&self, addr: u64) -> Option<usize> {
        self.functions.iter().position(|f| f.start == addr & !1)
    }
}

/// `08000400 <name>:`
fn label(line: &str) -> Option<(u64, &str)> {
    let (addr, rest) = line.split_once(' ')?;
    let name = rest.strip_prefix('<')?.strip_suffix(">:")?;
    Some((u64::from_str_radix(addr, 16).ok()?, name))
}
