//! The fits a diagnosis makes near the calibration, each with a model extension held and a mask
//! of the values that take part: the base model per humidity level, the noise from neighbouring
//! points, the instrument's channels with their tolerances as priors, and a candidate's global
//! parameters jointly with every level's. Least squares, levels and responses are
//! `ipmc_fit`'s; every model value is `ipmc_core`'s.

pub mod base;
pub mod instrument;
pub mod joint;
pub mod noise;
pub mod strip_cache;
#[cfg(test)]
mod test_levels;

pub use base::{
    BASE, BaseFits, LevelSigmas, Mask, PerPoint, RefitError, Theta, calibration_theta, chi2, fit_level, fit_level_from, fit_levels,
    level_params, log_ratios, unit_sigmas, write_residuals, write_residuals_kept,
};
pub use instrument::{ChannelPrior, Channels, InstrumentFit, fit_instrument, shift_residuals};
pub use joint::{ChannelStart, Extend, JointFit, fit_joint, inside_tight};
pub use noise::{Noise, ResidualCorrelation, estimate_noise, residual_correlation, sigmas, structure_z};
pub use strip_cache::StripCache;
