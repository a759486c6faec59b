//! The noise of each channel from the scatter between neighbouring points, the σ it gives every
//! value, and how structured the residuals are beyond it.

use super::base::{LevelSigmas, Mask, Theta, level_params, log_ratios};
use ipmc_core::model::extension::Extension;
use ipmc_core::{C, Calibration};
use ipmc_fit::level::LevelData;
use ipmc_fit::noise::{self, ChannelNoise};
use ipmc_fit::response::{Channel, Point, Sigma};

/// Noise of each channel, from the data.
#[derive(Clone, Copy, Debug, Default)]
pub struct Noise {
    pub tip: Option<ChannelNoise>,
    pub current: Option<ChannelNoise>,
}

/// The noise of each channel from the scatter of neighbouring points: the residuals of the
/// per-level base fit are smooth wherever the model misses physics, so their local second
/// difference (linear interpolation in ln f between the two neighbours) keeps the noise and
/// cancels the structure. Its variance is σ²(1 + w₁² + w₂²) for interpolation weights w; points
/// over 4σ (a narrow feature, a line) are left out and the estimate repeated, so that they
/// count as structure, not noise.
pub fn estimate_noise(calib: &Calibration, levels: &[LevelData], thetas: &[Theta]) -> Noise {
    // Per channel: where each residual is, the residual, and its model's magnitude.
    type ChannelResiduals = (Vec<Point>, Vec<C<f64>>, Vec<f64>);
    let mut per_channel: [ChannelResiduals; 2] = Default::default();
    for (level, theta) in levels.iter().zip(thetas) {
        let p = level_params(calib, level, theta);
        let (tip, cur) = log_ratios(level, &p, &Extension::default());
        let ln_f: Vec<f64> = level.freqs.iter().map(|f| f.ln()).collect();
        for (k, (ratios, values, channel)) in
            [(&tip, &level.tip, Channel::Tip), (&cur, &level.current, Channel::Current)].into_iter().enumerate()
        {
            let idx: Vec<usize> = (0..ratios.len()).filter(|&i| ratios[i].is_some()).collect();
            for w in idx.windows(3) {
                let (a, b, c) = (w[0], w[1], w[2]);
                let span = ln_f[c] - ln_f[a];
                if span <= 0.0 {
                    continue;
                }
                let wa = (ln_f[c] - ln_f[b]) / span;
                let wc = 1.0 - wa;
                let e = ratios[b].unwrap() - ratios[a].unwrap() * wa - ratios[c].unwrap() * wc;
                let e = e / (1.0 + wa * wa + wc * wc).sqrt();
                let gain = values[b].unwrap().norm();
                per_channel[k].0.push(Point { freq_hz: level.freqs[b], channel, value: values[b].unwrap() });
                per_channel[k].1.push(e);
                per_channel[k].2.push(gain);
            }
        }
    }
    let mut out = Noise::default();
    for (k, channel) in [Channel::Tip, Channel::Current].into_iter().enumerate() {
        let (mut pts, mut e, mut g) = std::mem::take(&mut per_channel[k]);
        let mut est = noise::estimate(&pts, &e, &g, channel, 0);
        for _ in 0..2 {
            let Some(n) = est else { break };
            let keep: Vec<bool> =
                e.iter().zip(&g).zip(&pts).map(|((e, &g), p)| e.re.abs().max(e.im.abs()) <= 4.0 * n.sigma(g, p.freq_hz)).collect();
            let kept = |i: &usize| keep[*i];
            let idx: Vec<usize> = (0..keep.len()).filter(kept).collect();
            if idx.len() == keep.len() {
                // Nothing left out: the estimate again would be this one.
                break;
            }
            pts = idx.iter().map(|&i| pts[i]).collect();
            e = idx.iter().map(|&i| e[i]).collect();
            g = idx.iter().map(|&i| g[i]).collect();
            // Dropping the tails of a Gaussian at 4σ shrinks its variance by < 0.1 %.
            est = noise::estimate(&pts, &e, &g, channel, 0).or(est);
        }
        match channel {
            Channel::Tip => out.tip = est,
            Channel::Current => out.current = est,
        }
    }
    out
}

/// σ of each value from the noise model at the measured gain (fixed through the fits).
pub fn sigmas(level: &LevelData, noise: &Noise) -> LevelSigmas {
    let one = |v: &Option<C<f64>>, f: f64, n: &Option<ChannelNoise>| match (v, n) {
        (Some(v), Some(n)) => {
            let s = n.sigma(v.norm(), f).max(1e-6);
            Sigma { ln_gain: s, phase: s }
        }
        _ => Sigma::UNIT,
    };
    LevelSigmas {
        tip: level.tip.iter().zip(&level.freqs).map(|(v, &f)| one(v, f, &noise.tip)).collect(),
        current: level.current.iter().zip(&level.freqs).map(|(v, &f)| one(v, f, &noise.current)).collect(),
    }
}

/// How structured the residuals are: the correlation of each weighted residual with its
/// neighbour in frequency (same level, channel and component), as a z. A model that misses
/// physics leaves residuals that are smooth in frequency (z ≫ 0) whatever the noise level; noise,
/// even misjudged in size, leaves them uncorrelated (z ≈ 0 ± 1).
pub fn structure_z(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    theta: &[Theta],
    ext: &[Extension<f64>],
) -> f64 {
    let n = neighbour_sums(calib, levels, sig, masks, theta, ext);
    if n.products_sq > 0.0 { n.products / n.products_sq.sqrt() } else { 0.0 }
}

/// How correlated the weighted residuals are along frequency: their integrated autocorrelation
/// time ([`ipmc_fit::stats::autocorrelation_time_of`], the estimator `recalibrate` widens its
/// bins by, over one series per level, channel and component) and the series' mean length.
/// One for white noise; large where a smooth misfit dominates the residuals.
pub fn residual_correlation(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    theta: &[Theta],
    ext: &[Extension<f64>],
) -> ResidualCorrelation {
    let mut series: Vec<Vec<f64>> = Vec::new();
    for (l, level) in levels.iter().enumerate() {
        for r in weighted_series(calib, level, &sig[l], &masks[l], &theta[l], &ext[l]) {
            if r.len() >= 2 {
                series.push(r.iter().map(|z| z.re).collect());
                series.push(r.iter().map(|z| z.im).collect());
            }
        }
    }
    let points: usize = series.iter().map(Vec::len).sum();
    let views: Vec<&[f64]> = series.iter().map(Vec::as_slice).collect();
    ResidualCorrelation {
        tau: ipmc_fit::stats::autocorrelation_time_of(&views),
        points_per_series: if series.is_empty() { 1.0 } else { points as f64 / series.len() as f64 },
    }
}

/// The integrated autocorrelation time of residuals along frequency and the mean length of the
/// series it was taken over (one series per level, channel and component).
#[derive(Clone, Copy, Debug)]
pub struct ResidualCorrelation {
    pub tau: f64,
    pub points_per_series: f64,
}

/// A level's weighted residuals along frequency where the mask keeps them, per channel (tip,
/// current): ln-gain over its σ as the real part, phase over its σ as the imaginary.
fn weighted_series(
    calib: &Calibration,
    level: &LevelData,
    sig: &LevelSigmas,
    mask: &Mask,
    theta: &Theta,
    ext: &Extension<f64>,
) -> [Vec<C<f64>>; 2] {
    let p = level_params(calib, level, theta);
    let (tip, cur) = log_ratios(level, &p, ext);
    let one = |ratios: &[Option<C<f64>>], sigmas: &[Sigma], on: &[bool]| -> Vec<C<f64>> {
        (0..ratios.len())
            .filter(|&i| on[i])
            .filter_map(|i| ratios[i].map(|z| C::new(z.re / sigmas[i].ln_gain, z.im / sigmas[i].phase)))
            .collect()
    };
    [one(&tip, &sig.tip, &mask.tip), one(&cur, &sig.current, &mask.current)]
}

/// Sums over neighbouring weighted residuals: Σ a·b and Σ a²·b².
struct NeighbourSums {
    products: f64,
    products_sq: f64,
}

fn neighbour_sums(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    theta: &[Theta],
    ext: &[Extension<f64>],
) -> NeighbourSums {
    let mut out = NeighbourSums { products: 0.0, products_sq: 0.0 };
    for (l, level) in levels.iter().enumerate() {
        for r in weighted_series(calib, level, &sig[l], &masks[l], &theta[l], &ext[l]) {
            for w in r.windows(2) {
                for (a, b) in [(w[0].re, w[1].re), (w[0].im, w[1].im)] {
                    out.products += a * b;
                    out.products_sq += a * a * b * b;
                }
            }
        }
    }
    out
}
