//! The firmware's operating point: its sample rate, block length, preview delay and the design
//! it runs. The firmware, its QEMU replay, the host's replica of the chain and the host tests
//! all take these from here, so none of them can drift from the device.

use crate::{DesignConfig, Real};

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

/// Samples per processed block (one DMA half-buffer: 16 ms at 2 kHz), defined with the filter
/// whose warm-up and fade count blocks.
pub use crate::filter::BLOCK_LEN;

impl<T: Real> DesignConfig<T> {
    /// The design the firmware runs: the default design at the firmware's sample rate.
    pub fn firmware() -> Self {
        DesignConfig::at_rate(T::lit(SAMPLE_RATE_HZ as f64))
    }
}

/// A retune is due when the humidity moved by more than this [% RH] from the RH of the active
/// (or already requested) design: about a tenth of the compensation error a 1 % RH mismatch
/// causes (≈ 3 %, `ipmc accuracy`), at ~1 retune per second during a fast 0.25 %/s drift.
pub const RETUNE_THRESHOLD_PCT: f32 = 0.25;

/// Whether a reading at `rh_pct` calls for a new design, given the RH of the last one (NaN:
/// none yet).
pub fn needs_retune(design_rh_pct: f32, rh_pct: f32) -> bool {
    design_rh_pct.is_nan() || (rh_pct - design_rh_pct).abs() > RETUNE_THRESHOLD_PCT
}

/// Whether the sample path asks for a design now: the humidity moved (`needs_retune`) and no
/// retune is under way. A design asked for during one would wait for it to end, up to a whole
/// retune later than the moment `block_humidity::design_lead_s` reads the humidity ahead for.
pub fn asks_for_design(design_rh_pct: f32, rh_pct: f32, retuning: bool) -> bool {
    !retuning && needs_retune(design_rh_pct, rh_pct)
}

/// Humidity polling period [ms] (the HTS221 runs at its 1 Hz output data rate). The firmware
/// holds each reading until the next, so on average a block uses one half a period old.
pub const HUMIDITY_PERIOD_MS: u64 = 1_000;

/// Average age of the reading a firmware block uses [s] (see [`HUMIDITY_PERIOD_MS`]).
pub fn reading_age_s() -> f64 {
    HUMIDITY_PERIOD_MS as f64 / 2000.0
}

/// Settling skipped at the start of each burst when an estimate is scored [s]. The regularizing
/// high-pass's start-up rings at ~1 Hz, decaying as e^(−1.94 t) (its Butterworth poles' least
/// damped pair), from an amplitude of the 1/ω² double integration's, thousands of times the
/// signal; the band's FIR takes 40 dB off its ~1 Hz content, but the tail of its spectrum
/// reaches into the band and measured 3–15 % of a clean sweep for 4 s. By 5 s it is 6·10⁻⁵
/// of its start.
pub const SETTLE_S: f64 = 5.0;

/// Samples the firmware's estimate lags the true base motion by, keeping `band`: its design's
/// preview (`max_delay_s`) and the band's linear-phase FIR (`band_limit`) at the firmware's
/// rate (a band the firmware cannot keep is refused when its calibration loads).
pub fn delay_samples(band: &crate::band::Band) -> usize {
    let c = DesignConfig::<f64>::firmware();
    let fir = crate::band_limit::check(band, c.fs_hz).map_or(0, |n| (n - 1) / 2);
    (c.max_delay_s * c.fs_hz).round() as usize + fir
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

    #[test]
    fn the_preview_is_whole_samples() {
        let c = crate::DesignConfig::<f64>::firmware();
        let band = crate::band::Band::DEFAULT;
        let fir = crate::band_limit::Taps::design(&band, c.fs_hz).unwrap().delay_samples();
        assert_eq!((super::delay_samples(&band) - fir) as f64, c.max_delay_s * c.fs_hz);
        assert_eq!(super::delay_samples(&band), 4 + fir, "the preview is 2 ms, 4 samples");
    }
}
