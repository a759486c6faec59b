//! Identification of IPMC model parameters from measured frequency responses.
//!
//! - [`lsq`]: bounded, weighted nonlinear least squares (Levenberg–Marquardt) with standard
//!   errors and correlations: generic, knows nothing of IPMCs.
//! - [`block_qr`]: the QR factor of a Jacobian whose columns reach one block of rows or all,
//!   computed block by block ([`lsq::fit_blocks`]'s steps).
//! - [`response`]: residuals of a measured tip/current response against the core's exact model
//!   (`ipmc_core::model::exact`), with any subset of the model's parameters fitted by their `--set` names.
//! - [`multisine`]: tip/base and current/base responses, their noise and the between-line
//!   spectrum estimated from a time-series recording's multisine bursts.
//! - [`recordings`]: recording files read as frequency responses at the strip's humidity.
//! - [`noise`]: each point's σ estimated from a preliminary fit's residual scatter.
//! - [`estimate`]: a fitted value with its standard error.
//! - [`level`]: one humidity level's measured responses, as every fit takes them.
//! - [`identify`]: one humidity level's Y, Cs, Ca and d, staged as the paper does, then jointly.
//! - [`laws`]: humidity laws through the levels, and the calibration they make.
//! - [`departures`]: the strip's departures from those laws where its levels show them (a
//!   Gaussian process over humidity, the bench's read errors a random effect), and what remains.
//! - [`chamber`]: where a session's stated setpoints and its readings place the levels.
//! - [`stats`]: the χ² distribution's tail and a simplex minimizer.
//! - [`scatter`]: how far the levels stray from those laws (the calibration's `[uncertainty]`).
//! - [`scalar`]: minimizing a function of one positive scalar over decades.
//! - [`random`]: deterministic random numbers (the simulator's recordings, a diagnosis's bootstrap).
//!
//! The physics is never written here: every model value comes from `ipmc_core`.

pub mod block_qr;
pub mod chamber;
pub mod departures;
pub mod estimate;
pub mod identify;
pub mod laws;
pub mod level;
pub mod lsq;
pub mod multisine;
pub mod noise;
pub mod random;
pub mod recordings;
pub mod response;
pub mod scalar;
pub mod scatter;
pub mod stats;
