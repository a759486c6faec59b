//! Gaussian-process regression with a linear mean whose coefficients are integrated out, generic
//! over what it fits: observations of several independent outputs, each a zero-mean process
//! with squared-exponential covariance over an input known only up to a variance, plus a mean
//! that is linear in its coefficients. The hyperparameters are judged by the restricted (REML)
//! likelihood: the mean's coefficients integrated out, so that fitting them does not bias the
//! variances low where there are few observations. The posterior gives the process's mean and
//! variance anywhere, and each observation's leave-one-out residual in closed form.

mod kernel;
mod reml;

pub use kernel::{cross_covariances, kernel};
pub use reml::{Posterior, leave_one_out_z2, posterior_var, reml};
