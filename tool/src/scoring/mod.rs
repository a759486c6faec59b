//! How an estimate is scored against the true base motion (on a check, against its accelerometer's): one definition for every figure the
//! tool prints (`score`, `compensate`, `strip-check`, `vs-exact`, `field-table`, the plot's
//! error trace) and for the firmware's estimates (`cargo xtask qemu` runs `ipmc score`).
//!
//! The truth is the base motion shifted by the inverse's preview and put through the same band
//! filter the estimate went through; the error is rms(estimate − truth) / rms(truth) sample by
//! sample, after each burst's settling and the filter's start-up, over windows of whole periods
//! of the excitation where the recording states its period (and said not to be otherwise).
//!
//! - `definition`: the truth through the band, the samples skipped, the period;
//! - `figures`: the sums per window and burst, pooled and as an rms over the bursts;
//! - `coverage`: whether the stated error bars hold, window by window;
//! - `spectral`: where in frequency an error lies (a diagnostic, not the score);
//! - `wording`: the one line every command prints of a score, and why nothing was scored;
//! - `accelerometer`: a check's reference, its accelerometer's displacement;
//! - `stale_chance`: where the device's stale test does not call a check's error, how rare it is
//!   for a calibration that holds, and the measurement that decides;
//! - `estimate_file`: an estimate file scored against its recording, with the figures `ipmc
//!   score` prints (and `cargo xtask` checks) as a struct.

pub mod accelerometer;
pub mod coverage;
mod definition;
pub mod estimate_file;
mod figures;
pub mod spectral;
pub mod stale_chance;
mod wording;

pub use definition::{Reference, Scoring, stated_period_s};
pub use figures::{Score, Sums};
pub use ipmc_core::firmware::operating_point::SETTLE_S;
pub use wording::{line, nothing_scored};
