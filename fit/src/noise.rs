//! Each point's noise, estimated from the scatter of a preliminary fit's residuals.
//!
//! A measured response is the true one plus a relative error (gain calibration, shaker jitter)
//! and an absolute floor (amplifier and ADC noise, the same in A or m whatever the signal). In
//! ln(measured/model) the floor weighs 1/|G|: a point with a small response, such as the current
//! at low frequency or low humidity (its double zero at s = 0, small diffusivity), is noisy.
//! So per channel and per component (log gain, phase) the variance is modelled as
//! σ² = a² + b²/|G|², with a and b ≥ 0 fitted to the squared residuals by least squares.

use crate::response::{Channel, Point, Sigma};
use ipmc_core::C;

/// Variance model of one component: σ² = rel² + floor²/|G|².
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct NoiseModel {
    /// Relative part (dimensionless; radians for the phase).
    pub rel: f64,
    /// Absolute floor in the channel's unit (m/m or A/m).
    pub floor: f64,
}

impl NoiseModel {
    pub fn sigma(&self, gain: f64) -> f64 {
        (self.rel * self.rel + (self.floor / gain).powi(2)).sqrt()
    }
}

/// Noise of one channel.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ChannelNoise {
    pub ln_gain: NoiseModel,
    pub phase: NoiseModel,
}

/// No σ below this: an exact (noise-free) data set must not give infinite weights.
const SIGMA_FLOOR: f64 = 1e-9;

/// Fits σ² = a² + b²·x (x = 1/|G|²) to squared residuals with a², b² ≥ 0.
///
/// A squared residual scatters by about its own variance, so the points where the floor
/// dominates would swamp an unweighted fit: iteratively reweighted by 1/σ⁴.
fn fit_variance(x: &[f64], r2: &[f64], dof_scale: f64) -> NoiseModel {
    let mut weights = vec![1.0; x.len()];
    let (mut a2, mut b2) = (0.0, 0.0);
    for _ in 0..4 {
        (a2, b2) = weighted_nonneg_line(x, r2, &weights);
        for (w, &xi) in weights.iter_mut().zip(x) {
            let v = a2 + b2 * xi;
            *w = if v > 0.0 { 1.0 / (v * v) } else { 1.0 };
        }
    }
    NoiseModel { rel: (a2 * dof_scale).sqrt(), floor: (b2 * dof_scale).sqrt() }
}

/// Weighted least squares y ≈ a + b·x with a, b ≥ 0.
fn weighted_nonneg_line(x: &[f64], y: &[f64], w: &[f64]) -> (f64, f64) {
    let s = |f: &dyn Fn(usize) -> f64| (0..x.len()).map(|i| w[i] * f(i)).sum::<f64>();
    let (sw, sx, sy) = (s(&|_| 1.0), s(&|i| x[i]), s(&|i| y[i]));
    let (sxx, sxy) = (s(&|i| x[i] * x[i]), s(&|i| x[i] * y[i]));
    let det = sw * sxx - sx * sx;
    if det > 1e-12 * sw * sxx {
        let (a, b) = ((sy * sxx - sx * sxy) / det, (sw * sxy - sx * sy) / det);
        if a >= 0.0 && b >= 0.0 {
            return (a, b);
        }
    }
    // The non-negative solution lies on a face when the free one leaves the quadrant.
    let only_a = sy / sw;
    let only_b = if sxx > 0.0 { (sxy / sxx).max(0.0) } else { 0.0 };
    let sse = |a: f64, b: f64| (0..x.len()).map(|i| w[i] * (y[i] - a - b * x[i]).powi(2)).sum::<f64>();
    if sse(only_a, 0.0) <= sse(0.0, only_b) { (only_a, 0.0) } else { (0.0, only_b) }
}

/// Estimates the noise of `channel` from the unweighted log ratios of a fit with `n_fitted`
/// parameters over all `points` (`None` when the channel has fewer than three points).
pub fn estimate(points: &[Point], log_ratios: &[C<f64>], model_gains: &[f64], channel: Channel, n_fitted: usize) -> Option<ChannelNoise> {
    let idx: Vec<usize> = (0..points.len()).filter(|&i| points[i].channel == channel).collect();
    if idx.len() < 3 {
        return None;
    }
    let x: Vec<f64> = idx.iter().map(|&i| model_gains[i].powi(-2)).collect();
    let re2: Vec<f64> = idx.iter().map(|&i| log_ratios[i].re.powi(2)).collect();
    let im2: Vec<f64> = idx.iter().map(|&i| log_ratios[i].im.powi(2)).collect();
    // Residuals of a fit are smaller than the noise by the parameters it absorbed; the fitted
    // parameters are shared by all 2·N residuals of the fit.
    let m = 2 * points.len();
    let dof_scale = m as f64 / (m.saturating_sub(n_fitted)).max(1) as f64;
    Some(ChannelNoise { ln_gain: fit_variance(&x, &re2, dof_scale), phase: fit_variance(&x, &im2, dof_scale) })
}

/// σ of every point from its channel's noise and the model's gain there.
pub fn sigmas(points: &[Point], model_gains: &[f64], noise: &[(Channel, ChannelNoise)]) -> Vec<Sigma> {
    points
        .iter()
        .zip(model_gains)
        .map(|(pt, &g)| match noise.iter().find(|(c, _)| *c == pt.channel) {
            Some((_, n)) => Sigma { ln_gain: n.ln_gain.sigma(g).max(SIGMA_FLOOR), phase: n.phase.sigma(g).max(SIGMA_FLOOR) },
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
        for m in [est.ln_gain, est.phase] {
            assert!((m.rel / rel - 1.0).abs() < 0.2, "{m:?}");
            assert!((m.floor / floor - 1.0).abs() < 0.2, "{m:?}");
        }
        assert!(estimate(&points[..2], &ratios[..2], &gains[..2], Channel::Current, 0).is_none());
        assert!(estimate(&points, &ratios, &gains, Channel::Tip, 0).is_none());
    }
}
