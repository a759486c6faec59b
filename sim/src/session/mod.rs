//! The session file: what a recording is asked to be (the kind, the chamber's humidity program,
//! the sample's departure from its calibration, the frequencies or time series, the noise),
//! read from TOML and checked before anything is simulated; and the session of
//! `ipmc simulate-sweep`'s two-level ramp. Everything else in the simulator reads a session
//! from here and writes none.

mod file;
#[cfg(test)]
mod fuzz;
pub mod sweep;
mod toml_file;
mod validate;

pub use file::{
    ChargingPlan, Frequencies, Humidity, Kind, MAX_FREQUENCY_POINTS, MAX_SAMPLES, MAX_TONES, Noise, Sample, Session, TimeSeriesPlan,
    log_spaced,
};
