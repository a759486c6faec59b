//! Identification of IPMC model parameters from measured frequency responses, in four rooms,
//! each using only those before it (the refits near a calibration
//! are the diagnosis's, `ipmc_diagnose::fits`):
//!
//! - [`numeric`]: generic numerics that know nothing of IPMCs: nonlinear least squares
//!   ([`lsq`], Levenberg–Marquardt with bounds, standard errors and block-structured problems),
//!   linear least squares, a value with its standard error, the χ² tail, minimizers, random
//!   numbers.
//! - [`measure`]: what a recording measures: measured points and their noise, the frequency
//!   responses a time series' multisine bursts estimate, recordings as the fits read them, one
//!   humidity level's data, and where a chamber's setpoints place the levels.
//! - [`gaussian_process`]: Gaussian-process regression with an integrated-out linear mean,
//!   judged by the restricted likelihood: the engine under the strip's departures.
//! - [`identification`]: a strip's identification: each level's parameters ([`identify`],
//!   against [`response`]), humidity laws through the levels ([`laws`]), the strip's departures
//!   from them ([`departures`]), and what remains unknown ([`scatter`]).
//!
//! Every module keeps its path at the crate's root too (`ipmc_fit::lsq`, `ipmc_fit::multisine`, …).
//! The physics is never written here: every model value comes from `ipmc_core`.

pub mod gaussian_process;
pub mod identification;
pub mod measure;
pub mod numeric;

pub use identification::{departures, identify, laws, response, scatter};
pub use measure::{chamber, level, multisine, noise, recordings};
pub use numeric::lsq::block_qr;
pub use numeric::{estimate, lsq, random, scalar, stats};
