//! The ideal brickwall band limit: a signal's content in a frequency band, every bin inside kept
//! and every bin outside dropped (not the firmware's FIR band filter, `ipmc_core::band`). By the
//! discrete Fourier transform of the whole signal, an FFT: a field recording of 90 s at 2 kHz has
//! 12 600 bins in 10–150 Hz, and a direct sum over them costs seconds per signal. The signal is
//! taken as one period of a periodic one: exact for a whole number of periods of a periodic
//! recording, with the usual leakage otherwise.
//!
//! One implementation for the uses that must agree on what "in band" means: scoring an
//! estimate's error in the band (`scoring`: a burst's error and each window's coverage), the
//! exact band-limited inverse (`exact`) and the field table's band limit.

use ipmc_core::C;
use rustfft::FftPlanner;

/// The bins k (frequency k·fs/n) with lo ≤ f ≤ hi, below Nyquist.
pub fn bins(n: usize, fs_hz: f64, lo_hz: f64, hi_hz: f64) -> std::ops::RangeInclusive<usize> {
    let df = fs_hz / n as f64;
    let first = ((lo_hz / df).ceil() as usize).max(1);
    let last = ((hi_hz / df).floor() as usize).min((n - 1) / 2);
    first..=last
}

/// X_k = Σ x_n e^(−2πikn/N) for the bins `ks`.
pub fn dft(x: &[f64], ks: std::ops::RangeInclusive<usize>) -> Vec<C<f64>> {
    let mut buf: Vec<C<f64>> = x.iter().map(|&v| C::new(v, 0.0)).collect();
    if buf.is_empty() {
        return vec![];
    }
    FftPlanner::new().plan_fft_forward(buf.len()).process(&mut buf);
    buf[ks].to_vec()
}

/// The real signal of length `n` whose only content is `spectrum` at the bins `ks` (and their
/// mirror images): the inverse of [`dft`] restricted to the band.
pub fn synthesize(spectrum: &[C<f64>], ks: std::ops::RangeInclusive<usize>, n: usize) -> Vec<f64> {
    if n == 0 {
        return vec![];
    }
    let mut buf = vec![C::new(0.0, 0.0); n];
    for (&xk, k) in spectrum.iter().zip(ks) {
        buf[k] = xk;
        buf[n - k] = xk.conj();
    }
    FftPlanner::new().plan_fft_inverse(n).process(&mut buf);
    buf.iter().map(|c| c.re / n as f64).collect()
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
    use std::f64::consts::PI;

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

    /// The FFT agrees with the definition's sum at a prime length, where it cannot split.
    #[test]
    fn the_transform_is_the_definitions_sum() {
        let n = 4001;
        let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 1013.0 - 0.5).collect();
        let ks = 17..=311;
        let direct: Vec<C<f64>> = ks
            .clone()
            .map(|k| x.iter().enumerate().map(|(i, &v)| C::from_polar(v, -2.0 * PI * ((k * i) % n) as f64 / n as f64)).sum())
            .collect();
        let worst = dft(&x, ks).iter().zip(&direct).map(|(a, b)| (a - b).norm()).fold(0.0, f64::max);
        assert!(worst < 1e-9, "{worst}");
    }
}
