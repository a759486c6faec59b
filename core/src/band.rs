//! The band an estimate is good in (the file's `[band]` table), and the linear-phase FIR
//! band-pass at the end of the chain that keeps it.
//!
//! A calibration is measured over a band (its frequency responses, its time series' lines).
//! Below it the inverse's gain rises as 1/ω² down to its regularizing high-pass, and lifts the
//! current's white noise there by orders of magnitude over what it adds in band (on realistic
//! recordings the raw estimate was 33–51× the true base motion's rms); above it the model is
//! unchecked. So the chain keeps only this band of its estimate, and every figure of error is
//! taken in it.
//!
//! Any causal minimum-phase high-pass steep enough to matter turns the phase at the band's lower
//! edge by tens of degrees (Bode's gain–phase integral), which the design's 1 % flatness in band
//! cannot take. A linear-phase FIR can: its only cost in band is a pure delay, which the chain
//! already reports. The transitions lie outside the band ([`transition_hz`] each side), so the
//! band itself keeps the design's accuracy.
//!
//! The taps are designed once (windowed sinc, Kaiser window) in f64 and narrowed to the
//! working precision, so the firmware and its host replica run the same bits. The table and the
//! filter are one file because a band is valid only where the firmware's FIR can keep it.

use crate::numeric::real::Real;
use crate::timing::SAMPLE_RATE_HZ;

/// Edges of the calibrated band [Hz].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct Band {
    pub low_hz: f64,
    pub high_hz: f64,
}

impl Band {
    /// What the paper's frequency responses and the project's sessions cover.
    pub const DEFAULT: Band = Band { low_hz: 10.0, high_hz: 150.0 };

    /// The key (as the file spells it) and value of the first edge no band can have.
    pub fn invalid(&self) -> Option<(&'static str, f64)> {
        if !(self.low_hz.is_finite() && self.low_hz > 0.0) {
            return Some(("low_hz", self.low_hz));
        }
        if !(self.high_hz.is_finite() && self.high_hz > self.low_hz) {
            return Some(("high_hz", self.high_hz));
        }
        // The firmware keeps the band at its own rate, with the FIR below.
        match check(self, SAMPLE_RATE_HZ as f64) {
            Ok(_) => None,
            Err(BandLimitError::TooLow { .. }) => Some(("low_hz", self.low_hz)),
            Err(BandLimitError::AboveNyquist) => Some(("high_hz", self.high_hz)),
        }
    }
}

impl Default for Band {
    fn default() -> Self {
        Band::DEFAULT
    }
}

/// Stop-band attenuation of the design [dB]: 0.9 % ripple at most in
/// band (its rms is far smaller: the ripple gathers at the edges), and the noise below the
/// transition reduced about 10⁴ in power (−39 dB at worst).
pub const ATTENUATION_DB: f64 = 42.0;
/// Most taps (odd: a type I filter, delay a whole number of samples): at 2 kHz a lower band
/// edge down to 9.9 Hz (the default band's 10 Hz needs 793). Its history, kept both ways round,
/// is 12.8 KB of the firmware's RAM in f32.
pub const MAX_TAPS: usize = 801;
const MAX_HALF: usize = MAX_TAPS / 2 + 1;

/// Width of each transition [Hz]: from the lower edge down to 0.4 of it, where the noise the
/// inverse lifts as 1/f⁴ would otherwise dominate; the upper transition is as wide.
pub fn transition_hz(band: &Band) -> f64 {
    0.6 * band.low_hz
}

/// Why a band cannot be kept at a sample rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BandLimitError {
    /// The upper transition would reach Nyquist.
    AboveNyquist,
    /// The lower edge is so low that its transition needs more than [`MAX_TAPS`] taps.
    TooLow { taps_needed: usize },
}

impl core::fmt::Display for BandLimitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            BandLimitError::AboveNyquist => f.write_str("the band's upper transition reaches the Nyquist frequency"),
            BandLimitError::TooLow { taps_needed } => {
                write!(f, "the band's lower edge needs a {taps_needed}-tap filter at this rate (at most {MAX_TAPS})")
            }
        }
    }
}

/// Taps a band needs at `fs_hz` (Kaiser's estimate, rounded up to odd).
pub fn taps_for(band: &Band, fs_hz: f64) -> usize {
    let dw = 2.0 * core::f64::consts::PI * transition_hz(band) / fs_hz;
    let n = Real::ceil((ATTENUATION_DB - 7.95) / (2.285 * dw)) as usize + 1;
    n | 1
}

/// The lowest lower edge a band can have at `fs_hz` ([`MAX_TAPS`]).
pub fn lowest_low_hz(fs_hz: f64) -> f64 {
    (ATTENUATION_DB - 7.95) / (2.285 * 2.0 * core::f64::consts::PI / fs_hz * (MAX_TAPS - 1) as f64) / 0.6
}

/// Whether `band` can be kept at `fs_hz`, and with how many taps.
pub fn check(band: &Band, fs_hz: f64) -> Result<usize, BandLimitError> {
    if !(band.high_hz + transition_hz(band) < fs_hz / 2.0) {
        return Err(BandLimitError::AboveNyquist);
    }
    let n = taps_for(band, fs_hz);
    if n > MAX_TAPS {
        return Err(BandLimitError::TooLow { taps_needed: n });
    }
    Ok(n)
}

/// The filter's taps in f64: `half[k]` = h[k] = h[n−1−k] for k ≤ (n−1)/2.
#[derive(Clone, Copy)]
pub struct Taps {
    half: [f64; MAX_HALF],
    n: usize,
}

impl Taps {
    /// The band-pass keeping `band` at `fs_hz`.
    pub fn design(band: &Band, fs_hz: f64) -> Result<Self, BandLimitError> {
        let n = check(band, fs_hz)?;
        let half_width = transition_hz(band) / 2.0;
        let (f1, f2) = (band.low_hz - half_width, band.high_hz + half_width);
        let m = (n - 1) / 2;
        let beta = 0.5842 * Real::powf(ATTENUATION_DB - 21.0, 0.4) + 0.07886 * (ATTENUATION_DB - 21.0);
        let (w1, w2) = (f1 / fs_hz, f2 / fs_hz);
        let pi = core::f64::consts::PI;
        let mut t = Taps { half: [0.0; MAX_HALF], n };
        for (k, h) in t.half.iter_mut().enumerate().take(m + 1) {
            let j = k as f64 - m as f64;
            let ideal = if k == m { 2.0 * (w2 - w1) } else { (Real::sin(2.0 * pi * w2 * j) - Real::sin(2.0 * pi * w1 * j)) / (pi * j) };
            let r = j / m as f64;
            *h = ideal * bessel_i0(beta * Real::sqrt((1.0 - r * r).max(0.0))) / bessel_i0(beta);
        }
        // Unit gain at the band's geometric centre, where the ripple is smallest.
        let gain = t.response(Real::sqrt(band.low_hz * band.high_hz), fs_hz);
        for h in t.half.iter_mut() {
            *h /= gain;
        }
        Ok(t)
    }

    /// Number of taps.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Never: a band-pass has at least one tap.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The filter's delay [samples]: its taps' centre.
    pub fn delay_samples(&self) -> usize {
        (self.n - 1) / 2
    }

    /// The response at `freq_hz` as the filter runs it, with its delay.
    pub fn delayed_response(&self, freq_hz: f64, fs_hz: f64) -> crate::C<f64> {
        let w = 2.0 * core::f64::consts::PI * freq_hz / fs_hz * self.delay_samples() as f64;
        crate::C::new(Real::cos(w), -Real::sin(w)) * self.response(freq_hz, fs_hz)
    }

    /// The response at `freq_hz`, its delay removed (real: linear phase).
    pub fn response(&self, freq_hz: f64, fs_hz: f64) -> f64 {
        let m = self.delay_samples();
        let w = 2.0 * core::f64::consts::PI * freq_hz / fs_hz;
        let mut g = self.half[m];
        for (k, h) in self.half[..m].iter().enumerate() {
            g += 2.0 * h * Real::cos(w * (m - k) as f64);
        }
        g
    }
}

/// The running filter at the working precision: its taps narrowed from [`Taps`], and the last
/// `n` inputs.
#[derive(Clone, Copy)]
pub struct BandLimit<T> {
    half: [T; MAX_HALF],
    n: usize,
    /// The last `n` inputs, stored twice so that the newest `n` are always contiguous.
    hist: [T; 2 * MAX_TAPS],
    pos: usize,
    /// The same, newest first.
    rhist: [T; 2 * MAX_TAPS],
    rpos: usize,
}

impl<T: Real> BandLimit<T> {
    /// The band-pass keeping `band` at `fs_hz`.
    pub fn new(band: &Band, fs_hz: f64) -> Result<Self, BandLimitError> {
        Ok(Self::from_taps(&Taps::design(band, fs_hz)?))
    }

    pub fn from_taps(t: &Taps) -> Self {
        let mut b = Self::identity();
        b.load(t);
        b
    }

    /// One tap of 1: the input as it is, undelayed.
    pub fn identity() -> Self {
        let mut half = [T::zero(); MAX_HALF];
        half[0] = T::one();
        BandLimit { half, n: 1, hist: [T::zero(); 2 * MAX_TAPS], pos: 0, rhist: [T::zero(); 2 * MAX_TAPS], rpos: 0 }
    }

    /// Takes the taps `t`, in place (no copy of the filter on the stack), with no history.
    pub fn load(&mut self, t: &Taps) {
        self.half = [T::zero(); MAX_HALF];
        for (h, &v) in self.half.iter_mut().zip(&t.half[..=t.delay_samples()]) {
            *h = T::lit(v);
        }
        self.n = t.n;
        self.reset();
    }

    /// Number of taps.
    pub fn taps(&self) -> usize {
        self.n
    }

    /// The filter's delay [samples]: its taps' centre.
    pub fn delay_samples(&self) -> usize {
        (self.n - 1) / 2
    }

    /// Forgets the history (after a fault: as if the input had been zero).
    pub fn reset(&mut self) {
        self.hist = [T::zero(); 2 * MAX_TAPS];
        self.pos = 0;
        self.rhist = [T::zero(); 2 * MAX_TAPS];
        self.rpos = 0;
    }

    /// Filters `buf` in place.
    pub fn process_block(&mut self, buf: &mut [T]) {
        let (n, m) = (self.n, self.delay_samples());
        for v in buf.iter_mut() {
            // Newest sample at hist[pos + n − 1], oldest at hist[pos]: the window is contiguous.
            self.hist[self.pos] = *v;
            self.hist[self.pos + n] = *v;
            self.pos = if self.pos + 1 == n { 0 } else { self.pos + 1 };
            // The same window newest first: a ring run backwards, so that both halves of the
            // symmetric sum are read forwards (zipped slices: no bounds checks in the loop).
            self.rpos = if self.rpos == 0 { n - 1 } else { self.rpos - 1 };
            self.rhist[self.rpos] = *v;
            self.rhist[self.rpos + n] = *v;
            let older = &self.hist[self.pos..self.pos + m];
            let newer = &self.rhist[self.rpos..self.rpos + m];
            let mut acc = self.half[m] * self.hist[self.pos + m];
            for ((h, a), b) in self.half[..m].iter().zip(older).zip(newer) {
                acc += *h * (*a + *b);
            }
            *v = acc;
        }
    }
}

impl<T> core::fmt::Debug for BandLimit<T> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "BandLimit {{ taps: {} }}", self.n)
    }
}

/// The modified Bessel function I₀ by its power series (converges for the β ≤ 10 used here).
fn bessel_i0(x: f64) -> f64 {
    let (mut sum, mut term) = (1.0, 1.0);
    let q = x * x / 4.0;
    for k in 1..40 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_in_band_and_deep_below() {
        let band = Band::DEFAULT;
        let fs = 2000.0;
        let f = Taps::design(&band, fs).unwrap();
        assert!(f.len() <= MAX_TAPS && f.len() % 2 == 1, "{}", f.len());
        let ripple = (0..=280).map(|i| (f.response(10.0 + 0.5 * i as f64, fs) - 1.0).abs()).fold(0.0, f64::max);
        assert!(ripple <= 0.01, "ripple in band {ripple}");
        let stop = (0..=40).map(|i| f.response(0.1 * i as f64, fs).abs()).fold(0.0, f64::max);
        assert!(stop <= 0.0125, "below the transition {stop}");
        let above = (0..=200).map(|i| f.response(157.0 + i as f64, fs).abs()).fold(0.0, f64::max);
        assert!(above <= 0.0125, "above the transition {above}");
    }

    #[test]
    fn runs_what_it_says_with_its_delay() {
        let (band, fs) = (Band::DEFAULT, 2000.0);
        let mut f = BandLimit::<f64>::new(&band, fs).unwrap();
        let d = f.delay_samples();
        let tone = |fr: f64, i: usize| (2.0 * core::f64::consts::PI * fr * i as f64 / fs).sin();
        let n = 6000;
        let mut x: std::vec::Vec<f64> = (0..n).map(|i| tone(40.0, i) + 5.0 * tone(2.0, i)).collect();
        for c in x.chunks_mut(37) {
            f.process_block(c);
        }
        let g = Taps::design(&band, fs).unwrap().response(40.0, fs);
        let worst = (2 * d..n).map(|i| (x[i] - g * tone(40.0, i - d)).abs()).fold(0.0, f64::max);
        assert!(worst < 0.06, "the 2 Hz tone is left at {worst}");
    }

    #[test]
    fn refuses_bands_it_cannot_keep() {
        assert!(matches!(Taps::design(&Band { low_hz: 2.0, high_hz: 150.0 }, 2000.0), Err(BandLimitError::TooLow { .. })));
        assert!(matches!(Taps::design(&Band { low_hz: 10.0, high_hz: 996.0 }, 2000.0), Err(BandLimitError::AboveNyquist)));
    }
}
