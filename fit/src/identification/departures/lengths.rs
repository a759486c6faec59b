//! The departure's length averaged over, not taken at its REML point. Levels a step s apart,
//! each visited once, cannot tell a departure of length ℓ ≲ s/2 from one of s/2: both make the
//! levels independent, and the likelihood is flat below there. A point estimate near s would
//! claim that the strip between two levels is the smooth interpolation of them, with a small
//! sd there, while a strip departing every half step is as far off midway as anywhere.
//!
//! So per parameter with a departure, ℓ takes a grid log-spaced over its search bounds, the other
//! hyperparameters at their REML point, the amplitude the REML one given that length (profiled:
//! a length shorter than the spacing makes the levels white, and their scatter is then the whole
//! amplitude). Each grid point weighs the restricted likelihood there times its step in ln ℓ,
//! wⱼ ∝ e^(−REML negative log-likelihood)·Δln ℓ: the posterior of ℓ under a log-uniform prior
//! over the bounds. Log-uniform because a length is a scale: nothing says 1 %RH is likelier than
//! 10 %RH, and a prior uniform in ℓ would put nearly all its mass at the long end. Where the data
//! decide the length the prior does not matter; where they do not (below the spacing) the
//! weight follows the prior, so the lower bound sets how much weight the short, unknowable
//! lengths get, and moves the stated sd between levels only between the point model's and the
//! full amplitude.

use super::hyper::{AMPLITUDE, LENGTH_PCT, Spread};
use super::problem::Problem;
use crate::numeric::stats::nelder_mead;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// Points of the grid of lengths averaged over: a ratio of ~1.5 between neighbours over a
/// bench session's 40 %RH, fine against the likelihood's width in ln ℓ where the data decide.
const LENGTH_GRID: usize = 14;
/// Weight below which a length's posterior is dropped from the mixture (after normalizing).
const NEGLIGIBLE_WEIGHT: f64 = 1e-4;

/// One length of a parameter's departure in the average over lengths: its posterior weight,
/// the amplitude the likelihood takes at that length and the posterior given both.
#[derive(Clone, Debug)]
pub(super) struct Component {
    pub(super) weight: f64,
    pub(super) amplitude: f64,
    pub(super) length_pct: f64,
    pub(super) beta: DVector<f64>,
    pub(super) alpha: DVector<f64>,
    pub(super) chol: Cholesky<f64, Dyn>,
    pub(super) hch_inv: DMatrix<f64>,
}

/// The posteriors of parameter k over a grid of its departure's length, weighted by the
/// restricted likelihood under a log-uniform prior on the length (this file's doc); the other
/// hyperparameters at their REML point (`amplitude`, `length`), k's amplitude the likelihood's
/// best at each length. Empty when no length gives a posterior.
pub(super) fn over_lengths(
    p: &Problem<'_>,
    k: usize,
    amplitude: &[f64; 4],
    length: &[f64; 4],
    spread: Spread,
    max_length: f64,
) -> Vec<Component> {
    let (lo, hi) = (LENGTH_PCT.0.ln(), max_length.ln());
    let step = (hi - lo) / (LENGTH_GRID - 1) as f64;
    let mut fits: Vec<(f64, Component)> = Vec::with_capacity(LENGTH_GRID);
    for j in 0..LENGTH_GRID {
        let mut lengths = *length;
        lengths[k] = (lo + step * j as f64).exp().clamp(LENGTH_PCT.0, max_length);
        let with = |ln_a: f64| {
            let mut a = *amplitude;
            a[k] = ln_a.exp().clamp(AMPLITUDE.0, AMPLITUDE.1);
            a
        };
        let nll = |u: &[f64]| p.reml(p.covariance(&with(u[0]), &lengths, spread)).map_or(f64::INFINITY, |r| r.0);
        // From no smaller than a percent: below the levels' errors the likelihood is flat in A
        // and a simplex started there would not move.
        let (u, _) = nelder_mead(&nll, &[amplitude[k].max(0.01).ln()], 0.7, 1e-9, 300);
        let (u, _) = nelder_mead(&nll, &u, 0.2, 1e-10, 200);
        let a = with(u[0]);
        let Some((v, post)) = p.reml(p.covariance(&a, &lengths, spread)) else { continue };
        // Trapezoid in ln ℓ: the two ends carry half a step.
        let dl = if j == 0 || j + 1 == LENGTH_GRID { 0.5 * step } else { step };
        let component = Component {
            weight: 0.0,
            amplitude: a[k],
            length_pct: lengths[k],
            beta: post.beta,
            alpha: post.alpha,
            chol: post.chol,
            hch_inv: post.hch_inv,
        };
        fits.push((-v + dl.max(f64::MIN_POSITIVE).ln(), component));
    }
    let Some(top) = fits.iter().map(|f| f.0).reduce(f64::max) else { return vec![] };
    let total: f64 = fits.iter().map(|f| (f.0 - top).exp()).sum();
    let mut kept: Vec<Component> = fits
        .into_iter()
        .map(|(lw, c)| Component { weight: (lw - top).exp() / total, ..c })
        .filter(|c| c.weight >= NEGLIGIBLE_WEIGHT)
        .collect();
    let kept_total: f64 = kept.iter().map(|c| c.weight).sum();
    for c in &mut kept {
        c.weight /= kept_total;
    }
    kept
}
