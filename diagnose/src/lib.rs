//! Diagnosis of the mismatch between the model and recordings: compare, locate, name the
//! missing physics from a library of candidates, decide on held-out levels and an information
//! criterion, and report (`ipmc diagnose`, proved by `ipmc prove`; the tool draws the figures).
//!
//! - [`strip_files`]: the files of one strip, primaries and follow-ups, checked together.
//! - [`data`]: the recordings as a dataset of `ipmc_fit` levels with the humidity histories.
//! - [`effect`]: the effects the model leaves out, by name (shared with the simulator, `ipmc-sim`).
//! - [`candidates`]: the library of candidate physics (what, how it shows, its parameters).
//! - [`fits`] (`ipmc_fit::refit`): per-level base fits with an extension and a mask, the noise
//!   from neighbouring points, joint candidate fits.
//! - [`laws`]: humidity laws over levels (held-out prediction, humidity-acting candidates).
//! - [`locate`]: where the mismatch lives and how significant it is.
//! - [`mains_between_lines`]: mains interference in a time series' spectrum between its lines.
//! - [`context`]: what every candidate is scored from (base fits, noise, law weights) and
//!   against (the plain model's baseline).
//! - [`held_out`]: held-out scores of levels and their paired comparison.
//! - [`scorers`]: one scorer per kind of candidate behind one interface.
//! - [`remap`]: candidates acting through the humidity (sensor error, hydration lag).
//! - [`humidity_path`]: the whole humidity path fitted at once for the calibration.
//! - [`humidity_reach`]: the shortest lag and smallest offset a recording could name.
//! - [`level_bootstrap`]: the evidence's uncertainty over levels (Bayesian bootstrap).
//! - [`decide`]: the decision rule and its thresholds.
//! - [`followup_request`]: the follow-up recording a diagnosis asks for when it cannot name.
//! - [`sensor_reference`]: the humidity sensor's offset and gain from reference readings.
//! - [`types`]: what a diagnosis reports.
//! - [`engine`]: the diagnosis in order.
//! - [`strip_diagnosis`]: one diagnosis from a strip's primary and follow-ups, stage by stage.
//! - [`report`]: report.json and report.md.

pub mod candidates;
pub mod context;
pub mod data;
pub mod decide;
pub mod effect;
pub mod engine;
pub mod fits;
pub mod followup_request;
pub mod held_out;
pub mod humidity_path;
pub mod humidity_reach;
pub mod laws;
pub mod level_bootstrap;
pub mod locate;
pub mod mains_between_lines;
pub mod remap;
pub mod report;
pub mod scorers;
pub mod sensor_reference;
pub mod strip_diagnosis;
pub mod strip_files;
pub mod types;

pub use effect::Effect;
pub use engine::diagnose;
pub use types::{Diagnosis, HeldOutModel, Verdict};
