//! Humidity: polls the board's sensor about once a second and keeps the last good reading
//! for the sample path, which turns it into the strip's humidity block by block
//! (`ipmc_core::block_humidity`) and asks for retunes. Before sampling starts this task asks for
//! the first design itself: at the first reading, or at a fallback when the sensor is silent.

use embassy_time::{Duration, Instant, Ticker, with_timeout};
use ipmc_core::{block_humidity::BlockHumidity, operating_point::reading_age_s};

use crate::board::Humidity;

use super::{
    config::{HUMIDITY_PERIOD_MS, RH_FALLBACK_PCT},
    flags,
    handoff::{self, LATEST_READ_RH_PCT, RETUNE_REQUEST},
    ports::{HumidityError, HumiditySource},
};

/// A reading that takes longer than this counts as no response.
const READ_TIMEOUT: Duration = Duration::from_millis(HUMIDITY_PERIOD_MS / 2);

/// Polls in a row without a new sample after which the reading counts as stale.
const NO_NEW_DATA_PERIODS: u64 = 3;

#[embassy_executor::task]
pub async fn humidity_task(mut sensor: Humidity) {
    let mut ticker = Ticker::every(Duration::from_millis(HUMIDITY_PERIOD_MS));
    // Whether the first design has been asked for (later ones come from the sample path).
    let mut first_requested = false;
    let mut failures: u32 = 0;
    let started = Instant::now();
    let mut last_new = Instant::now();
    loop {
        let reading = match with_timeout(READ_TIMEOUT, sensor.read_rh_pct()).await {
            Ok(r) => r,
            Err(_) => Err(HumidityError::NoResponse),
        };
        match reading {
            Ok(raw) => {
                last_new = Instant::now();
                LATEST_READ_RH_PCT.store(raw);
                if failures > 0 {
                    defmt::info!("humidity back after {} failed readings", failures);
                }
                failures = 0;
                handoff::set_condition(flags::RH_STALE, false);
                if !first_requested {
                    // The strip starts settled at the first reading: the sample path's first
                    // block will be at exactly this humidity.
                    let first = BlockHumidity::<f32>::new(&super::compensation::calibration(), reading_age_s()).advance(raw, 0.0);
                    if let Some(first) = first {
                        first_requested = true;
                        RETUNE_REQUEST.signal(first.rh_pct);
                    }
                }
            }
            // The sensor is fine, only not faster than the poll: the last value holds, unless
            // no new sample has come for several periods (a sensor that stopped converting).
            Err(HumidityError::NoNewData) => {
                if last_new.elapsed() > Duration::from_millis(NO_NEW_DATA_PERIODS * HUMIDITY_PERIOD_MS) {
                    handoff::set_condition(flags::RH_STALE, true);
                }
            }
            Err(e) => {
                failures += 1;
                handoff::set_condition(flags::RH_STALE, true);
                if failures == 1 {
                    defmt::warn!("humidity reading failed ({}), keeping the last good value", e);
                }
                // No reading at all yet: start with the fallback so sampling is not held up
                // for long by a dead sensor.
                if !first_requested && started.elapsed() >= Duration::from_millis(2 * HUMIDITY_PERIOD_MS) {
                    first_requested = true;
                    RETUNE_REQUEST.signal(RH_FALLBACK_PCT);
                }
            }
        }
        ticker.next().await;
    }
}
