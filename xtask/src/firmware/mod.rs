//! The firmware as xtask handles it: its variants and their release builds, flashing a board,
//! and what a build costs (flash and RAM against the budget, the worst-case stack, instruction
//! counts under QEMU). `build` is the bottom; `size` reads `stack`'s analysis.

pub mod bench;
mod build;
pub mod flash;
pub mod size;
mod stack;

pub use build::{Variant, build, build_all, build_with, target_dir};
