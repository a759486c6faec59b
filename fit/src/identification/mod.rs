//! The identification of a strip: each humidity level's parameters fitted to its measured
//! responses against the core's exact model, humidity laws through the levels with the strip's
//! departures from them, and what the calibration they make does not know. The physics is the
//! core's; here are the fits and their statistics.

pub mod departures;
pub mod identify;
pub mod laws;
pub mod response;
pub mod scatter;
