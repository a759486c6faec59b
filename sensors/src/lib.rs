//! Sensor drivers and bus handling of the firmware, generic over embedded-hal(-async) so that
//! their state machines run against fake buses on the host (`tests/`). The boards pick buses
//! and pins; the conversions from raw values live in `ipmc_core::humidity::sensor`.
#![no_std]

pub mod hts221;
pub mod i2c_recovery;
pub mod sht4x;
pub mod vrefint;
