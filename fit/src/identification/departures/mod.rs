//! The strip's own departures from smooth humidity laws, kept where its levels show them beyond
//! their errors (the calibration's `[departures]` table), and what remains unknown after laws and
//! departures (its `[uncertainty]`). Per level the fit gives θ = ln(Y, Cs, Ca, d) with its
//! covariance, read at a humidity the bench sensor knows up to a read error σₑ (a random effect
//! of the level). Each parameter follows θₖ(x) = ln baseₖ(x) + pₖ(x) + gₖ(x): the base
//! calibration's law shape, a polynomial correction pₖ (the law), and the strip's departure gₖ, a
//! zero-mean Gaussian process over humidity ([`crate::gaussian_process`]), the four independent.
//! The hyperparameters are the data's (the restricted likelihood's, the departures' lengths
//! averaged over), never set from a recording: where the levels show no departure beyond their
//! errors the law alone remains, and the posterior variance is what the calibration states it
//! does not know.

mod hyper;
mod law_test;
mod lengths;
mod levels;
mod model;
mod posterior;
mod problem;
mod table;
#[cfg(test)]
mod tests;

pub use hyper::Hyper;
pub use law_test::LawTest;
pub use levels::{LevelTheta, MIN_REVISITS, rh_sd_from_revisits};
pub use model::{CORRECTION_DEGREE, StripModel};
pub use problem::ModelError;
pub use table::table;
