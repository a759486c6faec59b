//! The humidity chain: which humidity each block's design is for. A sensor's reading in %RH (its
//! driver, in the `ipmc-sensors` crate, converts the raw value) and the strip's own humidity, read
//! from its current's running spectrum ([`spectrum`], [`strip`]), are fused by their
//! uncertainties ([`fusion`]); the trend looks ahead to when a design will be in effect
//! ([`trend`]); and block by block, [`block`] (the reading through the calibration's humidity
//! path) and [`hygrometer`] (the strip's own estimate) give the firmware and its host replica the
//! same humidity, bit for bit.

pub mod block;
pub mod fusion;
pub mod hygrometer;
pub mod spectrum;
pub mod strip;
pub mod trend;
