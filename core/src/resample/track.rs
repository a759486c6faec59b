//! The board's accelerometer followed onto the ADC's clock, as the device runs it and the host
//! replays it: the part's bursts in (their samples numbered from the FIFO's timestamps, one pair
//! of a stamp and the board's timer a burst into the [`ClockMap`]), a block of accelerations out
//! for an ADC block. A burst reaches the board a watermark (38 ms) and a bus read after its first
//! sample, so an ADC block is resampled [`LAG_BLOCKS`] blocks after it was sampled: the caller
//! keeps the block's current until then, and a check's samples travel that much behind the
//! estimates.
//!
//! The resampler is retimed from the clock map after each burst and after samples the ADC lost,
//! not at every block: the map's f64 arithmetic is software on the device.

use super::{clock_map::ClockMap, resampler::Resampler};
use crate::timing::{BLOCK_LEN, SAMPLE_RATE_HZ};

/// The board's timer the map is fitted against [counts/s] (TIM2 at SYSCLK, 80 MHz).
pub const BOARD_HZ: u64 = 80_000_000;
/// The board's timer counts between two ADC samples.
pub const BOARD_COUNTS_PER_SAMPLE: u64 = BOARD_HZ / SAMPLE_RATE_HZ as u64;
/// The part's timestamp count [s] (TIMER_HR) and its samples' spacing in counts (1.66 kHz: 600 µs).
pub const PART_COUNT_S: f64 = 25e-6;
pub const PART_COUNTS_PER_SAMPLE: u64 = 24;
/// How many ADC blocks a block waits for the part's samples around it: a watermark of 64
/// samples (38.6 ms) and its read on the bus (under 10 ms at 400 kHz) after its first sample,
/// and the interpolator's two samples beyond: 4 blocks, 64 ms.
pub const LAG_BLOCKS: usize = 4;
/// The delay of the LSM6DSL's filter chain as the driver configures it (1.66 kHz, anti-aliasing
/// at 1.5 kHz, LPF1 at ODR/2, LPF2 and the high-pass off) that the device takes out of its
/// samples [s]: none. The datasheet states no group delay for this configuration; what the chain
/// delays is the instrument's, which a check fits as a nuisance parameter (`ipmc recalibrate`).
pub const CHAIN_DELAY_S: f64 = 0.0;
/// Pairs the clock map remembers (its weight falls by 1/e over as many bursts: 38 s).
const MAP_MEMORY_PAIRS: f64 = 1000.0;

/// One of the part's samples: its acceleration along the strip's bending axis [m/s²] and, where
/// the FIFO stamped it, its timestamp (unwrapped, in the part's counts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartSample {
    pub accel_mps2: f32,
    pub stamp: Option<u64>,
}

/// The clock map, the resampler and the numbering of the part's samples.
#[derive(Debug, Clone)]
pub struct AccelTrack {
    map: ClockMap,
    resampler: Resampler<f32>,
    /// The part's timestamp of its sample 0: the first stamp seen.
    origin: Option<u64>,
    /// The number of the next sample pushed; None after an overrun until a stamp places it.
    next: Option<u64>,
    /// The chain's delay [part counts]: a sample shows the signal of that much earlier.
    delay_counts: f64,
    retime_due: bool,
}

impl AccelTrack {
    /// For a part whose filter chain delays its samples by `delay_s`.
    pub fn new(delay_s: f64) -> Self {
        Self {
            map: ClockMap::new(PART_COUNT_S * BOARD_HZ as f64, 1.0 - 1.0 / MAP_MEMORY_PAIRS),
            resampler: Resampler::new(),
            origin: None,
            next: None,
            delay_counts: delay_s / PART_COUNT_S,
            retime_due: false,
        }
    }

    /// A burst of the part's samples in FIFO order; `overran`: samples were lost before it (the
    /// ones before its first stamp cannot be placed and are dropped); `board_at_last_stamp`: the
    /// board's timer at the instant of the burst's last stamped sample.
    pub fn burst(&mut self, samples: &[PartSample], overran: bool, board_at_last_stamp: Option<u64>) {
        if overran {
            self.next = None;
        }
        let mut last_stamp = None;
        for s in samples {
            if let Some(stamp) = s.stamp {
                let origin = *self.origin.get_or_insert(stamp);
                // The nearest whole sample: a stamp is taken with its sample, 24 counts apart.
                let counts = stamp.saturating_sub(origin) + PART_COUNTS_PER_SAMPLE / 2;
                self.next = Some(counts / PART_COUNTS_PER_SAMPLE);
                last_stamp = Some(stamp);
            }
            if let Some(k) = self.next {
                self.resampler.push(k, s.accel_mps2);
                self.next = Some(k + 1);
            }
        }
        if let (Some(stamp), Some(board)) = (last_stamp, board_at_last_stamp) {
            self.map.push(stamp, board);
            self.retime_due = true;
        }
    }

    /// The accelerations at the ADC samples `first_sample`… of a block (`out.len()` of them,
    /// [`BLOCK_LEN`] on the device), the board's timer reading `board_origin` at ADC sample 0;
    /// `lost`: the ADC lost samples before this block. `false` (and `out` untouched) while the
    /// part's samples around it are not all there.
    pub fn block(&mut self, first_sample: u64, board_origin: u64, lost: bool, out: &mut [f32]) -> bool {
        if (self.retime_due || lost)
            && let Some(origin) = self.origin
        {
            let board = board_origin + first_sample * BOARD_COUNTS_PER_SAMPLE;
            self.resampler.retime(
                &self.map,
                board,
                BOARD_COUNTS_PER_SAMPLE as f64,
                origin,
                PART_COUNTS_PER_SAMPLE as f64,
                self.delay_counts,
            );
            self.retime_due = false;
        }
        self.resampler.next_block(out)
    }
}

const _: () = assert!(BLOCK_LEN * LAG_BLOCKS * 1000 / SAMPLE_RATE_HZ as usize >= 50, "the lag covers a watermark and its read");

#[cfg(test)]
mod tests {
    use super::*;

    /// A 40 Hz tone sampled by a part 80 ppm fast, bursts of 64 arriving 10 ms after their last sample: each block resampled [`LAG_BLOCKS`] blocks late
    /// is the tone at the ADC's instants, to the resampler's error.
    #[test]
    fn a_tone_comes_back_on_the_adc_clock() {
        let rate_error = 80e-6;
        let delay_s = 0.9e-3;
        let count_s = PART_COUNT_S / (1.0 + rate_error);
        let tone = |t: f64| 3.0 * libm::sin(2.0 * core::f64::consts::PI * 40.0 * t + 0.3);
        let origin = 16_000_000u64;
        let mut track = AccelTrack::new(delay_s);
        let part_t = |k: u64| k as f64 * PART_COUNTS_PER_SAMPLE as f64 * count_s;
        let (mut k, mut err2, mut sig2, mut whole) = (0u64, 0.0, 0.0, 0);
        for block in 0..400u64 {
            let end_s = ((block + 1) * BLOCK_LEN as u64) as f64 / SAMPLE_RATE_HZ as f64;
            // Bursts whose last sample is 10 ms before this block's end have arrived.
            while part_t(k + 63) + 0.010 <= end_s {
                let samples: [PartSample; 64] = core::array::from_fn(|j| {
                    let n = k + j as u64;
                    let stamp = n.is_multiple_of(8).then_some(origin + n * PART_COUNTS_PER_SAMPLE);
                    PartSample { accel_mps2: tone(part_t(n) - delay_s) as f32, stamp }
                });
                let last = k + 56;
                track.burst(&samples, false, Some((part_t(last) * BOARD_HZ as f64).round() as u64));
                k += 64;
            }
            let Some(lagged) = block.checked_sub(LAG_BLOCKS as u64) else { continue };
            let first = lagged * BLOCK_LEN as u64;
            let mut out = [0.0f32; BLOCK_LEN];
            if track.block(first, 0, false, &mut out) {
                whole += 1;
                for (j, v) in out.iter().enumerate() {
                    let truth = tone((first + j as u64) as f64 / SAMPLE_RATE_HZ as f64);
                    err2 += (f64::from(*v) - truth).powi(2);
                    sig2 += truth * truth;
                }
            }
        }
        assert!(whole >= 390, "{whole} whole blocks of 396");
        let e = libm::sqrt(err2 / sig2);
        assert!(e < 2e-3, "{e}");
    }
}
