//! Frequency responses estimated from a time-series recording (recording-format.md §2): the one
//! estimator `identify` and `diagnose` both read time series through.
//!
//! Each burst (a jump in `t_s`) is one humidity level. The excited lines come from the
//! recording's `tones_hz` metadata or, failing that, from the base motion's spectrum: bins far
//! above its median (a noise-only bin's power is exponential, so a threshold of
//! ln(1000·bins)·mean lets a false line through once in a thousand bursts), their greatest
//! common divisor giving the multisine's period.
//!
//! - Periodic multisine (lines on the period's grid): the burst's last whole periods,
//!   rectangular window; each line is exact in every period. Leading periods that disagree with
//!   the later ones beyond their scatter (a start-up transient) are dropped.
//! - Tones off any common grid (`tones_hz`): equal Hann-windowed segments long enough to
//!   separate the tones.
//!
//! H = mean(Y)/mean(U) over the segments. Its noise comes from two independent estimates of
//! the error e = Y − H·U, pooled by their degrees of freedom: the scatter of e from segment to
//! segment, and e at the unexcited bins beside each line (there Y and U are noise plus the
//! window's leakage, which cancels in e to first order). What lies between the lines in the
//! current, interference such as mains and its harmonics, is kept as a spectrum.

mod between;
mod burst;
mod estimator;
mod phasor;
mod plan;
#[cfg(test)]
mod tests;
mod to_fits;

pub use crate::measure::noise::ChannelNoise;
pub use burst::{BetweenLines, Burst, Line, Ratio};
pub use estimator::estimate;
pub use plan::excitation_period;
pub use to_fits::{channel_noise, to_frequency_response};
