//! `ipmc monitor`'s work: the firmware's binary stream read from where it comes (`source`),
//! decoded into samples and once-a-second status lines (`decode`), the samples written as CSV
//! (`csv`).

pub mod csv;
pub mod decode;
pub mod source;

pub use decode::{CheckSample, Event, Monitor, Sample, WindowSample};
