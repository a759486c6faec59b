//! Whether the stated error bars hold: the actual in-band error of an estimate against the
//! expected error (1σ) it was stated with, window by window and burst by burst. Honest bars
//! contain the actual error about 68 % of the time.
//!
//! "In band" is what the expected error speaks of: the DFT lines of the design band (10–150 Hz)
//! of each window, error against true base. The double integration leaves the estimate a
//! low-frequency wander far larger than the signal (50× on the external recordings); a window
//! that is not a whole number of periods of everything in it would leak that wander into the
//! band, and a high-pass run over the burst first leaks its own edge transients instead
//! (measured: 68 % where the exact figure is 28 %). So the windows must be whole periods of a
//! periodic excitation with the chain settled (`ipmc loop-bursts` makes such recordings), and the
//! DFT is taken as it is.

use super::SETTLE_S;
use ipmc_core::DesignConfig;
use std::ops::Range;

/// One scored stretch: the stated 1σ (rms of the per-sample `rel_err` over it) and the actual
/// relative error (rms of the in-band error over rms of the true base), as fractions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scored {
    pub stated: f64,
    pub actual: f64,
}

impl Scored {
    pub fn covered(&self) -> bool {
        self.actual <= self.stated
    }
}

/// One burst: its humidity reading, the whole burst scored, and its windows.
#[derive(Clone, Debug, PartialEq)]
pub struct Burst {
    pub rh_pct: f64,
    pub whole: Scored,
    pub windows: Vec<Scored>,
}

/// Energy of `x` in the DFT lines of the design band, for a window `x.len()` samples long at `fs_hz`.
fn band_energy(x: &[f64], fs_hz: f64) -> f64 {
    let cfg = DesignConfig::<f64>::default();
    crate::band::energy(x, fs_hz, cfg.band_lo_hz, cfg.band_hi_hz)
}

/// Scores `est` (each sample compared with `base` `delay` samples earlier) against `rel_err` in
/// each burst after its first `settle_s` (at least [`SETTLE_S`]), in windows of `window_s` (whole periods of the
/// excitation, so that its lines fall on the DFT's). Bursts with nothing to score are left out.
#[allow(clippy::too_many_arguments)]
pub fn score(
    est: &[f32],
    rel_err: &[f32],
    base: &[f64],
    rh: &[f64],
    bursts: &[Range<usize>],
    delay: usize,
    fs_hz: f64,
    window_s: f64,
    settle_s: f64,
) -> Vec<Burst> {
    let settle = (settle_s.max(SETTLE_S) * fs_hz).round() as usize;
    let win = ((window_s * fs_hz).round() as usize).max(1);
    let n = est.len().min(rel_err.len()).min(base.len());
    let mut out = vec![];
    for b in bursts {
        let from = (b.start + settle).max(b.start + delay);
        let to = b.end.min(n);
        if from >= to {
            continue;
        }
        let err: Vec<f64> = (from..to).map(|k| est[k] as f64 - base[k - delay]).collect();
        let window = |r: Range<usize>| {
            let ss: f64 = rel_err[r.clone()].iter().map(|&v| (v as f64).powi(2)).sum();
            let truth: Vec<f64> = r.clone().map(|k| base[k - delay]).collect();
            let (se, sb) = (band_energy(&err[r.start - from..r.end - from], fs_hz), band_energy(&truth, fs_hz));
            (Scored { stated: (ss / r.len() as f64).sqrt(), actual: (se / sb).sqrt() }, ss, se, sb)
        };
        let scored: Vec<_> = (0..(to - from) / win).map(|w| window(from + w * win..from + (w + 1) * win)).collect();
        if scored.is_empty() {
            continue;
        }
        let sum = |f: fn(&(Scored, f64, f64, f64)) -> f64| scored.iter().map(f).sum::<f64>();
        let whole = Scored { stated: (sum(|s| s.1) / (scored.len() * win) as f64).sqrt(), actual: (sum(|s| s.2) / sum(|s| s.3)).sqrt() };
        let rh_pct = rh[from..to].iter().sum::<f64>() / (to - from) as f64;
        out.push(Burst { rh_pct, whole, windows: scored.into_iter().map(|s| s.0).collect() });
    }
    out
}

/// (covered, total) over every window of every burst, and over the bursts as wholes.
pub fn coverage(bursts: &[Burst]) -> ((usize, usize), (usize, usize)) {
    let windows = bursts.iter().flat_map(|b| &b.windows);
    let w = (windows.clone().filter(|s| s.covered()).count(), windows.count());
    let b = (bursts.iter().filter(|b| b.whole.covered()).count(), bursts.len());
    (w, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An estimate off by a known gain in each burst, stated with a known error bar: the
    /// windows and the bursts come out covered exactly where the gain error is within the bar.
    #[test]
    fn counts_what_the_bars_contain() {
        let fs = 1000.0;
        let len = 8000;
        let bursts = [0..len, len..2 * len];
        let base: Vec<f64> = (0..2 * len).map(|k| (2.0 * std::f64::consts::PI * 40.0 * k as f64 / fs).sin()).collect();
        // 3 % too large in the first burst, 10 % in the second, both stated as 5 %.
        let est: Vec<f32> = (0..2 * len).map(|k| (base[k] * if k < len { 1.03 } else { 1.10 }) as f32).collect();
        let rel_err = vec![0.05f32; 2 * len];
        let rh = vec![50.0; 2 * len];
        let b = score(&est, &rel_err, &base, &rh, &bursts, 0, fs, 1.0, SETTLE_S);
        assert_eq!(b.len(), 2);
        assert!((b[0].whole.actual - 0.03).abs() < 2e-3 && (b[1].whole.actual - 0.10).abs() < 5e-3, "{b:?}");
        assert!((b[0].whole.stated - 0.05).abs() < 1e-6);
        let ((wc, wn), (bc, bn)) = coverage(&b);
        assert_eq!((bc, bn), (1, 2));
        assert_eq!(wn, 2 * 3, "3 whole seconds after the 5 s settling, per burst");
        assert_eq!(wc, 3);
    }
}
