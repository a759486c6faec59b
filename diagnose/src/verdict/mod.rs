//! What the evidence concludes: the probabilities, the verdict and its thresholds, the
//! follow-up recording to ask for when it cannot name, and the diagnosis as reported.

pub mod decide;
pub mod followup_request;
pub mod types;

pub use types::{Diagnosis, Verdict};
