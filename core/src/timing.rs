//! The firmware's clock: its sample rate, its block length and how often it reads the humidity.
//! Below everything else in the core, since the band a calibration may declare, the filter's
//! warm-up and fade, and the board's timers all count in these units.

/// Current sampling rate [Hz]. The board's trigger timer and the filter design both use it.
pub const SAMPLE_RATE_HZ: u32 = 2_000;

/// Clocks of a timer clocked at `timer_clock_hz` per sample: the nearest whole number to the
/// real clock over the rate, so the rate is [`SAMPLE_RATE_HZ`] to within half a clock per period
/// (12.5 ppm at most at 80 MHz, 1.0 ppm with the board's real clock) plus the clock's own error. A period computed from the clock's
/// nominal frequency instead carries the difference between nominal and real into every
/// designed frequency and every time stamp.
pub const fn sample_period_clocks(timer_clock_hz: u64) -> u64 {
    (timer_clock_hz + SAMPLE_RATE_HZ as u64 / 2) / SAMPLE_RATE_HZ as u64
}

/// Samples per block on the device and in the host's replica of it. Part of the algorithm, not
/// a detail of either side: warm-up and fade are counted per block, so host and device agree bit
/// for bit only with the same block length.
pub const BLOCK_LEN: usize = 32;

/// Humidity polling period [ms] (the HTS221 runs at its 1 Hz output data rate). The firmware
/// holds each reading until the next, so on average a block uses one half a period old.
pub const HUMIDITY_PERIOD_MS: u64 = 1_000;

/// Average age of the reading a firmware block uses [s] (see [`HUMIDITY_PERIOD_MS`]).
pub fn reading_age_s() -> f64 {
    HUMIDITY_PERIOD_MS as f64 / 2000.0
}

/// Samples lost in a gap of `gap_us` between the arrivals of two blocks (an ADC overrun: the
/// ring buffer restarts and the samples in between are gone). Whole blocks, since the DMA
/// delivers half-buffers: the gap is rounded to block periods, and one period is the block
/// that did arrive.
pub fn samples_lost(gap_us: u64) -> u32 {
    let period_us = 1_000_000 * BLOCK_LEN as u64 / SAMPLE_RATE_HZ as u64;
    let periods = (gap_us + period_us / 2) / period_us;
    (periods.saturating_sub(1) * BLOCK_LEN as u64).min(u32::MAX as u64) as u32
}

#[cfg(test)]
mod tests {
    #[test]
    fn gaps_count_whole_blocks() {
        use super::{BLOCK_LEN, samples_lost};
        // 16 ms per block at 2 kHz: an on-time block lost nothing, jitter included.
        assert_eq!(samples_lost(16_000), 0);
        assert_eq!(samples_lost(23_000), 0);
        assert_eq!(samples_lost(0), 0);
        assert_eq!(samples_lost(25_000), BLOCK_LEN as u32);
        assert_eq!(samples_lost(48_000), 2 * BLOCK_LEN as u32);
        assert_eq!(samples_lost(1_000_000), 62 * BLOCK_LEN as u32);
    }

    #[test]
    fn the_sample_period_is_set_from_the_real_clock() {
        use super::{SAMPLE_RATE_HZ, sample_period_clocks};
        let rate_error_ppm = |clock: u64, period: u64| (clock as f64 / period as f64 / SAMPLE_RATE_HZ as f64 - 1.0) * 1e6;
        // MSI locked to the 32.768 kHz crystal (122 × LSE) × 40 / 2: 79 953 920 Hz, not 80 MHz.
        let msi_pll = 122 * 32_768 * 40 / 2;
        let period = sample_period_clocks(msi_pll);
        assert_eq!(period, 39_977);
        // 39 976.96 clocks rounded: −1.0 ppm, twenty times below the crystal's tolerance.
        assert!((rate_error_ppm(msi_pll, period) + 1.0).abs() < 0.01, "{} ppm", rate_error_ppm(msi_pll, period));
        // The period from the nominal 80 MHz would run the sampling 576 ppm slow.
        assert!(rate_error_ppm(msi_pll, sample_period_clocks(80_000_000)) < -570.0);
        // HSI16 × 10 / 2, the clock without the crystal: exactly 80 MHz nominal.
        assert_eq!(sample_period_clocks(80_000_000), 40_000);
        // Any clock from 10 MHz up: within half a clock per period.
        for clock in [10_000_000u64, 16_000_000, 48_000_000, 79_953_920, 80_000_000, 120_000_000] {
            assert!(rate_error_ppm(clock, sample_period_clocks(clock)).abs() <= 0.5e6 / (clock as f64 / SAMPLE_RATE_HZ as f64) + 1e-9);
        }
    }
}
