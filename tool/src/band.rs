//! A signal's content in a frequency band, by the discrete Fourier transform of the whole
//! signal evaluated at the band's bins only (a band of 10–150 Hz in a 2 kHz signal is a few
//! percent of the bins, so a direct sum costs less than it would to pull in an FFT). The signal
//! is taken as one period of a periodic one: exact for a whole number of periods of a periodic
//! recording, with the usual leakage otherwise.
//!
//! One implementation for the two uses that must agree on what "in band" means: scoring an
//! estimate's error in the band (`scoring::band_error`) and the exact band-limited inverse
//! (`exact`).

use ipmc_core::C;
use std::f64::consts::PI;

/// The bins k (frequency k·fs/n) with lo ≤ f ≤ hi, below Nyquist.
pub fn bins(n: usize, fs_hz: f64, lo_hz: f64, hi_hz: f64) -> std::ops::RangeInclusive<usize> {
    let df = fs_hz / n as f64;
    let first = ((lo_hz / df).ceil() as usize).max(1);
    let last = ((hi_hz / df).floor() as usize).min((n - 1) / 2);
    first..=last
}

/// X_k = Σ x_n e^(−2πikn/N) for the bins `ks`. The rotation is taken from its angle every 1024
/// samples so that the recurrence's rounding does not build up over long signals.
pub fn dft(x: &[f64], ks: std::ops::RangeInclusive<usize>) -> Vec<C<f64>> {
    let n = x.len();
    ks.map(|k| {
        let w = -2.0 * PI * k as f64 / n as f64;
        let step = C::<f64>::from_polar(1.0, w);
        let mut acc = C::<f64>::new(0.0, 0.0);
        for (start, chunk) in x.chunks(1024).enumerate() {
            let mut ph = C::<f64>::from_polar(1.0, w * ((start * 1024) % n) as f64);
            for &v in chunk {
                acc += ph * v;
                ph *= step;
            }
        }
        acc
    })
    .collect()
}

/// The real signal of length `n` whose only content is `spectrum` at the bins `ks` (and their
/// mirror images): the inverse of [`dft`] restricted to the band.
pub fn synthesize(spectrum: &[C<f64>], ks: std::ops::RangeInclusive<usize>, n: usize) -> Vec<f64> {
    let mut out = vec![0.0; n];
    for (&xk, k) in spectrum.iter().zip(ks) {
        let w = 2.0 * PI * k as f64 / n as f64;
        let step = C::<f64>::from_polar(1.0, w);
        let a = xk * (2.0 / n as f64);
        for (start, chunk) in out.chunks_mut(1024).enumerate() {
            let mut ph = C::<f64>::from_polar(1.0, w * ((start * 1024) % n) as f64);
            for v in chunk.iter_mut() {
                *v += (a * ph).re;
                ph *= step;
            }
        }
    }
    out
}

/// Sum of squares of `x`'s content in the band (Parseval: what Σ of the band-limited signal
/// squared would be, without synthesizing it).
pub fn energy(x: &[f64], fs_hz: f64, lo_hz: f64, hi_hz: f64) -> f64 {
    let ks = bins(x.len(), fs_hz, lo_hz, hi_hz);
    dft(x, ks).iter().map(|c| c.norm_sqr()).sum::<f64>() * 2.0 / x.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_band_and_drops_the_rest() {
        let (n, fs) = (4000, 2000.0);
        let tone = |f: f64, a: f64| (0..n).map(move |i| a * (2.0 * PI * f * i as f64 / fs + 0.3).sin());
        let inband: Vec<f64> = tone(40.0, 1.0).collect();
        let x: Vec<f64> = tone(40.0, 1.0).zip(tone(3.0, 5.0)).zip(tone(400.0, 2.0)).map(|((a, b), c)| a + b + c).collect();
        let ks = bins(n, fs, 10.0, 150.0);
        assert_eq!((*ks.start(), *ks.end()), (20, 300));
        let y = synthesize(&dft(&x, ks.clone()), ks, n);
        let worst = y.iter().zip(&inband).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "{worst}");
        let e = energy(&x, fs, 10.0, 150.0);
        assert!((e - n as f64 / 2.0).abs() < 1e-6 * n as f64, "{e}");
    }
}
