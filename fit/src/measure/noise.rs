//! Each point's noise, estimated from the scatter of a preliminary fit's residuals.
//!
//! A measured response is the true one plus a relative error (gain calibration, shaker jitter)
//! and an absolute floor (amplifier and ADC noise, the same in A or m whatever the signal). In
//! measured/model − 1 the floor weighs 1/|G|: a point with a small response, such as the current
//! at low frequency or low humidity (its double zero at s = 0, small diffusivity), is noisy.
//!
//! The floor is absolute in the output, but a response is output over base motion: where the
//! shaker is held to an acceleration limit, the base amplitude falls as 1/f² and the same
//! output floor grows as f² in the response. A sweep that goes past that limit (a wideband
//! follow-up) therefore has a floor that a flat term cannot state: the misfit at the top of
//! the sweep would be read as physics. So per channel the variance is modelled as
//! σ² = a² + (b² + c²·(f/1 kHz)⁴)/|G|², with a, b, c ≥ 0 found by maximum likelihood from
//! the residuals; the rising part is kept only when it pays its parameter (BIC), so a band
//! below the limit keeps the two-term model.

use crate::measure::point::{Channel, Point, Sigma};
use crate::numeric::scalar::minimize_log;
use ipmc_core::C;

/// Noise of one channel: σ² = rel² + (floor² + floor_rising²·(f/1 kHz)⁴)/|G|², the same for
/// ln gain and phase [rad] (a complex error that is equally likely in every direction, which
/// both parts of the measurement share: the one FFT bin they come from).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ChannelNoise {
    /// Relative part (dimensionless).
    pub rel: f64,
    /// Absolute floor in the channel's unit (m/m or A/m).
    pub floor: f64,
    /// The floor's part that rises as f² (an acceleration-limited drive), at 1 kHz, in the
    /// channel's unit; 0 where the data do not pay for it.
    pub floor_rising: f64,
}

/// Where the rising floor is stated: f⁴ in kHz keeps its fitted weights within f64's range.
const RISING_AT_HZ: f64 = 1e3;

impl ChannelNoise {
    pub fn sigma(&self, gain: f64, freq_hz: f64) -> f64 {
        let rising = self.floor_rising * (freq_hz / RISING_AT_HZ).powi(2);
        (self.rel * self.rel + (self.floor * self.floor + rising * rising) / (gain * gain)).sqrt()
    }
}

/// No σ below this: an exact (noise-free) data set must not give infinite weights.
const SIGMA_FLOOR: f64 = 1e-9;

/// Maximum-likelihood σ² = a² + b²·x (x = 1/|G|², a, b ≥ 0) from complex errors whose two
/// parts each have variance σ², given as |e|². With t = b²/a² the best a² for a given t is
/// closed-form, so the likelihood is profiled over t alone: a log grid spanning every ratio of
/// floor to relative noise that the data's gains can tell apart, refined by golden section,
/// against the two pure models. (Least squares on e² instead is swamped by the noisiest points
/// and flips between the pure models when iteratively reweighted.) Returns (−2 ln L up to a
/// constant, a², b²).
fn fit_variance(x: &[f64], e2: &[f64]) -> (f64, f64, f64) {
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
        return (f64::INFINITY, 0.0, 0.0);
    }
    let mut xs: Vec<f64> = x.to_vec();
    xs.sort_by(f64::total_cmp);
    let (x_lo, x_hi) = (xs[0].max(f64::MIN_POSITIVE), xs[xs.len() - 1].max(f64::MIN_POSITIVE));
    // t·x from 1e-3 at the largest x (floor negligible everywhere) to 1e3 at the smallest.
    // The likelihood is smooth in ln t: a grid over ln t and golden section do.
    let (t, _) = minimize_log(|t| nll(t).0, 1e-3 / x_hi, 1e3 / x_lo);
    let mixed = nll(t);
    let only_rel = nll(0.0);
    let candidates = [(mixed.0, (mixed.1, mixed.1 * t)), (only_rel.0, (only_rel.1, 0.0)), only_floor];
    candidates
        .into_iter()
        .filter(|c| c.0.is_finite())
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or((f64::INFINITY, 0.0, 0.0), |(nll, (a2, b2))| (nll, a2, b2))
}

/// [`fit_variance`] with a floor that also rises: σ² = a² + b²·x + c²·y (y = x·(f/1 kHz)⁴).
/// For a ratio v = c²/b² it is the two-term problem in x + v·y, so the likelihood is profiled
/// over ln v as over ln t, against the purely rising floor (b = 0). Returns (−2 ln L, a², b², c²).
fn fit_variance_rising(x: &[f64], y: &[f64], e2: &[f64]) -> (f64, f64, f64, f64) {
    const NO_FIT: (f64, f64, f64, f64) = (f64::INFINITY, 0.0, 0.0, 0.0);
    let at = |v: f64| {
        let xv: Vec<f64> = x.iter().zip(y).map(|(xi, yi)| xi + v * yi).collect();
        let (nll, a2, b2) = fit_variance(&xv, e2);
        (nll, a2, b2, b2 * v)
    };
    let ratio: Vec<f64> = x.iter().zip(y).filter(|(xi, _)| **xi > 0.0).map(|(xi, yi)| yi / xi).filter(|r| *r > 0.0).collect();
    let (Some(r_lo), Some(r_hi)) = (ratio.iter().copied().reduce(f64::min), ratio.iter().copied().reduce(f64::max)) else {
        return NO_FIT;
    };
    // v·y/x from 1e-3 at the top of the band (the rising part negligible) to 1e3 at its bottom.
    let (v, _) = minimize_log(|v| at(v).0, 1e-3 / r_hi, 1e3 / r_lo);
    let mixed = at(v);
    let only_rising = {
        let (nll, a2, c2) = fit_variance(y, e2);
        (nll, a2, 0.0, c2)
    };
    [mixed, only_rising].into_iter().filter(|c| c.0.is_finite()).min_by(|a, b| a.0.total_cmp(&b.0)).unwrap_or(NO_FIT)
}

/// Estimates the noise of `channel` from the relative errors (measured/model − 1) of a fit with
/// `n_fitted` parameters over all `points` (`None` when the channel has fewer than three points).
pub fn estimate(points: &[Point], errors: &[C<f64>], model_gains: &[f64], channel: Channel, n_fitted: usize) -> Option<ChannelNoise> {
    let idx: Vec<usize> = (0..points.len()).filter(|&i| points[i].channel == channel).collect();
    if idx.len() < 3 {
        return None;
    }
    let x: Vec<f64> = idx.iter().map(|&i| model_gains[i].powi(-2)).collect();
    let y: Vec<f64> = idx.iter().zip(&x).map(|(&i, xi)| xi * (points[i].freq_hz / RISING_AT_HZ).powi(4)).collect();
    let e2: Vec<f64> = idx.iter().map(|&i| errors[i].norm_sqr()).collect();
    let (nll_flat, a2, b2) = fit_variance(&x, &e2);
    // One more parameter, paid as BIC pays it over the 2·N real residuals.
    let rising = fit_variance_rising(&x, &y, &e2);
    let price = ((2 * idx.len()) as f64).ln();
    let (a2, b2, c2) = if rising.0 + price < nll_flat { (rising.1, rising.2, rising.3) } else { (a2, b2, 0.0) };
    // Residuals of a fit are smaller than the noise by the parameters it absorbed; the fitted
    // parameters are shared by all 2·N residuals of the fit.
    let m = 2 * points.len();
    let dof_scale = m as f64 / (m.saturating_sub(n_fitted)).max(1) as f64;
    Some(ChannelNoise { rel: (a2 * dof_scale).sqrt(), floor: (b2 * dof_scale).sqrt(), floor_rising: (c2 * dof_scale).sqrt() })
}

/// σ of every point from its channel's noise and the model's gain there.
pub fn sigmas(points: &[Point], model_gains: &[f64], noise: &[(Channel, ChannelNoise)]) -> Vec<Sigma> {
    points
        .iter()
        .zip(model_gains)
        .map(|(pt, &g)| match noise.iter().find(|(c, _)| *c == pt.channel) {
            Some((_, n)) => {
                let s = n.sigma(g, pt.freq_hz).max(SIGMA_FLOOR);
                Sigma { ln_gain: s, phase: s }
            }
            None => Sigma::UNIT,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gaussian(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            // Box–Muller from an LCG: only needs to be roughly Gaussian for this check.
            let mut u = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            let (a, b) = (u(), u());
            (-2.0 * a.ln()).sqrt() * (2.0 * core::f64::consts::PI * b).cos()
        }
    }

    /// Residuals drawn with a known relative part and floor: both come back within the
    /// sampling error of a variance from 400 points, and a flat floor is not read as rising.
    #[test]
    fn recovers_relative_part_and_floor() {
        let mut gauss = gaussian(12345);
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
        assert_eq!(est.floor_rising, 0.0, "{est:?}");
        assert!(estimate(&points[..2], &ratios[..2], &gains[..2], Channel::Current, 0).is_none());
        assert!(estimate(&points, &ratios, &gains, Channel::Tip, 0).is_none());
    }

    /// A sweep from 10 Hz to 2 kHz whose drive is held to an acceleration limit above 150 Hz:
    /// the output's floor grows as f² in the response there. The model states the error power
    /// of the top octave as it is; the flat floor alone would state a fraction of it.
    #[test]
    fn a_floor_rising_above_the_drive_limit_is_stated() {
        let mut gauss = gaussian(777);
        let (rel, floor) = (0.01, 2e-3);
        let n = 600;
        let freqs: Vec<f64> = (0..n).map(|i| 10.0 * 200f64.powf(i as f64 / (n - 1) as f64)).collect();
        // A resonance near 60 Hz, then a slow roll-off: the gain spans two decades.
        let gains: Vec<f64> = freqs.iter().map(|&f| 1.0 / ((1.0 - (f / 60.0).powi(2)).powi(2) + (f / 600.0).powi(2)).sqrt()).collect();
        let floor_at = |f: f64| floor * (f / 150.0).max(1.0).powi(2);
        let sigma = |g: f64, f: f64| (rel * rel + (floor_at(f) / g).powi(2)).sqrt();
        let points: Vec<Point> = freqs.iter().zip(&gains).map(|(&f, &g)| Point::new(f, Channel::Current, g, 0.0)).collect();
        let errors: Vec<C<f64>> = freqs.iter().zip(&gains).map(|(&f, &g)| C::new(sigma(g, f) * gauss(), sigma(g, f) * gauss())).collect();
        let est = estimate(&points, &errors, &gains, Channel::Current, 0).unwrap();
        assert!(est.floor_rising > 0.0, "{est:?}");
        let top: Vec<usize> = (0..n).filter(|&i| freqs[i] > 1000.0).collect();
        let actual: f64 = top.iter().map(|&i| errors[i].norm_sqr() / 2.0).sum();
        let stated: f64 = top.iter().map(|&i| est.sigma(gains[i], freqs[i]).powi(2)).sum();
        let flat = ChannelNoise { floor_rising: 0.0, ..est };
        let stated_flat: f64 = top.iter().map(|&i| flat.sigma(gains[i], freqs[i]).powi(2)).sum();
        assert!((actual / stated - 1.0).abs() < 0.3, "top octave: actual/stated {}", actual / stated);
        assert!(actual / stated_flat > 3.0, "the flat part alone states it too: {}", actual / stated_flat);
    }
}
