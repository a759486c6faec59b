//! What a recording measures, before any model of the strip: its current's samples that are no
//! measurement, replaced; the measured points and their
//! noise, the frequency responses a time series' multisine bursts estimate, recordings read as
//! the fits take them, one humidity level's data, and where a chamber's setpoints place the
//! levels on the humidity axis.

pub mod bad_samples;
pub mod chamber;
pub mod level;
pub mod multisine;
pub mod noise;
pub mod point;
pub mod recordings;
