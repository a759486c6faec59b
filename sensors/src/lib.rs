//! Sensor drivers and bus handling of the firmware, generic over embedded-hal(-async) so that
//! their state machines run against fake buses on the host (`tests/`). Each humidity sensor's
//! driver is whole in its own file, its conversions from raw values (pure arithmetic, unit-tested
//! on the host) beside its bus traffic; the boards pick buses and pins.
#![no_std]

pub mod hih4030;
pub mod hts221;
pub mod i2c_recovery;
pub mod sht4x;
pub mod vrefint;
