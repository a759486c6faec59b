//! Levels made by the model for the fits' tests.

use super::base::LevelSigmas;
use ipmc_core::C;
use ipmc_fit::level::LevelData;
use ipmc_fit::response::Sigma;

/// A level at `rh` recorded as (tip, current) `r` at `freqs`.
pub(super) fn recorded(rh: f64, freqs: &[f64], r: Vec<(C<f64>, C<f64>)>) -> LevelData {
    LevelData {
        session: 0,
        rh_pct: rh,
        temp_c: None,
        time_s: None,
        time_span: None,
        revisit_of: None,
        tip: r.iter().map(|v| Some(v.0)).collect(),
        current: r.iter().map(|v| Some(v.1)).collect(),
        freqs: freqs.to_vec(),
        kappa_e: None,
    }
}

/// The same σ at every point of each channel.
pub(super) fn even_sigmas(levels: &[LevelData], tip: f64, current: f64) -> Vec<LevelSigmas> {
    levels
        .iter()
        .map(|l| LevelSigmas {
            tip: vec![Sigma { ln_gain: tip, phase: tip }; l.freqs.len()],
            current: vec![Sigma { ln_gain: current, phase: current }; l.freqs.len()],
        })
        .collect()
}
