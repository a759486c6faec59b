//! Each point's noise, estimated from the scatter of a preliminary fit's residuals.
//!
//! A measured response is the true one plus a relative error (gain calibration, shaker jitter)
//! and an absolute floor (amplifier and ADC noise, the same in A or m whatever the signal). In
//! measured/model − 1 the floor weighs 1/|G|: a point with a small response, such as the current
//! at low frequency or low humidity (its double zero at s = 0, small diffusivity), is noisy.
//! So per channel the variance is modelled as σ² = a² + b²/|G|², with a and b ≥ 0 found by
//! maximum likelihood from the residuals.

use crate::response::{Channel, Point, Sigma};
use ipmc_core::C;

/// Noise of one channel: σ² = rel² + floor²/|G|², the same for ln gain and phase [rad] (a
/// complex error that is equally likely in every direction, which both parts of the
/// measurement share: the one FFT bin they come from).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ChannelNoise {
    /// Relative part (dimensionless).
    pub rel: f64,
    /// Absolute floor in the channel's unit (m/m or A/m).
    pub floor: f64,
}

impl ChannelNoise {
    pub fn sigma(&self, gain: f64) -> f64 {
        (self.rel * self.rel + (self.floor / gain).powi(2)).sqrt()
    }
}

/// No σ below this: an exact (noise-free) data set must not give infinite weights.
const SIGMA_FLOOR: f64 = 1e-9;

/// Maximum-likelihood σ² = a² + b²·x (x = 1/|G|², a, b ≥ 0) from complex errors whose two
/// parts each have variance σ², given as |e|². With t = b²/a² the best a² for a given t is
/// closed-form, so the likelihood is profiled over t alone: a log grid spanning every ratio of
/// floor to relative noise that the data's gains can tell apart, refined by golden section,
/// against the two pure models. (Least squares on e² instead is swamped by the noisiest points
/// and flips between the pure models when iteratively reweighted.)
fn fit_variance(x: &[f64], e2: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    // −2·log-likelihood up to a constant for σ² = a²·(1 + t·x) with a² at its optimum.
    let nll = |t: f64| {
        let mut sum_ln_v = 0.0;
        let mut s = 0.0;
        for (&xi, &ei) in x.iter().zip(e2) {
            let v = 1.0 + t * xi;
            sum_ln_v += v.ln();
            s += ei / v;
        }
        let a2 = s / (2.0 * n);
        (2.0 * sum_ln_v + 2.0 * n * a2.ln(), a2)
    };
    let only_floor = {
        let b2 = x.iter().zip(e2).map(|(xi, ei)| ei / xi).sum::<f64>() / (2.0 * n);
        (2.0 * x.iter().map(|xi| (b2 * xi).ln()).sum::<f64>(), (0.0, b2))
    };
    if !(e2.iter().any(|&e| e > 0.0)) {
        return (0.0, 0.0);
    }
    let mut xs: Vec<f64> = x.to_vec();
    xs.sort_by(f64::total_cmp);
    let (x_lo, x_hi) = (xs[0].max(f64::MIN_POSITIVE), xs[xs.len() - 1].max(f64::MIN_POSITIVE));
    // t·x from 1e-3 at the largest x (floor negligible everywhere) to 1e3 at the smallest.
    let (lt_lo, lt_hi) = ((1e-3 / x_hi).ln(), (1e3 / x_lo).ln());
    // ln t steps of about 1 (the likelihood is smooth in ln t); golden section does the rest.
    const STEPS: usize = 24;
    let lt = |k: usize| lt_lo + (lt_hi - lt_lo) * k as f64 / STEPS as f64;
    let best_k = (0..=STEPS).min_by(|&a, &b| nll(lt(a).exp()).0.total_cmp(&nll(lt(b).exp()).0)).expect("non-empty grid");
    let (mut lo, mut hi) = (lt(best_k.saturating_sub(1)), lt((best_k + 1).min(STEPS)));
    const INV_PHI: f64 = 0.618_033_988_749_894_9;
    for _ in 0..25 {
        let (m1, m2) = (hi - (hi - lo) * INV_PHI, lo + (hi - lo) * INV_PHI);
        if nll(m1.exp()).0 < nll(m2.exp()).0 { hi = m2 } else { lo = m1 }
    }
    let t = (0.5 * (lo + hi)).exp();
    let mixed = nll(t);
    let only_rel = nll(0.0);
    let candidates = [(mixed.0, (mixed.1, mixed.1 * t)), (only_rel.0, (only_rel.1, 0.0)), only_floor];
    candidates.into_iter().filter(|c| c.0.is_finite()).min_by(|a, b| a.0.total_cmp(&b.0)).map(|c| c.1).unwrap_or((0.0, 0.0))
}

/// Estimates the noise of `channel` from the relative errors (measured/model − 1) of a fit with
/// `n_fitted` parameters over all `points` (`None` when the channel has fewer than three points).
pub fn estimate(points: &[Point], errors: &[C<f64>], model_gains: &[f64], channel: Channel, n_fitted: usize) -> Option<ChannelNoise> {
    let idx: Vec<usize> = (0..points.len()).filter(|&i| points[i].channel == channel).collect();
    if idx.len() < 3 {
        return None;
    }
    let x: Vec<f64> = idx.iter().map(|&i| model_gains[i].powi(-2)).collect();
    let e2: Vec<f64> = idx.iter().map(|&i| errors[i].norm_sqr()).collect();
    let (a2, b2) = fit_variance(&x, &e2);
    // Residuals of a fit are smaller than the noise by the parameters it absorbed; the fitted
    // parameters are shared by all 2·N residuals of the fit.
    let m = 2 * points.len();
    let dof_scale = m as f64 / (m.saturating_sub(n_fitted)).max(1) as f64;
    Some(ChannelNoise { rel: (a2 * dof_scale).sqrt(), floor: (b2 * dof_scale).sqrt() })
}

/// σ of every point from its channel's noise and the model's gain there.
pub fn sigmas(points: &[Point], model_gains: &[f64], noise: &[(Channel, ChannelNoise)]) -> Vec<Sigma> {
    points
        .iter()
        .zip(model_gains)
        .map(|(pt, &g)| match noise.iter().find(|(c, _)| *c == pt.channel) {
            Some((_, n)) => {
                let s = n.sigma(g).max(SIGMA_FLOOR);
                Sigma { ln_gain: s, phase: s }
            }
            None => Sigma::UNIT,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Residuals drawn with a known relative part and floor: both come back within the
    /// sampling error of a variance from 400 points.
    #[test]
    fn recovers_relative_part_and_floor() {
        let mut state = 12345u64;
        let mut gauss = move || {
            // Box–Muller from an LCG: only needs to be roughly Gaussian for this check.
            let mut u = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (2.0 * core::f64::consts::PI * b).cos()
        };
        let (rel, floor) = (0.02, 3e-3);
        let n = 400;
        let gains: Vec<f64> = (0..n).map(|i| 10f64.powf(-2.0 + 3.0 * i as f64 / n as f64)).collect();
        let points: Vec<Point> = gains.iter().map(|&g| Point::new(10.0, Channel::Current, g, 0.0)).collect();
        let ratios: Vec<C<f64>> = gains
            .iter()
            .map(|&g| {
                let s = (rel * rel + (floor / g).powi(2)).sqrt();
                C::new(s * gauss(), s * gauss())
            })
            .collect();
        let est = estimate(&points, &ratios, &gains, Channel::Current, 0).unwrap();
        assert!((est.rel / rel - 1.0).abs() < 0.15, "{est:?}");
        assert!((est.floor / floor - 1.0).abs() < 0.15, "{est:?}");
        assert!(estimate(&points[..2], &ratios[..2], &gains[..2], Channel::Current, 0).is_none());
        assert!(estimate(&points, &ratios, &gains, Channel::Tip, 0).is_none());
    }
}
