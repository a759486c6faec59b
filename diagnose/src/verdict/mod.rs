//! What the evidence concludes: the probabilities, tempered between candidates by the misfit
//! they leave; the one rule that states the verdict and the set from them; the plan of
//! follow-ups, ranked by information per hour of lab time, and the request it makes when the
//! evidence cannot name; the check that a report agrees with itself; and the diagnosis as
//! reported.

pub mod consistency;
pub mod decide;
pub mod followup_request;
pub mod hypotheses;
pub mod misfit;
pub mod plan;
pub mod types;

pub use types::{Diagnosis, Verdict};
