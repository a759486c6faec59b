//! Diagnosis of the mismatch between the model and recordings: compare, locate, name the
//! missing physics from a library of candidates, decide on held-out levels and an information
//! criterion, and report (`ipmc diagnose`, proved by `ipmc prove`; the tool draws the figures).
//!
//! The rooms, each importing only from those above it in this list:
//! - [`input`]: a strip's files and the recordings as a dataset.
//! - [`fits`]: the fits near the calibration: base fits per level with an extension and a
//!   mask, the noise from neighbouring points, the instrument's channels, joint candidate fits.
//! - [`evidence`]: what the recordings show before any candidate: humidity laws, the scoring
//!   context, where the mismatch lives, held-out scores, the uncertainty over levels.
//! - [`candidates`]: the effects, the library of candidate physics, what a score holds, the
//!   scorers' interface, the measurement that separates two candidates.
//! - [`humidity`]: the humidity question: sensor error and hydration lag, the sensor at
//!   references, the whole humidity path, what a recording can carry.
//! - [`scorers`]: the other kinds' scorers and the one scoring every candidate goes through.
//! - [`verdict`]: the decision, the follow-up it asks for, what a diagnosis reports.
//! - [`engine`]: the diagnosis of one dataset in order.
//! - [`strip_diagnosis`]: one diagnosis from a strip's primary and follow-ups, stage by stage.
//! - [`report`]: report.json and report.md.

pub mod candidates;
pub mod engine;
pub mod evidence;
pub mod fits;
pub mod humidity;
pub mod input;
pub mod report;
pub mod scorers;
pub mod strip_diagnosis;
pub mod verdict;

pub use candidates::Effect;
pub use engine::diagnose;
pub use evidence::HeldOutModel;
pub use input::{data, strip_files};
pub use verdict::{Diagnosis, Verdict};
