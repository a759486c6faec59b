//! The humidity question in one room: candidates that act through the humidity the strip lives
//! at (a sensor's offset and gain, a hydration lag), their fits and scorers, the sensor read at
//! references, the whole humidity path fitted at once for the calibration, and what a
//! recording's humidity path can carry at all.

pub(crate) mod hydration_lag;
pub mod path;
pub mod reach;
pub mod remap;
pub(crate) mod sensor_error;
pub mod sensor_reference;
