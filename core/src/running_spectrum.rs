//! The current's running power spectrum over the calibrated band, sample by sample: what the
//! strip's own humidity is read from (`strip_humidity`).
//!
//! The current is averaged over [`decimation`] samples (a boxcar: one addition a sample; its
//! smooth response and the little it folds back are part of the excitation's smooth spectrum
//! the fit takes as unknown), Hann-windowed segments of [`SEGMENT`] decimated samples overlap by
//! half, and their periodograms at the band's bins are averaged exponentially over
//! [`AVERAGING_S`]: a constant amount of memory, and the same arithmetic on the device and the
//! host.

use crate::band::Band;
use crate::fft::RealFft;
use crate::{C, Real};

/// Decimated samples per segment: with the decimated rate near 3× the band's top, bins of about
/// 1 Hz, several across the strip's first resonance (28–35 Hz, Q ≈ 10–15: 2–3 Hz wide).
pub const SEGMENT: usize = 512;
const _: () = assert!(SEGMENT.is_multiple_of(4), "segments complete at an even head");
/// Most bins of the band kept.
pub const MAX_BINS: usize = 192;
/// Time constant of the average [s]: long enough for the log-spectrum's scatter to be small
/// (about 50 segments), short against the humidity's drift by several %RH.
pub const AVERAGING_S: f64 = 20.0;

/// Decimation of the current for a rate `fs_hz` and the band's top: the decimated rate stays at
/// least 3× the band's top, so the band is clear of the boxcar's first null.
pub fn decimation(fs_hz: f64, band: &Band) -> usize {
    ((fs_hz / (3.0 * band.high_hz)) as usize).max(1)
}

/// Cross-correlation of the Hann window's periodogram at lags of one and two bins (for white
/// input): the bins of one spectrum are not independent, and the fit's variance says so.
pub const HANN_BIN_CORRELATION: [f64; 2] = [4.0 / 9.0, 1.0 / 36.0];
/// Correlation of the periodograms of two Hann segments overlapping by half (white input).
const HANN_HALF_OVERLAP_CORRELATION: f64 = 1.0 / 6.0;

/// The band's bins of the average, as the fit reads them.
#[derive(Clone, Copy, Debug)]
pub struct SpectrumView<'a, T> {
    /// Frequency of the first bin and the bins' spacing [Hz].
    pub first_hz: T,
    pub df_hz: T,
    /// One-sided power spectral density of the current [A²/Hz].
    pub psd: &'a [T],
    /// Degrees of freedom of the average over two (the number of independent periodograms it is
    /// worth).
    pub segments: T,
}

/// Where the band's bins of the average lie, for a rate and a band: what the spectrum keeps
/// and what the fit's model table ([`crate::strip_humidity::ModelTable`]) is tabulated at.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BinGeometry {
    pub decimation: usize,
    pub first_bin: usize,
    pub bins: usize,
    pub df_hz: f64,
}

impl BinGeometry {
    pub fn new(fs_hz: f64, band: &Band) -> Self {
        let decimation = decimation(fs_hz, band);
        let df_hz = fs_hz / decimation as f64 / SEGMENT as f64;
        let first_bin = ((band.low_hz / df_hz).ceil() as usize).max(1);
        let last_bin = ((band.high_hz / df_hz).floor() as usize).min(SEGMENT / 2 - 1);
        let bins = (last_bin + 1).saturating_sub(first_bin).min(MAX_BINS);
        BinGeometry { decimation, first_bin, bins, df_hz }
    }

    /// Frequency of bin `k` of the band [Hz].
    pub fn hz(&self, k: usize) -> f64 {
        (self.first_bin + k) as f64 * self.df_hz
    }
}

pub struct RunningSpectrum<T> {
    fft: RealFft<T, { SEGMENT / 2 }>,
    window: [T; SEGMENT],
    /// The last SEGMENT decimated samples, a ring.
    ring: [T; SEGMENT],
    head: usize,
    filled: usize,
    since_hop: usize,
    decimation: usize,
    acc: T,
    acc_n: usize,
    first_bin: usize,
    bins: usize,
    average: [T; MAX_BINS],
    /// Segments averaged so far, and the forgetting factor once it is reached.
    count: u32,
    alpha: T,
    /// From |X|² to one-sided PSD: 2/(fs_dec·Σw²).
    scale: T,
    df_hz: T,
}

impl<T: Real> RunningSpectrum<T> {
    pub fn new(fs_hz: f64, band: &Band) -> Self {
        let BinGeometry { decimation, first_bin, bins, df_hz: df } = BinGeometry::new(fs_hz, band);
        let fs_dec = fs_hz / decimation as f64;
        let mut window = [T::zero(); SEGMENT];
        let mut power = 0.0;
        for (n, w) in window.iter_mut().enumerate() {
            let v = 0.5 - 0.5 * libm::cos(2.0 * core::f64::consts::PI * n as f64 / SEGMENT as f64);
            power += v * v;
            *w = T::lit(v);
        }
        let hop_s = (SEGMENT / 2) as f64 / fs_dec;
        RunningSpectrum {
            fft: RealFft::new(),
            window,
            ring: [T::zero(); SEGMENT],
            head: 0,
            filled: 0,
            since_hop: 0,
            decimation,
            acc: T::zero(),
            acc_n: 0,
            first_bin,
            bins,
            average: [T::zero(); MAX_BINS],
            count: 0,
            alpha: T::lit(hop_s / AVERAGING_S),
            scale: T::lit(2.0 / (fs_dec * power)),
            df_hz: T::lit(df),
        }
    }

    /// Takes the current's samples [A]; returns how many segments were completed.
    pub fn push(&mut self, samples: &[T]) -> usize {
        let mut done = 0;
        // The boxcar's sum in registers: the per-sample work is the addition alone.
        let (mut acc, mut n) = (self.acc, self.acc_n);
        for &x in samples {
            acc += x;
            n += 1;
            if n == self.decimation {
                done += self.decimated(acc / T::lit(self.decimation as f64));
                (acc, n) = (T::zero(), 0);
            }
        }
        (self.acc, self.acc_n) = (acc, n);
        done
    }

    /// One decimated sample; 1 if it completed a segment.
    fn decimated(&mut self, v: T) -> usize {
        self.ring[self.head] = v;
        self.head = (self.head + 1) % SEGMENT;
        self.filled = (self.filled + 1).min(SEGMENT);
        self.since_hop += 1;
        if self.filled == SEGMENT && self.since_hop >= SEGMENT / 2 {
            self.since_hop = 0;
            self.segment();
            1
        } else {
            0
        }
    }

    // Once a segment: kept out of line so the per-sample loop stays small in flash.
    #[inline(never)]
    fn segment(&mut self) {
        let mut mean = T::zero();
        for v in self.ring.iter() {
            mean += *v;
        }
        mean /= T::lit(SEGMENT as f64);
        let mut z = [C::new(T::zero(), T::zero()); SEGMENT / 2];
        // Oldest first; a segment completes every half segment, so the ring's head is even
        // then and no pair straddles its end.
        let (newer, older) = self.ring.split_at(self.head);
        let ordered = older.chunks_exact(2).chain(newer.chunks_exact(2));
        for ((slot, x), w) in z.iter_mut().zip(ordered).zip(self.window.chunks_exact(2)) {
            *slot = C::new((x[0] - mean) * w[0], (x[1] - mean) * w[1]);
        }
        self.fft.transform(&mut z);
        self.count = self.count.saturating_add(1);
        // A plain mean until the forgetting factor is reached, then exponential.
        let a = T::one() / T::lit(self.count as f64);
        let a = if a > self.alpha { a } else { self.alpha };
        for (k, avg) in self.average.iter_mut().enumerate().take(self.bins) {
            let p = self.fft.bin(&z, self.first_bin + k).norm_sqr() * self.scale;
            *avg += a * (p - *avg);
        }
    }

    /// Segments averaged so far.
    pub fn segments(&self) -> u32 {
        self.count
    }

    /// Degrees of freedom over two of the average: n segments while it is a plain mean, then
    /// (2 − α)/α, both reduced by the half-overlap's correlation.
    pub fn equivalent_segments(&self) -> T {
        let n = T::lit(self.count as f64);
        let plain = T::one() / n;
        let a = if plain > self.alpha { plain } else { self.alpha };
        let independent = if plain > self.alpha { n } else { (T::lit(2.0) - a) / a };
        independent / T::lit(1.0 + 2.0 * HANN_HALF_OVERLAP_CORRELATION)
    }

    /// The forgetting factor per segment, for averages that must follow the same weights.
    pub fn alpha(&self) -> T {
        self.alpha
    }

    pub fn view(&self) -> SpectrumView<'_, T> {
        SpectrumView {
            first_hz: T::lit(self.first_bin as f64) * self.df_hz,
            df_hz: self.df_hz,
            psd: &self.average[..self.bins],
            segments: self.equivalent_segments(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_gives_its_density() {
        // A deterministic pseudo-random white sequence of known variance.
        let mut state = 12345u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let fs = 2000.0;
        let mut s = RunningSpectrum::<f64>::new(fs, &Band::DEFAULT);
        let x: std::vec::Vec<f64> = (0..200_000).map(|_| next()).collect();
        s.push(&x);
        // Uniform on ±0.5: variance 1/12; the boxcar mean of 4 divides it by 4 and spreads it
        // over 0–fs/8 one-sided.
        let expected = (1.0 / 12.0) / 4.0 / (fs / 8.0);
        let v = s.view();
        let mean = v.psd.iter().sum::<f64>() / v.psd.len() as f64;
        // The boxcar's response in the band (≥ 0.86² at 150 Hz) lowers it a little.
        assert!(mean / expected > 0.85 && mean / expected < 1.02, "{mean} vs {expected}");
        assert!((v.first_hz - 10.0).abs() < 1.0 && v.psd.len() > 140, "{} {}", v.first_hz, v.psd.len());
    }

    #[test]
    fn a_tone_lands_in_its_bin() {
        let fs = 2000.0;
        let mut s = RunningSpectrum::<f32>::new(fs, &Band::DEFAULT);
        let f = 40.0;
        let x: std::vec::Vec<f32> = (0..40_000).map(|n| (2.0 * core::f64::consts::PI * f * n as f64 / fs).sin() as f32).collect();
        s.push(&x);
        let v = s.view();
        let (k, _) = v.psd.iter().enumerate().fold((0, 0.0f32), |b, (k, &p)| if p > b.1 { (k, p) } else { b });
        let at = v.first_hz + v.df_hz * k as f32;
        assert!((at - f as f32).abs() <= v.df_hz, "{at}");
    }
}
