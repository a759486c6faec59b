//! What a check measures: the strip's current against the board's accelerometer, per frequency,
//! as a coherence-weighted cross-spectral estimate (Welch: Hann segments of one second, half
//! overlapping), with the clocks' residual rate difference found first.
//!
//! H₁ = S_ia / S_aa per bin, its 1σ from the coherence γ²: each of ln H₁'s real and imaginary
//! parts scatters by √((1 − γ²)/(2·n·γ²)) over n independent segments (Bendat & Piersol), so a
//! bin where the current's noise or the accelerometer's swamps the other counts little. The rate
//! difference ε between the accelerometer's clock and the ADC's turns into a delay that grows
//! along the run, ε·t: the segments' cross-spectra are turned back by e^(jωεt) before they are
//! summed, ε the one that keeps them most coherent.

use anyhow::{Result, bail};
use ipmc_core::C;
use rustfft::FftPlanner;

/// Segment length [s]: 1 Hz bins, fine beside the strip's and the mounts' resonances.
const SEGMENT_S: f64 = 1.0;
/// Hann windows half overlapping are correlated by 0.167 (Welch 1967): n segments average as
/// n/(1 + 2·0.167²) independent ones.
const OVERLAP_CORRELATION: f64 = 0.167;
/// Rate differences searched [ppm]: the datasheet's ±20 ppm (1σ) four times over.
const RATE_SEARCH_PPM: f64 = 80.0;

/// The check's measured response, bin by bin.
#[derive(Clone, Debug)]
pub struct Measured {
    pub freq_hz: Vec<f64>,
    /// I/a as measured [A/(m/s²)].
    pub ratio: Vec<C<f64>>,
    /// 1σ of the real and of the imaginary part of ln(ratio).
    pub sd_ln: Vec<f64>,
    pub coherence: Vec<f64>,
    /// The accelerometer's clock against the ADC's [ppm], as found.
    pub rate_ppm: f64,
    /// Independent segments the estimate averages.
    pub segments_eff: f64,
}

/// Per segment: its centre time and the spectra of both channels at the bins kept.
struct Segments {
    t_s: Vec<f64>,
    current: Vec<Vec<C<f64>>>,
    accel: Vec<Vec<C<f64>>>,
    freq_hz: Vec<f64>,
}

fn segments(current: &[f64], accel: &[f64], fs_hz: f64, band_hz: (f64, f64), t0_s: f64) -> Segments {
    let n = (SEGMENT_S * fs_hz).round() as usize;
    let hop = n / 2;
    let window: Vec<f64> = (0..n).map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos()).collect();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    let bins: Vec<usize> = (1..n / 2).filter(|&k| (band_hz.0..=band_hz.1).contains(&(k as f64 * fs_hz / n as f64))).collect();
    let mut out =
        Segments { t_s: vec![], current: vec![], accel: vec![], freq_hz: bins.iter().map(|&k| k as f64 * fs_hz / n as f64).collect() };
    let spectrum = |x: &[f64]| {
        let mean = x.iter().sum::<f64>() / x.len() as f64;
        let mut buf: Vec<rustfft::num_complex::Complex<f64>> =
            x.iter().zip(&window).map(|(v, w)| rustfft::num_complex::Complex::new((v - mean) * w, 0.0)).collect();
        fft.process(&mut buf);
        bins.iter().map(|&k| C::new(buf[k].re, buf[k].im)).collect::<Vec<_>>()
    };
    let mut start = 0;
    while start + n <= current.len().min(accel.len()) {
        out.t_s.push(t0_s + (start + n / 2) as f64 / fs_hz);
        out.current.push(spectrum(&current[start..start + n]));
        out.accel.push(spectrum(&accel[start..start + n]));
        start += hop;
    }
    out
}

/// Σ over segments of I·A*·e^(jωεt) and the auto-spectra, per bin.
fn sums(s: &Segments, rate: f64) -> (Vec<C<f64>>, Vec<f64>, Vec<f64>) {
    let nb = s.freq_hz.len();
    let (mut cross, mut saa, mut sii) = (vec![C::new(0.0, 0.0); nb], vec![0.0; nb], vec![0.0; nb]);
    for (k, t) in s.t_s.iter().enumerate() {
        for b in 0..nb {
            let phase = 2.0 * std::f64::consts::PI * s.freq_hz[b] * rate * t;
            let turn = C::new(phase.cos(), phase.sin());
            let (i, a) = (s.current[k][b], s.accel[k][b]);
            cross[b] += i * a.conj() * turn;
            saa[b] += a.norm_sqr();
            sii[b] += i.norm_sqr();
        }
    }
    (cross, saa, sii)
}

fn total_coherence(s: &Segments, rate: f64) -> f64 {
    let (cross, saa, sii) = sums(s, rate);
    cross.iter().zip(&saa).zip(&sii).map(|((c, a), i)| c.norm_sqr() / (a * i).max(f64::MIN_POSITIVE)).sum()
}

/// The check's response between `band_hz`, its rate difference found on a grid of 1 ppm and
/// refined to 0.05 ppm.
pub fn measure(current: &[f64], accel: &[f64], fs_hz: f64, band_hz: (f64, f64)) -> Result<Measured> {
    let s = segments(current, accel, fs_hz, band_hz, 0.0);
    enough(&s, current.len() as f64 / fs_hz)?;
    let mut best = (0.0, f64::NEG_INFINITY);
    let steps = RATE_SEARCH_PPM as i64;
    for k in -steps..=steps {
        let c = total_coherence(&s, k as f64 * 1e-6);
        if c > best.1 {
            best = (k as f64, c);
        }
    }
    for k in -20..=20 {
        let ppm = best.0 + k as f64 * 0.05;
        let c = total_coherence(&s, ppm * 1e-6);
        if c > best.1 {
            best = (ppm, c);
        }
    }
    Ok(estimate(&s, best.0))
}

/// The response of a part of a check that starts `t0_s` into it, with the check's rate
/// difference `rate_ppm`: its phase in the check's time, as the whole check's fit reads it.
pub fn measure_part(current: &[f64], accel: &[f64], fs_hz: f64, band_hz: (f64, f64), t0_s: f64, rate_ppm: f64) -> Result<Measured> {
    let s = segments(current, accel, fs_hz, band_hz, t0_s);
    enough(&s, current.len() as f64 / fs_hz)?;
    Ok(estimate(&s, rate_ppm))
}

fn enough(s: &Segments, seconds: f64) -> Result<()> {
    if s.t_s.len() < 8 {
        bail!("{seconds} s of check: at least 4.5 s are needed for 8 half-overlapping segments of {SEGMENT_S} s");
    }
    Ok(())
}

/// H₁ per bin with the segments turned back by the rate difference, and its 1σ.
fn estimate(s: &Segments, rate_ppm: f64) -> Measured {
    let (cross, saa, sii) = sums(s, rate_ppm * 1e-6);
    let n_eff = s.t_s.len() as f64 / (1.0 + 2.0 * OVERLAP_CORRELATION * OVERLAP_CORRELATION);
    let mut m = Measured { freq_hz: vec![], ratio: vec![], sd_ln: vec![], coherence: vec![], rate_ppm, segments_eff: n_eff };
    for b in 0..s.freq_hz.len() {
        if !(saa[b] > 0.0 && sii[b] > 0.0) {
            continue;
        }
        let g2 = (cross[b].norm_sqr() / (saa[b] * sii[b])).min(1.0 - 1e-12);
        m.freq_hz.push(s.freq_hz[b]);
        m.ratio.push(cross[b] / saa[b]);
        m.sd_ln.push(((1.0 - g2) / (2.0 * n_eff * g2)).sqrt());
        m.coherence.push(g2);
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_fit::random::SplitMix64 as Rng;

    /// A current that is a known filter of the drive plus noise, the drive (lines off the bins,
    /// evaluated exactly at any time) recorded by a clock 30 ppm fast: the ratio, its rate and its
    /// 1σ come back.
    #[test]
    fn recovers_a_known_ratio_and_the_rate() {
        let fs = 2000.0;
        let n = 60 * 2000;
        let mut rng = Rng(3);
        let lines: Vec<(f64, f64)> = (3..250).map(|k| (k as f64 + 0.37, 2.0 * std::f64::consts::PI * rng.uniform())).collect();
        let drive = |t: f64| lines.iter().map(|&(f, ph)| (2.0 * std::f64::consts::PI * f * t + ph).cos()).sum::<f64>();
        let ppm = 30.0;
        let accel: Vec<f64> = (0..n).map(|i| drive(i as f64 / fs * (1.0 + ppm * 1e-6))).collect();
        // current = 2·drive one sample late, plus noise.
        let current: Vec<f64> = (0..n).map(|i| 2.0 * drive((i as f64 - 1.0) / fs) + rng.gauss(3.0)).collect();
        let m = measure(&current, &accel, fs, (5.0, 200.0)).unwrap();
        assert!((m.rate_ppm.abs() - ppm).abs() < 1.0, "rate {}", m.rate_ppm);
        let mut z2 = 0.0;
        for (k, &f) in m.freq_hz.iter().enumerate() {
            let expect = C::new(0.0, -2.0 * std::f64::consts::PI * f / fs).exp() * 2.0;
            let r = (m.ratio[k] / expect).ln();
            z2 += (r.re / m.sd_ln[k]).powi(2) + (r.im / m.sd_ln[k]).powi(2);
        }
        let per = z2 / (2.0 * m.freq_hz.len() as f64);
        assert!(per > 0.6 && per < 1.6, "normalized scatter {per}");
    }
}
