//! The candidates: the effects the model leaves out, the library of candidate physics that
//! could explain them, what scoring one gives and the interface each kind's scorer implements,
//! and the measurement that would separate two of them.

pub mod effect;
pub mod library;
pub mod score;
pub mod separation;
pub(crate) mod trial;

pub use effect::{Effect, NONE};
pub use library::{Candidate, ExtFn, HumidityMap, Kind, LIBRARY, Spec, by_effect, by_name, forms_of, label};
