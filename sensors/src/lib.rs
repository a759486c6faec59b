//! Sensor drivers and bus handling of the firmware, generic over embedded-hal(-async) so that
//! their state machines run against fake buses on the host (`tests/`). Each humidity sensor's
//! driver is whole in its own file, its conversions from raw values (pure arithmetic,
//! unit-tested on the host) beside its bus traffic; the LSM6DSL accelerometer's is a folder, its
//! FIFO's decoding beside its bus traffic. The boards pick buses and pins.
#![no_std]

pub mod hih4030;
pub mod hts221;
pub mod i2c_recovery;
pub mod lsm6dsl;
pub mod sht4x;
pub mod vrefint;
