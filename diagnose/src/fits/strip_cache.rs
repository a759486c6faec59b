//! A level's strip responses kept between evaluations that share them. The strip's own
//! responses (`ipmc_core`'s [`strip_responses`]: the beam, the ionic current) are most of the
//! cost of a residual, and many evaluations repeat them: a candidate of the measurement chain
//! (an amplifier's pole, a channel's timing, the feedthrough) moves none of them, nor do the
//! instrument's channels, and a held-out refit holds the training levels' parameters. Where
//! they do move, the current's electrical part ([`ionic_drive`]) mostly does not: only the
//! ionic rate, the diffusivity and the thickness move it, not Y, Cs, Ca or any extension.
//! Kept or not, every value is the one computed afresh, bit for bit.

use ipmc_core::model::exact::{ionic_drive, jw};
use ipmc_core::model::extension::{Extension, strip_responses_with};
use ipmc_core::{C, Params};
use std::cell::RefCell;

/// The strip responses of one level at the last parameters and strip terms asked for, and the
/// electrical parts they were made with.
#[derive(Default)]
pub struct StripCache(RefCell<Kept>);

#[derive(Default)]
struct Kept {
    strip: Option<(Params<f64>, Extension<f64>)>,
    responses: Vec<(C<f64>, C<f64>)>,
    /// K, d and h the drives are of.
    electrical: Option<[f64; 3]>,
    drives: Vec<C<f64>>,
}

impl StripCache {
    /// One empty cache per level.
    pub fn per_level(n: usize) -> Vec<StripCache> {
        (0..n).map(|_| StripCache::default()).collect()
    }

    /// `use_them` given the strip responses at `freqs` with parameters `p` and `x`'s strip
    /// terms ([`strip_responses`]), kept from the last call when it had the same.
    pub fn with<R>(&self, freqs: &[f64], p: &Params<f64>, x: &Extension<f64>, use_them: impl FnOnce(&[(C<f64>, C<f64>)]) -> R) -> R {
        let strip = x.strip_terms();
        let mut kept = self.0.borrow_mut();
        let kept = &mut *kept;
        let same = kept.strip == Some((*p, strip)) && kept.responses.len() == freqs.len();
        if !same {
            let electrical = [p.k_ionic(), p.d, p.h];
            let Kept { responses, drives, .. } = kept;
            if kept.electrical != Some(electrical) || drives.len() != freqs.len() {
                drives.clear();
                drives.extend(freqs.iter().map(|&f| ionic_drive(p, jw(f))));
                kept.electrical = Some(electrical);
            }
            responses.clear();
            responses.extend(freqs.iter().zip(drives.iter()).map(|(&f, &drive)| strip_responses_with(p, &strip, jw(f), drive)));
            kept.strip = Some((*p, strip));
        }
        use_them(&kept.responses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::Calibration;
    use ipmc_core::model::extension::strip_responses;

    /// Kept, partly kept (the electrical part) or computed afresh, the responses are
    /// strip_responses' bit for bit.
    #[test]
    fn kept_responses_are_the_fresh_ones() {
        let calib = Calibration::default_preset();
        let freqs: Vec<f64> = (0..25).map(|i| 10.0 + 6.0 * i as f64).collect();
        let p: Params<f64> = calib.params_at(50.0);
        let x = Extension { amp_tau: [2e-4, 0.0], stokes: 1e-3, ..Default::default() };
        let (mut stiffer, mut wetter) = (p, p);
        stiffer.y *= 1.01;
        wetter.d *= 1.2;
        let tries = [
            (p, Extension { amp_tau: [1e-4, 0.0], ..x }),
            (p, Extension { skew_current: 1e-5, feedthrough: 1e-9, ..x }),
            (p, Extension { stokes: 2e-3, ..x }),
            (stiffer, x),
            (stiffer, Extension { tip_mass: 1e-7, ..x }),
            (wetter, x),
            (p, x),
        ];
        let cache = StripCache::default();
        for (p, x) in tries {
            let want: Vec<_> = freqs.iter().map(|&f| strip_responses(&p, &x, jw(f))).collect();
            cache.with(&freqs, &p, &x, |got| assert_eq!(want, got, "{x:?}"));
        }
    }
}
