//! Diagnosis of the mismatch between the model and recordings: compare, locate, name the
//! missing physics from a library of candidates, decide on held-out levels and an information
//! criterion, and report (`ipmc diagnose`, proved by `ipmc prove`; the tool draws the figures).
//!
//! - [`recordings`]: recording files read as frequency responses at the strip's humidity.
//! - [`data`]: the recordings as levels of complex responses with time, temperature, session.
//! - [`effect`]: the effects the model leaves out, by name (shared with the tool's simulator).
//! - [`candidates`]: the library of candidate physics (what, how it shows, its parameters).
//! - [`fits`]: per-level base fits, the noise from neighbouring points, joint candidate fits.
//! - [`laws`]: humidity laws over levels (held-out prediction, humidity-acting candidates).
//! - [`locate`]: where the mismatch lives and how significant it is.
//! - [`engine`]: the diagnosis itself and its decision rule.
//! - [`report`]: report.json and report.md.

pub mod candidates;
pub mod data;
pub mod effect;
pub mod engine;
pub mod fits;
pub mod laws;
pub mod locate;
pub mod recordings;
pub mod report;

pub use effect::Effect;
