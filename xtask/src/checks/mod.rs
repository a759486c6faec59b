//! `cargo xtask test` and its steps: the suite (the list of steps, in order), the workspace's
//! cargo steps, the firmware's QEMU scenarios, the tool held to its figures on recordings, the
//! error bars' coverage, the humidity loop, the own-strip workflow, the docs' commands, and the
//! README's figures, which the steps that print them save. The suite is the top; `readme_figures`
//! is the bottom.

mod coverage;
mod doc_commands;
pub mod humidity_loop;
mod qemu_scenarios;
mod readme_figures;
mod running_error;
mod running_error_device;
mod strip_workflow;
mod suite;
mod tool;
mod workspace;

pub use suite::command as test;
