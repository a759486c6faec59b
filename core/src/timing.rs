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

/// Polls in a row without a new humidity sample after which the reading counts as stale (the
/// humidity task's own test).
pub const STALE_AFTER_PERIODS: u64 = 3;

/// Age of the last new reading beyond which the sample path flags it stale itself [ms]: the
/// humidity task's threshold plus its read timeout (half a period). While that task runs it
/// flags first; the sample path's test catches the task that no longer runs at all (a wedged I/O
/// executor), which cannot flag its own silence.
pub const READING_STALE_MS: u64 = STALE_AFTER_PERIODS * HUMIDITY_PERIOD_MS + HUMIDITY_PERIOD_MS / 2;

/// Whether a reading `age_ms` old is stale, as the sample path judges it.
pub fn reading_is_stale(age_ms: u64) -> bool {
    age_ms > READING_STALE_MS
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_reading_goes_stale_after_the_humidity_task_would_have_said_so() {
        use super::{HUMIDITY_PERIOD_MS, STALE_AFTER_PERIODS, reading_is_stale};
        // A sensor with no new sample for a couple of polls is not stale.
        assert!(!reading_is_stale(2 * HUMIDITY_PERIOD_MS + 400));
        // The humidity task flags at three periods, once a poll: the sample path only later.
        assert!(!reading_is_stale(STALE_AFTER_PERIODS * HUMIDITY_PERIOD_MS + 100));
        // A task that stopped polling: stale within four periods.
        assert!(reading_is_stale(4 * HUMIDITY_PERIOD_MS));
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
