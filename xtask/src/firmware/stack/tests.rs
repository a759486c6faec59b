//! The analysis on hand-written disassemblies in llvm-objdump's layout.

use std::collections::{BTreeMap, HashMap};

use super::context::Context;
use super::graph::Graph;
use super::names::short;
use super::thumb::register_list_bytes;
use super::walk::{Walk, worst_case};
use crate::Result;

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
    // Loads of several registers from sp read it; with write-back they release.
    let g = graph(
        "
        08000100 <f>:
        8000100: push {r7, lr}
        8000102: sub sp, #0x10
        8000104: ldm.w sp, {r0, r1, r2, r3}
        8000108: ldm sp!, {r0, r1}
    ",
    );
    assert_eq!(depth_of(&g, "f").unwrap(), 8 + 0x10);
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
