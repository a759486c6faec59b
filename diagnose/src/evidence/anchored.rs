//! The calibration anchored to the levels: at given humidities, plus the weighted mean drift of
//! the training levels' parameters from it. The per-level θ a candidate acting on the level
//! parameters predicts (a humidity remap, a temperature dependence), and with the humidity as
//! read their null.

use crate::evidence::context::Ctx;
use crate::evidence::laws;
use crate::fits::{self, Theta};

/// The calibration at humidities `rh` plus a constant drift per parameter, the drift the
/// weighted mean over the levels `train` of θ − calibration: the per-level θ a humidity remap
/// predicts (the null when `rh` is the humidity read).
pub(crate) fn anchored(ctx: &Ctx, rh: &[f64], train: &[usize]) -> Vec<Theta> {
    with_drift(ctx, rh.iter().map(|&h| fits::calibration_theta(ctx.calib, h)).collect(), train)
}

/// `cal` plus the weighted mean over the levels `train` of θ − `cal` per parameter.
pub(crate) fn with_drift(ctx: &Ctx, cal: Vec<Theta>, train: &[usize]) -> Vec<Theta> {
    let mut delta = [0.0; 4];
    for (j, d) in delta.iter_mut().enumerate() {
        let (mut sw, mut s) = (0.0, 0.0);
        for &l in train {
            let w = ctx.weights.weight(&ctx.base.se[l], j);
            s += w * (ctx.base.theta[l][j] - cal[l][j]);
            sw += w;
        }
        *d = if sw > 0.0 { s / sw } else { 0.0 };
    }
    cal.iter().map(|c| [c[0] + delta[0], c[1] + delta[1], c[2] + delta[2], c[3] + delta[3]]).collect()
}

/// −2 ln L of the levels `train`'s θ under [`anchored`] at humidities `rh`.
pub(crate) fn anchored_nll(ctx: &Ctx, rh: &[f64], train: &[usize]) -> f64 {
    anchored_nll_per_level(ctx, rh, train).iter().sum()
}

/// [`anchored_nll`] level by level, in the order of `train`.
pub(crate) fn anchored_nll_per_level(ctx: &Ctx, rh: &[f64], train: &[usize]) -> Vec<f64> {
    let pred = anchored(ctx, rh, train);
    let pick = |v: &[Theta]| train.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
    laws::nll_per_level(&pick(&pred), &pick(&ctx.base.theta), &pick(&ctx.base.se), &pick(&ctx.read_gradient))
}
