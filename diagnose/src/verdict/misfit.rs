//! The temperature of the evidence between candidates, from the misfit the best of them leaves.
//!
//! Two candidates whose shapes agree to the recording's resolution (an RC line and a pole at a
//! third of its τ agree to (sτ)²/45) differ in χ² by what the better one fits of a misfit both
//! leave. ΔBIC counts that difference as if every residual were an independent datum, but where
//! the better candidate's residuals are correlated along frequency (a smooth misfit, not noise)
//! the residuals of a level carry fewer independent data than points: for residuals correlated
//! as an AR(1) series with neighbour correlation ρ, the variance of a sum is (1 + ρ)/(1 − ρ) that
//! of independent ones (the effective number of independent points n·(1 − ρ)/(1 + ρ)), and never
//! below one independent datum per series. The log-likelihood ratio between candidates, and
//! BIC's penalty with it, is divided by that factor: a lead the shapes cannot carry is split,
//! while a candidate that leaves white residuals (the truth, fitted) keeps BIC's odds. The
//! overdispersion (the best model's χ²/dof) is already in every data-space ΔBIC
//! ([`crate::verdict::decide::overdispersion`]).
//!
//! Only the split among candidates is tempered: `none`'s probability is BIC's own
//! ([`crate::evidence::level_bootstrap`]), so a clean strip, whose candidates gain nothing
//! against `none` that survives the penalty, keeps `none` whatever its residuals look like.

use crate::fits::NeighbourCorrelation;

/// The factor the evidence between candidates is divided by: (1 + ρ)/(1 − ρ) for the neighbour
/// correlation ρ ≥ 0 of the best candidate's residuals, at most the series' mean length (one
/// independent datum per series), never below one.
pub fn between_candidates(c: NeighbourCorrelation) -> f64 {
    let rho = c.rho.max(0.0);
    let inflation = if rho < 1.0 { (1.0 + rho) / (1.0 - rho) } else { f64::INFINITY };
    inflation.min(c.points_per_series.max(1.0)).max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// White residuals keep BIC's odds; a smooth misfit divides them by the AR(1) variance
    /// inflation, bounded by one datum per series.
    #[test]
    fn correlated_misfit_tempers_and_white_noise_does_not() {
        let t = |rho: f64| between_candidates(NeighbourCorrelation { rho, points_per_series: 58.0 });
        assert_eq!(t(0.0), 1.0);
        assert_eq!(t(-0.3), 1.0);
        assert!((t(0.5) - 3.0).abs() < 1e-12);
        assert!((t(0.8) - 9.0).abs() < 1e-12);
        assert_eq!(t(1.0), 58.0);
        assert_eq!(between_candidates(NeighbourCorrelation { rho: 0.99, points_per_series: 0.5 }), 1.0);
    }
}
