//! A check's reference: the base displacement its accelerometer says. A check has no laser; the
//! board's accelerometer on the strip's base measures the drive. Integrated twice (in frequency,
//! X = −A/ω², from half the band's lower edge up) and put through the same band filter as a
//! true base motion, it is what the estimate is compared with. Its chain's delay (filters and
//! resampling, 0.3–1.5 ms by its datasheet) is a phase of up to 80° at 150 Hz, more than any
//! calibration's error: it is fitted (with the clocks' residual rate difference, which makes it
//! grow along the run), the delay in that range where the estimate's cross-correlation with it
//! peaks; its gain (±1 %) is not, and is part of what the figure states.

use super::Scoring;
use ipmc_core::C;
use ipmc_core::band::{BandDesign, BandTaps};
use ipmc_core::calibration::instrument::{ACCELEROMETER_LOWPASS_HZ, accelerometer_chain};
use ipmc_core::firmware::calibration_stale::StaleTest;
use ipmc_core::firmware::running_error::{RunningError, Window};
use ipmc_core::resample::track::LAG_BLOCKS;
use ipmc_core::timing::BLOCK_LEN;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use std::f64::consts::PI;
use std::ops::Range;

/// The accelerometer chain's delay by its datasheet and the resampling [s]: the range searched.
pub const DELAY_RANGE_S: (f64, f64) = (0.3e-3, 1.5e-3);

/// `accel` [m/s²] at `fs_hz` as displacement: X = −A/ω² above `low_hz` / 2 (below it the double
/// integral lifts the part's noise without bound and the band filter drops it), the chain's
/// second-order low-pass divided out in band (it is below 0.1 dB there), the mean taken out.
/// Extended by its mirror image, so that its ends meet without a jump: a jump's leakage, lifted
/// by 1/ω², would reach into the band. Its chain's delay is left in ([`fitted_truth`] finds it).
pub fn displacement(accel: &[f64], fs_hz: f64, low_hz: f64) -> Vec<f64> {
    let n = 2 * accel.len();
    let mean = accel.iter().sum::<f64>() / accel.len().max(1) as f64;
    let mut buf: Vec<Complex<f64>> = accel.iter().chain(accel.iter().rev()).map(|a| Complex::new(a - mean, 0.0)).collect();
    let mut planner = FftPlanner::<f64>::new();
    planner.plan_fft_forward(n).process(&mut buf);
    for (k, x) in buf.iter_mut().enumerate() {
        let f = (if k <= n / 2 { k as f64 } else { k as f64 - n as f64 }) * fs_hz / n as f64;
        *x = if f.abs() < low_hz / 2.0 {
            Complex::new(0.0, 0.0)
        } else {
            let w = 2.0 * PI * f;
            -*x / (w * w * lowpass(f))
        };
    }
    planner.plan_fft_inverse(n).process(&mut buf);
    buf.iter().take(accel.len()).map(|c| c.re / n as f64).collect()
}

/// The part's low-pass at `f` [Hz] (the core's model of its chain, without gain or delay).
fn lowpass(f: f64) -> Complex<f64> {
    let h = accelerometer_chain(1.0, 0.0, ACCELEROMETER_LOWPASS_HZ, C::new(0.0, 2.0 * PI * f));
    Complex::new(h.re, h.im)
}

/// Windows the chain's delay is found in, one by one [s]: long enough that a window's
/// cross-correlation peak is sharp, short enough that the clocks' residual rate (±20 ppm: 0.1 µs
/// a window) does not move it within one.
const DELAY_WINDOW_S: f64 = 5.0;

/// The truth a check's estimate is compared with, and the chain's delay [s] and the clocks'
/// residual rate difference [ppm] fitted: the accelerometer's displacement through the
/// scoring's band, advanced by d(t) = d₀ + ε·t. Per window, the lag of the estimate's
/// cross-correlation peak with it (parabolic between samples); d₀ and ε the least-squares line
/// through them, d₀ then refined within a sample to the least error, held to [`DELAY_RANGE_S`]. The rate difference turns a delay into one that
/// grows along the run (28 ppm is 1.7 ms over a minute): the firmware tracks the part's clock
/// against the ADC's, and what it leaves is what is fitted here.
pub fn fitted_truth(scoring: &Scoring, accel: &[f64], estimate: &[f32], bursts: &[Range<usize>]) -> (Vec<f64>, f64, f64) {
    let truth0 = scoring.truth(&displacement(accel, scoring.fs_hz, scoring.band.low_hz), bursts);
    let fs = scoring.fs_hz;
    let w = (DELAY_WINDOW_S * fs) as usize;
    let max_lag = (2.0 * DELAY_RANGE_S.1 * fs).ceil() as isize;
    let mut points: Vec<(f64, f64)> = vec![];
    for b in bursts {
        let mut start = b.start + scoring.skip() + max_lag as usize;
        while start + w + (max_lag as usize) <= b.end.min(estimate.len()) {
            let corr = |lag: isize| -> f64 {
                (start..start + w)
                    .map(|k| {
                        let (e, t) = (f64::from(estimate[k]), truth0[(k as isize + lag) as usize]);
                        if e.is_finite() && t.is_finite() { e * t } else { 0.0 }
                    })
                    .sum()
            };
            // The truth made at zero delay lags the base by the chain's delay: advanced by d it
            // matches the estimate, the peak of Σ e(k)·t0(k + lag) at lag = d.
            let c: Vec<f64> = (-1..=max_lag + 1).map(corr).collect();
            let peak = (1..c.len() - 1).max_by(|&i, &j| c[i].total_cmp(&c[j])).unwrap_or(1);
            let (l, m, r) = (c[peak - 1], c[peak], c[peak + 1]);
            let frac = if l - 2.0 * m + r < 0.0 { 0.5 * (l - r) / (l - 2.0 * m + r) } else { 0.0 };
            let lag = (peak as f64 - 1.0) + frac;
            points.push(((start + w / 2) as f64 / fs, lag / fs));
            start += w;
        }
    }
    let (d0, rate) = line(&points);
    // A correlation peak interpolated between samples is biased by a fraction of one: the
    // delay is refined within a sample of it to the one that brings the estimate closest.
    let truth_at = |d: f64| advance(&truth0, fs, |k| d + rate * k as f64 / fs);
    let error_at = |d: f64| {
        let s = scoring.score(estimate, &truth_at(d), bursts, None);
        if s.bursts.is_empty() { f64::INFINITY } else { s.pooled.error() }
    };
    let (mut a, mut b) = ((d0 - 1.0 / fs).max(DELAY_RANGE_S.0), (d0 + 1.0 / fs).min(DELAY_RANGE_S.1));
    if a >= b {
        (a, b) = (DELAY_RANGE_S.0, DELAY_RANGE_S.1);
    }
    let g = (5f64.sqrt() - 1.0) / 2.0;
    while b - a > 1e-7 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if error_at(c) < error_at(d) { b = d } else { a = c }
    }
    let d0 = 0.5 * (a + b);
    (truth_at(d0), d0, 1e6 * rate)
}

/// The least-squares line through (t, d): its value at t = 0 (the run's start, where the
/// firmware's resampling aligned the clocks) and its slope. One point: its value, no slope;
/// none: the middle of the delay's range.
fn line(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    if points.is_empty() {
        return (0.5 * (DELAY_RANGE_S.0 + DELAY_RANGE_S.1), 0.0);
    }
    let tm = points.iter().map(|p| p.0).sum::<f64>() / n;
    let dm = points.iter().map(|p| p.1).sum::<f64>() / n;
    let stt: f64 = points.iter().map(|p| (p.0 - tm).powi(2)).sum();
    let std: f64 = points.iter().map(|p| (p.0 - tm) * (p.1 - dm)).sum();
    let slope = if stt > 0.0 { std / stt } else { 0.0 };
    (dm - slope * tm, slope)
}

/// What the device measures of the same estimate against the same accelerometer: the core's
/// running error ([`RunningError`], f32 as on the device) run a block at a time over the first
/// burst, the accelerometer's block [`LAG_BLOCKS`] behind its estimate's as the firmware has it;
/// `rel_err` the blocks' stated 1σ (the estimate file's column; none: not stated).
pub struct DeviceMeasure {
    pub windows: Vec<Window<f32>>,
}

impl DeviceMeasure {
    pub fn run(scoring: &Scoring, accel: &[f64], estimate: &[f32], rel_err: Option<&[f32]>, bursts: &[Range<usize>]) -> Option<Self> {
        let burst = bursts.first()?.clone();
        let taps = &BandTaps::<f32>::from_design(&BandDesign::design(&scoring.band, scoring.fs_hz).ok()?);
        let mut measure = RunningError::new(taps, scoring.fs_hz, scoring.preview);
        let end = burst.end.min(estimate.len()).min(accel.len());
        let blocks = (end.saturating_sub(burst.start)) / BLOCK_LEN;
        let at = |b: usize| burst.start + b * BLOCK_LEN..burst.start + (b + 1) * BLOCK_LEN;
        let mut out = [0.0f32; BLOCK_LEN];
        let mut windows = vec![];
        for b in 0..blocks {
            let stated = rel_err.map_or(f32::NAN, |r| r[at(b).start]);
            measure.estimate(&estimate[at(b)], stated);
            if let Some(lagged) = b.checked_sub(LAG_BLOCKS) {
                let a: Vec<f32> = accel[at(lagged)].iter().map(|&x| x as f32).collect();
                windows.extend(measure.reference(taps, &a, &mut out));
            }
        }
        Some(DeviceMeasure { windows })
    }

    /// The error pooled over the windows: √(Σ error / Σ reference).
    pub fn pooled(&self) -> f64 {
        let (e, r) = self.windows.iter().fold((0.0, 0.0), |(e, r), w| (e + f64::from(w.error_sum), r + f64::from(w.reference_sum)));
        (e / r).sqrt()
    }

    /// The stated 1σ over the windows (rms).
    pub fn stated(&self) -> f64 {
        let n = self.windows.len().max(1) as f64;
        (self.windows.iter().map(|w| f64::from(w.stated).powi(2)).sum::<f64>() / n).sqrt()
    }

    /// The first window the device called the calibration stale in.
    pub fn first_stale(&self) -> Option<usize> {
        self.windows.iter().position(|w| w.stale)
    }

    /// The device's stale test as it stands after the last window (its windows' errors again,
    /// in the same order and precision): what [`super::stale_chance::undecided`] reads.
    pub fn stale_test(&self) -> StaleTest<f32> {
        let mut t = StaleTest::new();
        for w in &self.windows {
            t.push(w.measured, w.stated);
        }
        t
    }
}

/// Half-length of the interpolating kernel [samples].
const KERNEL_HALF: isize = 16;

/// `x` (band-limited well below `fs_hz` / 2) advanced by `delay_at(k)` seconds at sample k:
/// Blackman-windowed sinc interpolation; NaN (a sample the scoring leaves out) where the kernel
/// reaches a NaN or past the record's ends.
fn advance(x: &[f64], fs_hz: f64, delay_at: impl Fn(usize) -> f64) -> Vec<f64> {
    (0..x.len())
        .map(|k| {
            let at = k as f64 + delay_at(k) * fs_hz;
            let centre = at.floor() as isize;
            let mut sum = 0.0;
            for j in centre - KERNEL_HALF + 1..=centre + KERNEL_HALF {
                // Past either end the record does not say: unknown, and not scored.
                let Some(&v) = usize::try_from(j).ok().and_then(|j| x.get(j)) else { return f64::NAN };
                let u = at - j as f64;
                let sinc = if u.abs() < 1e-12 { 1.0 } else { (PI * u).sin() / (PI * u) };
                let window = 0.42 + 0.5 * (PI * u / KERNEL_HALF as f64).cos() + 0.08 * (2.0 * PI * u / KERNEL_HALF as f64).cos();
                sum += v * sinc * window;
            }
            sum
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::band::Band;

    /// A base moving as two tones, its acceleration delayed by 0.8 ms and through the part's
    /// low-pass: the delay is found, and an estimate that is the base through the band scores
    /// nil against the displacement (through the band: below it a record's ends leak energy
    /// that the double integral lifts, and the band filter takes away).
    #[test]
    fn the_accelerometers_displacement_is_the_base_and_its_delay_is_found() {
        let fs = 2000.0;
        let n = 40_000;
        let tones = [(23.0, 1e-5, 0.3), (97.0, 2e-6, 1.1)];
        let base = |t: f64| tones.iter().map(|&(f, a, p)| a * (2.0 * PI * f * t + p).sin()).sum::<f64>();
        let delay = 0.8e-3;
        // The acceleration of the base delayed, through the 666 Hz low-pass's response at each tone.
        let accel: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 / fs - delay;
                tones
                    .iter()
                    .map(|&(f, a, p)| {
                        let h = lowpass(f);
                        let w = 2.0 * PI * f;
                        -w * w * a * h.norm() * (w * t + p + h.arg()).sin()
                    })
                    .sum()
            })
            .collect();
        let scoring = Scoring::new(&Band::DEFAULT, fs, None).unwrap();
        let whole = 0..n;
        let bursts = std::slice::from_ref(&whole);
        let truth_base: Vec<f64> = (0..n).map(|k| base(k as f64 / fs)).collect();
        let estimate: Vec<f32> = scoring.truth(&truth_base, bursts).iter().map(|&x| x as f32).collect();
        let (truth, found, rate_ppm) = fitted_truth(&scoring, &accel, &estimate, bursts);
        assert!((found - delay).abs() < 0.002e-3 && rate_ppm.abs() < 1.0, "delay {found} against {delay}, rate {rate_ppm} ppm");
        let error = scoring.score(&estimate, &truth, bursts, None).pooled.error();
        assert!(error < 1e-3, "error {error}");
        // Only the samples whose kernel runs past the record's end are left unscored.
        let unknown = truth[n / 2..].iter().filter(|t| t.is_nan()).count();
        assert!(unknown > 0 && unknown <= KERNEL_HALF as usize + 2, "{unknown} unknown at the end");
    }

    /// A minute's check whose estimate is the base 8 % too large with the current's noise
    /// through the band (4 % of it), the accelerometer 0.7 ms late and its clock 15 ppm off:
    /// the device's running error (f32, a block at a time, the accelerometer 4 blocks behind)
    /// agrees with score's figure within 2 % of it (the bound is a tenth), and calls the calibration stale (8.9 %
    /// against a stated 2 %).
    #[test]
    fn the_device_measures_what_score_does() {
        let fs = 2000.0;
        let n = 120_000;
        let mut seed = 11u64;
        let mut uniform = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        // A broadband drive: tones from 5 to 300 Hz, the acceleration flat.
        let tones: Vec<(f64, f64, f64)> =
            (0..60).map(|k| (5.0 * 1.07f64.powi(k), 1.0, 2.0 * PI * uniform())).filter(|t| t.0 < 300.0).collect();
        let (delay, rate) = (0.7e-3, 15e-6);
        let accel: Vec<f64> = (0..n)
            .map(|k| {
                let t0 = k as f64 / fs;
                let t = t0 - delay - rate * t0;
                9.81 + tones
                    .iter()
                    .map(|&(f, a, p)| {
                        let h = lowpass(f);
                        a * h.norm() * (2.0 * PI * f * t + p + h.arg()).sin()
                    })
                    .sum::<f64>()
            })
            .collect();
        let base: Vec<f64> = (0..n)
            .map(|k| {
                let t = k as f64 / fs;
                tones.iter().map(|&(f, a, p)| -a / (2.0 * PI * f).powi(2) * (2.0 * PI * f * t + p).sin()).sum()
            })
            .collect();
        let scoring = Scoring::new(&Band::DEFAULT, fs, None).unwrap();
        let whole = 0..n;
        let bursts = std::slice::from_ref(&whole);
        let noise: Vec<f64> = (0..n).map(|_| uniform() - 0.5).collect();
        let (t, w) = (scoring.truth(&base, bursts), scoring.filtered(&noise, bursts));
        let rms = |x: &[f64]| (x[20_000..].iter().map(|v| v * v).sum::<f64>() / (n - 20_000) as f64).sqrt();
        let scale = 0.04 * rms(&t) / rms(&w);
        // Before the band filter's delay, the truth through it is unknown: the estimate is nought there.
        let estimate: Vec<f32> = t.iter().zip(&w).map(|(t, w)| if t.is_nan() { 0.0 } else { (1.08 * t + scale * w) as f32 }).collect();
        let (truth, _, _) = fitted_truth(&scoring, &accel, &estimate, bursts);
        let score = scoring.score(&estimate, &truth, bursts, None).pooled.error();
        let stated = vec![0.02f32; n];
        let device = DeviceMeasure::run(&scoring, &accel, &estimate, Some(&stated), bursts).unwrap();
        let pooled = device.pooled();
        assert!(device.windows.len() >= 8, "{} windows", device.windows.len());
        assert!((score - 0.089).abs() < 0.005, "score {score}");
        assert!((pooled / score - 1.0).abs() < 0.02, "the device {pooled}, score {score}");
        assert_eq!(device.first_stale(), Some(0), "8.9 % against 2 % stated");
    }
}
