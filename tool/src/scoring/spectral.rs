//! An estimate's error content in a band of DFT lines, per burst: a diagnostic of where an
//! error lies (below, in or above the band, `ipmc vs-exact`), not the score. The score is
//! [`super::Scoring`]'s, in the time domain through the band filter itself.

use super::SETTLE_S;

/// The error's content in `band` over the true base's content in `reference` (each
/// `(lo_hz, hi_hz)`; `brickwall::energy` per burst after its settling, the base delayed by `delay`),
/// as a ratio of rms values: what an estimate adds outside the design band, on the scale of the
/// signal in it.
pub fn band_error<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
    band: (f64, f64),
    reference: (f64, f64),
) -> Option<f64> {
    let (mut se, mut sb) = (0.0f64, 0.0f64);
    for (err, truth) in scored_bursts(est, delay, burst_start, base, fs_hz) {
        if err.len() > 2 {
            se += crate::brickwall::energy(&err, fs_hz, band.0, band.1);
            sb += crate::brickwall::energy(&truth, fs_hz, reference.0, reference.1);
        }
    }
    (sb > 0.0).then(|| (se / sb).sqrt())
}

/// Per burst, the samples scored: (estimate − delayed true base, delayed true base), after the
/// first [`SETTLE_S`] of the burst.
fn scored_bursts<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let settle = (SETTLE_S * fs_hz).round() as usize;
    let n = est.len().min(base.len()).min(delay.len()).min(burst_start.len());
    let mut out = vec![];
    let mut i = 0;
    while i < n {
        let b0 = burst_start[i];
        let mut j = i;
        while j < n && burst_start[j] == b0 {
            j += 1;
        }
        let (mut err, mut truth) = (vec![], vec![]);
        for k in i..j {
            if k < b0 + settle || k < b0 + delay[k] {
                continue;
            }
            let t = base[k - delay[k]];
            err.push(est[k].into() - t);
            truth.push(t);
        }
        out.push((err, truth));
        i = j;
    }
    out
}
