//! A level's strip responses kept between evaluations that share them. The strip's own
//! responses (`ipmc_core`'s [`strip_responses`]: the beam, the ionic current) are most of the
//! cost of a residual, and many evaluations repeat them: a candidate of the measurement chain
//! (an amplifier's pole, a channel's timing, the feedthrough) moves none of them, nor do the
//! instrument's channels, and a held-out refit holds the training levels' parameters. The
//! residuals are those of [`super::write_residuals`], bit for bit.

use super::base::{LevelSigmas, Mask, write_weighted};
use ipmc_core::model::exact::jw;
use ipmc_core::model::extension::{Extension, strip_responses, through_chains};
use ipmc_core::{C, Params};
use ipmc_fit::level::LevelData;
use std::cell::RefCell;

/// The strip responses of one level at the last parameters and strip terms asked for.
#[derive(Default)]
pub struct StripCache(RefCell<Option<Kept>>);

struct Kept {
    p: Params<f64>,
    strip: Extension<f64>,
    responses: Vec<(C<f64>, C<f64>)>,
}

impl StripCache {
    /// One empty cache per level.
    pub fn per_level(n: usize) -> Vec<StripCache> {
        (0..n).map(|_| StripCache::default()).collect()
    }

    /// [`super::write_residuals`] of `level`, whose strip responses at `p` and `x`'s strip
    /// terms are taken from the last call when it had the same (else computed and kept).
    pub fn write_residuals(&self, level: &LevelData, sig: &LevelSigmas, mask: &Mask, p: &Params<f64>, x: &Extension<f64>, out: &mut [f64]) {
        let strip = x.strip_terms();
        let mut kept = self.0.borrow_mut();
        let same = kept.as_ref().is_some_and(|k| k.p == *p && k.strip == strip && k.responses.len() == level.freqs.len());
        if !same {
            let responses = level.freqs.iter().map(|&f| strip_responses(p, &strip, jw(f))).collect();
            *kept = Some(Kept { p: *p, strip, responses });
        }
        let responses = &kept.as_ref().expect("kept above").responses;
        write_weighted(level, sig, mask, |i, s| through_chains(x, s, responses[i]), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fits::base::write_residuals;
    use crate::fits::test_levels::{even_sigmas, recorded};
    use ipmc_core::Calibration;
    use ipmc_core::model::extension::responses;

    /// Kept or computed afresh, through any chain, the residuals are write_residuals' bit for bit.
    #[test]
    fn kept_responses_give_the_same_residuals() {
        let calib = Calibration::default_preset();
        let freqs: Vec<f64> = (0..25).map(|i| 10.0 + 6.0 * i as f64).collect();
        let p: Params<f64> = calib.params_at(50.0);
        let truth = Extension { amp_tau: [2e-4, 0.0], stokes: 1e-3, ..Default::default() };
        let level = recorded(50.0, &freqs, freqs.iter().map(|&f| responses(&p, &truth, jw(f))).collect());
        let sig = even_sigmas(std::slice::from_ref(&level), 0.01, 0.01).remove(0);
        let mask = Mask::all(&level);
        let cache = StripCache::default();
        let mut moved = p;
        moved.y *= 1.01;
        let tries = [
            (p, Extension { amp_tau: [1e-4, 0.0], ..truth }),
            (p, Extension { skew_current: 1e-5, feedthrough: 1e-9, ..truth }),
            (p, Extension { stokes: 2e-3, ..truth }),
            (moved, truth),
            (moved, Extension { electrode_tau_distributed: 3e-4, ..truth }),
        ];
        for (p, x) in tries {
            let (mut want, mut got) = (vec![0.0; mask.count()], vec![1.0; mask.count()]);
            write_residuals(&level, &sig, &mask, &p, &x, &mut want);
            cache.write_residuals(&level, &sig, &mask, &p, &x, &mut got);
            assert_eq!(want, got, "{x:?}");
        }
    }
}
