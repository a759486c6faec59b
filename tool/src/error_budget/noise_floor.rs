//! The current's noise density measured on a recording whose excitation is not periodic (a strip
//! in service): where no two periods can be differenced, the noise is what the current holds
//! where the strip's motion does not reach, the top octave below Nyquist.
//!
//! The front end's noise is white up to Nyquist (the assumption the chain's error bar and
//! `ipmc_recording::looping::noise_density` make too), while the strip's current follows the
//! base motion, which a structure in service carries at its own resonances, far below the
//! sampling rate's quarter. The median over the octave's bins of a Welch average is the floor
//! where a few lines of motion or interference remain: with hundreds of segments averaged each
//! bin is nearly Gaussian about the density, so its median is its mean.

use ipmc_core::C;
use ipmc_recording::TimeSeries;
use rustfft::FftPlanner;

/// Samples of a Welch segment: bins of fs/1024 (≈ 2 Hz at 2 kHz), a top octave of 256 bins.
const SEGMENT: usize = 1024;

/// The current's noise density [A/√Hz] from the top octave (fs/4 to fs/2) of its spectrum;
/// None when no burst holds a segment.
pub fn noise_density(ts: &TimeSeries) -> Option<f64> {
    let fft = FftPlanner::new().plan_fft_forward(SEGMENT);
    let window: Vec<f64> = (0..SEGMENT).map(|n| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * n as f64 / SEGMENT as f64).cos()).collect();
    let power: f64 = window.iter().map(|w| w * w).sum();
    let (first, last) = (SEGMENT / 4, SEGMENT / 2 - 1);
    let mut sum = vec![0.0; last - first + 1];
    let mut segments = 0usize;
    for b in ts.bursts() {
        let x = &ts.current_a[b];
        let mut start = 0;
        while start + SEGMENT <= x.len() {
            let seg = &x[start..start + SEGMENT];
            let mean = seg.iter().sum::<f64>() / SEGMENT as f64;
            let mut buf: Vec<C<f64>> = seg.iter().zip(&window).map(|(v, w)| C::new((v - mean) * w, 0.0)).collect();
            fft.process(&mut buf);
            for (s, z) in sum.iter_mut().zip(&buf[first..=last]) {
                *s += z.norm_sqr();
            }
            segments += 1;
            start += SEGMENT / 2;
        }
    }
    if segments == 0 {
        return None;
    }
    // One-sided density of the average: 2|X|²/(fs Σw²).
    let mut psd: Vec<f64> = sum.iter().map(|s| 2.0 * s / segments as f64 / (ts.fs_hz * power)).collect();
    psd.sort_by(f64::total_cmp);
    Some(psd[psd.len() / 2].sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn white_noise_under_a_low_tone() {
        let fs = 2000.0;
        let n = 40_000;
        let mut state = 12345u64;
        let mut gauss = || {
            let mut u = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
            };
            (-2.0 * u().ln()).sqrt() * (2.0 * std::f64::consts::PI * u()).cos()
        };
        // White noise of density D has variance D²·fs/2.
        let density = 3e-10;
        let sd = density * (fs / 2.0f64).sqrt();
        let mut ts = TimeSeries { fs_hz: fs, ..Default::default() };
        for k in 0..n {
            let t = k as f64 / fs;
            ts.t_s.push(t);
            ts.current_a.push(1e-6 * (2.0 * std::f64::consts::PI * 40.0 * t).sin() + sd * gauss());
            ts.rh_pct.push(60.0);
        }
        let d = noise_density(&ts).unwrap();
        assert!((d / density - 1.0).abs() < 0.05, "{d:e}");
    }
}
