//! The temperature of the evidence between candidates, from the misfit the best of them leaves.
//!
//! Two candidates whose shapes agree to the recording's resolution (an RC line and a pole at a
//! third of its τ agree to (sτ)²/45) differ in χ² by what the better one fits of a misfit both
//! leave. ΔBIC counts that difference as if every residual were an independent datum, but where
//! the better candidate's residuals are correlated along frequency (a smooth misfit, not noise)
//! the residuals of a level carry fewer independent data than points: n correlated residuals
//! weigh as n/τ independent ones, τ their integrated autocorrelation time (the fit crate's one
//! estimator, [`ipmc_fit::stats::autocorrelation_time_of`], which `recalibrate` widens its bins
//! by too: each series about its own mean, pooled over the series), and never less than one
//! independent datum per series. The log-likelihood ratio
//! between candidates, and BIC's penalty with it, is divided by τ: a lead the shapes cannot
//! carry is split, while a candidate that leaves white residuals (the truth, fitted) keeps
//! BIC's odds. The overdispersion (the best model's χ²/dof) is already in every data-space ΔBIC
//! ([`crate::verdict::decide::overdispersion`]).
//!
//! Only the split among candidates is tempered: `none`'s probability is BIC's own
//! ([`crate::evidence::level_bootstrap`]), so a clean strip, whose candidates gain nothing
//! against `none` that survives the penalty, keeps `none` whatever its residuals look like.

use crate::fits::ResidualCorrelation;

/// The factor the evidence between candidates is divided by: the integrated autocorrelation
/// time of the best candidate's residuals, at most the series' mean length (one independent
/// datum per series), never below one.
pub fn between_candidates(c: ResidualCorrelation) -> f64 {
    c.tau.min(c.points_per_series.max(1.0)).max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White residuals keep BIC's odds; a smooth misfit divides them by its autocorrelation
    /// time, bounded by one datum per series.
    #[test]
    fn correlated_misfit_tempers_and_white_noise_does_not() {
        let t = |tau: f64| between_candidates(ResidualCorrelation { tau, points_per_series: 58.0 });
        assert_eq!(t(1.0), 1.0);
        assert_eq!(t(0.7), 1.0);
        assert!((t(3.0) - 3.0).abs() < 1e-12);
        assert_eq!(t(200.0), 58.0);
        assert_eq!(between_candidates(ResidualCorrelation { tau: 30.0, points_per_series: 0.5 }), 1.0);
    }
}
