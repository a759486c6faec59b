//! Sensor drivers, generic over embedded-hal-async buses; boards pick the bus and pins.

#[cfg(all(feature = "board-b-l475e", not(feature = "humidity-hih4030")))]
pub mod hts221;
