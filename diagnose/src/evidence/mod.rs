//! What the recordings show before any candidate: the humidity laws over the levels, the
//! context every candidate is scored from (base fits, noise, law weights), the calibration
//! anchored to the levels, where the mismatch lives, held-out scoring, the uncertainty over
//! levels, and mains interference between a time series' lines.

pub mod anchored;
pub mod context;
pub mod held_out;
pub mod laws;
pub mod level_bootstrap;
pub mod locate;
pub mod mains_between_lines;

pub use held_out::HeldOutModel;
