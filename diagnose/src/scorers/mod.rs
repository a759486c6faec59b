//! The scorers of the candidates that act on the data or beside the humidity: a model
//! candidate's joint fit, mains interference, the temperature; and the one `score` every
//! candidate goes through (the humidity's scorers are the humidity room's). A new kind of
//! candidate is a scorer implementing `candidates::trial::Scorer`, its variant of
//! [`crate::candidates::Kind`] and its row in `scorer_for`.

mod mains;
mod model;
mod scoring;
mod temperature;

pub(crate) use scoring::{Scored, score};
