//! How a recording is made: one maker per kind (a frequency response, a time series, charging
//! recordings, a humidity reference, a field recording), each running the session's bench
//! (`world`) through the physics seam in the order its instrument would, and [`simulate`]
//! choosing the maker a session's kind names. Every draw comes from the session's seed in a
//! fixed order, so a seed is a file.

mod charging;
pub mod field;
mod frequency_response;
pub mod humidity_reference;
mod recording;
mod simulate;
mod time_series;

pub use recording::Recording;
pub use simulate::simulate;
