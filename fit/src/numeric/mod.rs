//! Generic numerics that know nothing of IPMCs: nonlinear and linear least squares, a value
//! with its standard error, the χ² tail and a simplex minimizer, a one-dimensional minimizer
//! over decades, and deterministic random numbers. Kept apart so that every fit above reads
//! as its model and its data, the optimizers underneath.

pub mod estimate;
pub mod linear;
pub mod lsq;
pub mod random;
pub mod scalar;
pub mod stats;
