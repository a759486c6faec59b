//! The current's running power spectrum over the calibrated band, sample by sample: what the
//! strip's own humidity is read from ([`super::strip`]).
//!
//! The current is averaged over [`decimation`] samples (a boxcar: one addition a sample; its
//! smooth response and the little it folds back are part of the excitation's smooth spectrum
//! the fit takes as unknown), Hann-windowed segments of [`SEGMENT`] decimated samples overlap by
//! half, and their periodograms at the band's bins are averaged exponentially over
//! [`AVERAGING_S`]: a constant amount of memory, and the same arithmetic on the device and the
//! host.

use crate::band::Band;
use crate::numeric::fft::RealFft;
use crate::{C, Real};

/// Decimated samples per segment: with the decimated rate near 3× the band's top, bins of about
/// 1 Hz, several across the strip's first resonance (28–35 Hz, Q ≈ 10–15: 2–3 Hz wide).
pub const SEGMENT: usize = 512;
const _: () = assert!(SEGMENT.is_multiple_of(4), "a half segment packs into whole pairs");
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
/// and what the fit's model table ([`crate::humidity::strip::ModelTable`]) is tabulated at.
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

/// Decimated samples per hop: segments overlap by half.
const HALF: usize = SEGMENT / 2;

type Fft<T> = RealFft<T, { SEGMENT / 2 }>;

pub struct RunningSpectrum<T> {
    fft: Fft<T>,
    window: [T; SEGMENT],
    /// The last SEGMENT decimated samples in two halves, `pos` the next one written: when a half
    /// is full, the other one is the older half of the segment it completes.
    ring: [T; SEGMENT],
    pos: usize,
    /// Each half's sum, for the segment's mean.
    half_sums: [T; 2],
    halves_filled: u8,
    decimation: usize,
    /// The boxcar's sum so far and how many samples are in it.
    acc: T,
    acc_n: usize,
    first_bin: usize,
    bins: usize,
    average: [T; MAX_BINS],
    /// Segments averaged so far, and the forgetting factor once it is reached.
    count: u32,
    alpha: T,
    /// Σ w² over the segments' weights in the average: its scatter is that of 1/Σw²
    /// independent periodograms (before the half overlap's correlation).
    weight_sq: T,
    /// From |X|² of the boxcar's sums to one-sided PSD of their mean: 2/(fs_dec·Σw²·decimation²).
    scale: T,
    df_hz: T,
}

/// Where a boxcar's sum starts: −0 + x is x for every x, so a sum begun in one block and one
/// begun in the next round alike.
fn empty<T: Real>() -> T {
    T::lit(-0.0)
}

/// The boxcar over whole groups of `d` samples, each group's sum to `out` and added to `sum`, in
/// the order a group split across blocks is summed in. Inlined with a constant `d` the groups
/// unroll, which is most of the per-sample cost.
#[inline(always)]
fn boxcar<T: Real>(samples: &[T], d: usize, out: &mut [T], sum: &mut T) {
    let mut s = *sum;
    for (o, group) in out.iter_mut().zip(samples.chunks_exact(d)) {
        let v = group.iter().fold(empty(), |a, &x| a + x);
        *o = v;
        s += v;
    }
    *sum = s;
}

/// [`boxcar`] for a decimation known when compiled.
#[inline(never)]
fn boxcar_of<T: Real, const D: usize>(samples: &[T], out: &mut [T], sum: &mut T) {
    boxcar(samples, D, out, sum)
}

impl<T: Real> RunningSpectrum<T> {
    pub fn new(fs_hz: f64, band: &Band) -> Self {
        let BinGeometry { decimation, first_bin, bins, df_hz: df } = BinGeometry::new(fs_hz, band);
        let fs_dec = fs_hz / decimation as f64;
        let mut window = [T::zero(); SEGMENT];
        let mut power = 0.0;
        // In the working precision: in f64 the device would link a cosine for these values alone.
        for (n, w) in window.iter_mut().enumerate() {
            *w = T::lit(0.5) - T::lit(0.5) * T::lit(2.0 * core::f64::consts::PI * n as f64 / SEGMENT as f64).cos();
            power += w.to_f64() * w.to_f64();
        }
        let hop_s = HALF as f64 / fs_dec;
        let d = decimation as f64;
        RunningSpectrum {
            fft: RealFft::new(),
            window,
            ring: [T::zero(); SEGMENT],
            pos: 0,
            half_sums: [T::zero(); 2],
            halves_filled: 0,
            decimation,
            acc: empty(),
            acc_n: 0,
            first_bin,
            bins,
            average: [T::zero(); MAX_BINS],
            count: 0,
            alpha: T::lit(hop_s / AVERAGING_S),
            weight_sq: T::zero(),
            scale: T::lit(2.0 / (fs_dec * power * d * d)),
            df_hz: T::lit(df),
        }
    }

    /// Takes the current's samples [A]; returns how many segments were completed.
    pub fn push(&mut self, samples: &[T]) -> usize {
        let d = self.decimation;
        let mut done = 0;
        let mut rest = samples;
        while !rest.is_empty() {
            if self.acc_n > 0 || rest.len() < d {
                // A group an earlier block began, or one this block only begins.
                let (head, tail) = rest.split_at((d - self.acc_n).min(rest.len()));
                for &x in head {
                    self.acc += x;
                }
                self.acc_n += head.len();
                rest = tail;
                if self.acc_n == d {
                    let v = core::mem::replace(&mut self.acc, empty());
                    self.acc_n = 0;
                    done += self.store(1, |out, sum| {
                        out[0] = v;
                        *sum += v;
                    });
                }
                continue;
            }
            let groups = (rest.len() / d).min(HALF - self.pos % HALF);
            let (whole, tail) = rest.split_at(groups * d);
            rest = tail;
            done += self.store(groups, |out, sum| match d {
                4 => boxcar_of::<T, 4>(whole, out, sum),
                _ => boxcar(whole, d, out, sum),
            });
        }
        done
    }

    /// Writes `groups` decimated samples (no further than the half's end) with `fill`, which
    /// also adds them to the half's sum; 1 if a segment completed.
    #[inline(always)]
    fn store(&mut self, groups: usize, fill: impl FnOnce(&mut [T], &mut T)) -> usize {
        let half = self.pos / HALF;
        fill(&mut self.ring[self.pos..self.pos + groups], &mut self.half_sums[half]);
        self.pos += groups;
        if !self.pos.is_multiple_of(HALF) {
            return 0;
        }
        self.pos %= SEGMENT;
        self.halves_filled = self.halves_filled.saturating_add(1);
        let done = if self.halves_filled >= 2 {
            self.segment();
            1
        } else {
            0
        };
        self.half_sums[self.pos / HALF] = T::zero();
        done
    }

    // Once a segment: kept out of line so the per-sample loop stays small in flash.
    #[inline(never)]
    fn segment(&mut self) {
        let mean = (self.half_sums[0] + self.half_sums[1]) / T::lit(SEGMENT as f64);
        let (first, second) = self.ring.split_at(HALF);
        // The half about to be overwritten is the older.
        let (older, newer) = if self.pos == 0 { (first, second) } else { (second, first) };
        let (w_older, w_newer) = self.window.split_at(HALF);
        // The segment packed for the FFT and transformed there: on the stack for the segment's
        // work alone (every slot is written before the transform reads it), not 2 KB of RAM for
        // good.
        let mut packed = [C::new(T::zero(), T::zero()); SEGMENT / 2];
        let z = &mut packed;
        for (offset, x, w) in [(0, older, w_older), (HALF / 2, newer, w_newer)] {
            for (n, (x, w)) in x.chunks_exact(2).zip(w.chunks_exact(2)).enumerate() {
                z[Fft::<T>::slot(offset + n)] = C::new((x[0] - mean) * w[0], (x[1] - mean) * w[1]);
            }
        }
        self.fft.transform(z);
        self.count = self.count.saturating_add(1);
        // A plain mean until the forgetting factor is reached, then exponential.
        let a = T::one() / T::lit(self.count as f64);
        let a = if a > self.alpha { a } else { self.alpha };
        let keep = T::one() - a;
        self.weight_sq = keep * keep * self.weight_sq + a * a;
        let scale = self.scale;
        self.fft.powers(z, self.first_bin, &mut self.average[..self.bins], |avg, p| *avg += a * (p * scale - *avg));
    }

    /// Segments averaged so far.
    pub fn segments(&self) -> u32 {
        self.count
    }

    /// Degrees of freedom over two of the average: 1/Σw² of its segments' weights, reduced by
    /// the half overlap's correlation. n segments while it is a plain mean; once it forgets, the
    /// plain mean's weight fades and the figure rises toward the exponential average's
    /// (2 − α)/α over the averaging time, not at once: at the switch the average still holds the
    /// n segments it held.
    pub fn equivalent_segments(&self) -> T {
        let independent = if self.weight_sq > T::zero() { T::one() / self.weight_sq } else { T::zero() };
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
    fn blocks_of_any_length_give_the_same_bits() {
        // The device pushes blocks of 32, a replay may not: the boxcar's groups and the halves'
        // sums must round alike across any block boundaries.
        let fs = 2000.0;
        let x: std::vec::Vec<f32> = (0..60_000).map(|n| ((n as f32 * 0.731).sin() + 0.3 * (n as f32 * 2.9).cos()) * 1e-6 + 2e-6).collect();
        let mut by_32 = RunningSpectrum::<f32>::new(fs, &Band::DEFAULT);
        let done_32: usize = x.chunks(32).map(|b| by_32.push(b)).sum();
        let mut ragged = RunningSpectrum::<f32>::new(fs, &Band::DEFAULT);
        let (mut rest, mut done, mut k) = (&x[..], 0, 0);
        while !rest.is_empty() {
            let n = [1, 7, 3, 64, 13, 2, 301][k % 7].min(rest.len());
            done += ragged.push(&rest[..n]);
            rest = &rest[n..];
            k += 1;
        }
        assert!(done_32 > 50 && done == done_32, "{done} vs {done_32}");
        let bits = |s: &RunningSpectrum<f32>| s.view().psd.iter().map(|p| p.to_bits()).collect::<std::vec::Vec<_>>();
        assert_eq!(bits(&ragged), bits(&by_32));
    }

    /// The average's worth in independent periodograms follows its weights: n while it is a
    /// plain mean, and when it starts to forget, it rises from there toward the exponential
    /// average's (2 − α)/α over the averaging time, not at once (a figure that doubled at the
    /// switch halved the scatter the fit's misfit and tone test compare with).
    #[test]
    fn the_averages_worth_rises_smoothly_when_it_starts_to_forget() {
        let fs = 2000.0;
        let mut s = RunningSpectrum::<f64>::new(fs, &Band::DEFAULT);
        let hop = HALF * s.decimation;
        let overlap = 1.0 + 2.0 * HANN_HALF_OVERLAP_CORRELATION;
        let x: std::vec::Vec<f64> = (0..hop).map(|n| (n as f64 * 0.37).sin()).collect();
        s.push(&x);
        let (mut last, mut worth) = (0.0, std::vec::Vec::new());
        while s.segments() < 400 {
            if s.push(&x) > 0 {
                let m = s.equivalent_segments() * overlap;
                worth.push((s.segments(), m));
                assert!(m >= last - 1e-9, "never falls while it fills: {m} after {last}");
                last = m;
            }
        }
        let switch = (1.0 / s.alpha()).floor() as u32;
        let at = |n: u32| worth.iter().find(|w| w.0 == n).unwrap().1;
        assert!((at(switch) - switch as f64).abs() < 1e-9, "a plain mean of {switch}: {}", at(switch));
        assert!(at(switch + 1) < 1.05 * at(switch), "no jump at the switch: {} then {}", at(switch), at(switch + 1));
        let limit = (2.0 - s.alpha()) / s.alpha();
        assert!(at(switch + 20) < 0.9 * limit, "still rising half an averaging time on: {}", at(switch + 20));
        assert!((at(400) / limit - 1.0).abs() < 0.01, "{} vs {limit}", at(400));
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
