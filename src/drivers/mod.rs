//! Sensor drivers, generic over embedded-hal-async buses; boards pick the bus and pins.

#[cfg(feature = "board-b-l475e")]
pub mod hts221;
