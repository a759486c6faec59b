//! What the resampler leaves of a signal, measured the way the board runs it: a multisine of base
//! acceleration over 10–150 Hz sampled by the part at 1.66 kHz on its own oscillator (off by a
//! given rate error) through a filter chain's pure delay, stamped every 8 samples, the stamps
//! paired once a burst with the board's 80 MHz timer (with an interrupt's jitter), and read by
//! the [`Resampler`] at each 2 kHz ADC instant, a block at a time, the delay given; against the true acceleration at
//! those instants. The part's low-pass and the delay's own uncertainty are the instrument's, and
//! the host's check states them; this is the resampler's share alone.

use super::{clock_map::ClockMap, resampler::Resampler};
use crate::{numeric::real::Real, timing::BLOCK_LEN};

/// The part's timestamp count [s] and its samples' spacing in counts (1.66 kHz: 600 µs).
const COUNT_S: f64 = 25e-6;
const COUNTS_PER_SAMPLE: f64 = 24.0;
/// The board's timer and the ADC's rate.
const BOARD_HZ: f64 = 80e6;
const ADC_HZ: f64 = 2000.0;
/// Samples a burst (the watermark) and stamps' spacing.
const BURST: u64 = 64;
const STAMP_EVERY: u64 = 8;
/// The interrupt's latency jitter on the board's side [s], peak to peak.
const JITTER_S: f64 = 4e-6;
/// Tones of the multisine, log-spaced over the band.
const TONES: usize = 12;
const BAND_HZ: (f64, f64) = (10.0, 150.0);

/// What a run is: the part's rate error (e.g. 1e-4: 100 ppm fast), its chain's delay, the delay
/// the resampler is told, the band of the multisine [Hz].
#[derive(Debug, Clone, Copy)]
pub struct Case {
    pub rate_error: f64,
    pub delay_s: f64,
    pub told_delay_s: f64,
    pub band_hz: (f64, f64),
}

impl Case {
    /// The delay told as it is, over the calibration's band.
    pub fn in_band(rate_error: f64, delay_s: f64) -> Self {
        Self { rate_error, delay_s, told_delay_s: delay_s, band_hz: BAND_HZ }
    }
}

/// rms of (resampled − true) over rms(true) at the ADC's instants, over `seconds` after the clock
/// map's first second.
pub fn relative_error<T: Real>(case: Case, seconds: f64, seed: u64) -> f64 {
    let Case { rate_error, delay_s, told_delay_s, band_hz } = case;
    let mut state = seed;
    let mut uniform = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let tones: [(f64, f64); TONES] = core::array::from_fn(|i| {
        let f = band_hz.0 * libm::pow(band_hz.1 / band_hz.0, i as f64 / (TONES - 1) as f64);
        (f, 2.0 * core::f64::consts::PI * uniform())
    });
    let accel = |t: f64| tones.iter().map(|&(f, phase)| libm::sin(2.0 * core::f64::consts::PI * f * t + phase)).sum::<f64>();
    // The part's count lasts COUNT_S / (1 + rate_error) of true time; at time 0 its counter
    // reads some count and it takes its first sample; the board's timer reads some offset.
    let count_s = COUNT_S / (1.0 + rate_error);
    let part_origin = 1_000 + (uniform() * 1e6) as u64;
    let board_offset = 1e9 * uniform();
    let board_at = |t: f64| (board_offset + t * BOARD_HZ) as u64;
    let mut map = ClockMap::new(COUNT_S * BOARD_HZ, 0.999);
    let mut resampler = Resampler::<T>::new();
    let period = BOARD_HZ / ADC_HZ;
    let (mut k, mut n) = (0u64, 0u64);
    let (mut err2, mut sig2) = (0.0, 0.0);
    let adc_samples = ((seconds + 1.0) * ADC_HZ) as u64;
    while n < adc_samples {
        // A burst arrives: its samples, and one pair (its last stamp, the board's timer then).
        let mut last_stamp = None;
        for _ in 0..BURST {
            let count = part_origin + k * COUNTS_PER_SAMPLE as u64;
            let t = (count - part_origin) as f64 * count_s;
            resampler.push(k, T::lit(accel(t - delay_s)));
            if k.is_multiple_of(STAMP_EVERY) {
                last_stamp = Some((count, t));
            }
            k += 1;
        }
        if let Some((count, t)) = last_stamp {
            map.push(count, board_at(t + JITTER_S * (uniform() - 0.5)));
        }
        // The ADC's blocks up to the burst's end less two bursts' margin for the bus, the
        // resampler retimed at the first block after each burst.
        let burst_end_s = (k * COUNTS_PER_SAMPLE as u64) as f64 * count_s;
        let margin_s = 2.0 * BURST as f64 * COUNTS_PER_SAMPLE * COUNT_S;
        let mut retimed = false;
        while ((n + BLOCK_LEN as u64) as f64 / ADC_HZ) < burst_end_s - margin_s {
            if !retimed {
                let board = board_offset as u64 + (n as f64 * period) as u64;
                resampler.retime(&map, board, period, part_origin, COUNTS_PER_SAMPLE, told_delay_s / COUNT_S);
                retimed = true;
            }
            let mut block = [T::zero(); BLOCK_LEN];
            if resampler.next_block(&mut block) {
                for (j, v) in block.iter().enumerate() {
                    let t = (n + j as u64) as f64 / ADC_HZ;
                    if t > 1.0 {
                        let truth = accel(t);
                        let e = v.to_f64() - truth;
                        err2 += e * e;
                        sig2 += truth * truth;
                    }
                }
            }
            n += BLOCK_LEN as u64;
        }
    }
    libm::sqrt(err2 / sig2)
}

#[cfg(test)]
mod tests {
    use super::{Case, relative_error};

    /// The bound: at most 0.5 % of the signal in 10–150 Hz for a rate error of ±100 ppm and a
    /// chain delay of 0.3–1.5 ms, in f32 as the device runs it; and at the band's top alone.
    #[test]
    fn the_resampler_leaves_under_half_a_percent_in_band() {
        for rate_error in [-100e-6, 0.0, 100e-6] {
            for delay_s in [0.3e-3, 0.9e-3, 1.5e-3] {
                let case = Case::in_band(rate_error, delay_s);
                let e = relative_error::<f32>(case, 10.0, 3);
                let top = relative_error::<f32>(Case { band_hz: (150.0, 150.0), ..case }, 10.0, 3);
                std::println!(
                    "rate {:+.0} ppm, delay {:.1} ms: {:.3} % (150 Hz alone {:.3} %)",
                    rate_error * 1e6,
                    delay_s * 1e3,
                    100.0 * e,
                    100.0 * top
                );
                assert!(e < 0.005 && top < 0.005, "{e} {top}");
                assert!(relative_error::<f64>(case, 10.0, 3) <= e + 1e-4, "f32's rounding adds little");
            }
        }
    }

    #[test]
    fn a_delay_told_wrong_by_a_sample_shows() {
        // 0.6 ms at 150 Hz: |1 − e^(jωτ)| = 2 sin(ωτ/2) = 0.55.
        let case = Case { told_delay_s: 0.9e-3 + 0.6e-3, band_hz: (150.0, 150.0), ..Case::in_band(50e-6, 0.9e-3) };
        let e = relative_error::<f64>(case, 2.0, 3);
        assert!((e - 0.55).abs() < 0.02, "{e}");
    }
}
