//! `cargo xtask imports`: each crate's files as a graph of who imports whom, and the import
//! circles in it. A file imports another when it names an item or module the other defines
//! (through `use`, a path in code, or a macro's tokens); a front door's `pub use` of what its own
//! rooms export, a `mod x;` and unit tests are no import. Two checks must find nothing: no file
//! reaches itself through imports, and under every folder its children (a file, or a folder with
//! all it holds) import one another in one direction only, so that a folder's rooms read bottom
//! to top. Bottom up: `parse`, `graph`, `check`, `report`.

mod check;
mod graph;
mod parse;
mod report;

pub use report::command;
