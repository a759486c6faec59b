//! What a board and the application agree on, below both: the sources and sink a board
//! implements ([`sources`]), what is fixed at build time (the front end's and the stream's
//! constants: [`config`]; the calibration compiled in: [`calibration`]), the conversions of the current's and the analog humidity sensor's ADC codes
//! ([`current_conversion`], [`analog_humidity`]), the status bits of every block ([`flags`]),
//! a check's samples on a board with the accelerometer ([`check`]) and the lock-free f32 both
//! sides share ([`atomic_f32`]). A board imports from here and never from
//! `app`, so that the application can name the board's concrete types without a circle.

pub mod analog_humidity;
pub mod atomic_f32;
pub mod calibration;
pub mod check;
pub mod config;
pub mod current_conversion;
pub mod flags;
pub mod sources;
