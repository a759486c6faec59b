//! Bounded, weighted nonlinear least squares: Levenberg–Marquardt (the `levenberg-marquardt`
//! crate, a port of MINPACK's trust-region LM) in transformed coordinates, several starts, and
//! standard errors from the Jacobian at the optimum.
//!
//! A problem is a list of named [`Param`]s and a residual function of the parameters in their
//! natural units. The residuals must already be divided by each point's σ (so that χ² = Σ r²).
//! Bounds are kept by optimizing an unconstrained coordinate u with θ = g(u) ([`Bound`]); the
//! covariance is propagated back to θ through g′ (delta method), so a badly determined positive
//! parameter shows up as a large relative standard error instead of a clipped estimate.
//!
//! A problem whose residuals come in blocks (one per humidity level, say) where most parameters
//! move one block only is fitted by [`fit_blocks`]: the same optimizer, but each forward
//! difference of a block's own parameter evaluates that block alone.

pub mod block_qr;
mod bound;
mod outcome;
mod problem;
mod residuals;
mod solve;

pub use bound::{Bound, Param};
pub use outcome::{Fit, FitError, Tolerance};
pub use residuals::Blocks;
pub use solve::{fit, fit_blocks, fit_with, minimize, minimize_blocks, statistics_blocks};
