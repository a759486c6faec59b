//! What a recording measures, before any model of the strip: the measured points and their
//! noise, the frequency responses a time series' multisine bursts estimate, recordings read as
//! the fits take them, one humidity level's data, and where a chamber's setpoints place the
//! levels on the humidity axis.

pub mod chamber;
pub mod level;
pub mod multisine;
pub mod noise;
pub mod point;
pub mod recordings;
