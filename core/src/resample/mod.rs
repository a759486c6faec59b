//! One clock for two oscillators: the board's accelerometer samples on its own oscillator, the
//! ADC on the board's timer. [`clock_map`] fits the map from the accelerometer's timestamps to
//! the board's timer (rate and offset, forgetting slowly); [`interpolator`] is the fractional
//! delay that reads a signal between its samples; [`resampler`] keeps the accelerometer's recent
//! samples and gives their value at each ADC sample's instant, the delay of the part's filter
//! chain taken out; [`track`] runs both on the part's bursts as the device gets them, a block at
//! a time; [`accuracy`] measures what it leaves of a signal. The device runs it in f32,
//! the host in f64, the clock map in f64 on both (time needs its 53 bits).

pub mod accuracy;
pub mod clock_map;
pub mod interpolator;
pub mod resampler;
pub mod track;
