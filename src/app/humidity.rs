//! Humidity: polls the board's sensor about once a second, keeps the last good value on
//! failure, clamps to the calibrated range and asks for a retune when RH moved enough.

use embassy_time::{Duration, Instant, Ticker, with_timeout};

use crate::board::Humidity;

use super::{
    config::{HUMIDITY_PERIOD_MS, RH_FALLBACK_PCT},
    flags,
    handoff::{self, LATEST_RH_PCT, RETUNE_REQUEST},
    ports::{HumidityError, HumiditySource},
};

/// A reading that takes longer than this counts as no response.
const READ_TIMEOUT: Duration = Duration::from_millis(HUMIDITY_PERIOD_MS / 2);

/// Polls in a row without a new sample after which the reading counts as stale.
const NO_NEW_DATA_PERIODS: u64 = 3;

/// Clamps to the calibration's declared range; the bool says whether it had to.
fn clamp_to_calibration(rh_pct: f32) -> (f32, bool) {
    super::compensation::calibration().clamp_rh(rh_pct)
}

#[embassy_executor::task]
pub async fn humidity_task(mut sensor: Humidity) {
    let mut ticker = Ticker::every(Duration::from_millis(HUMIDITY_PERIOD_MS));
    // RH of the design that is active or already requested; NaN until the first request.
    let mut design_rh = f32::NAN;
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
                let (rh, clamped) = clamp_to_calibration(raw);
                if failures > 0 {
                    defmt::info!("humidity back after {} failed readings", failures);
                }
                failures = 0;
                LATEST_RH_PCT.store(rh);
                handoff::set_condition(flags::RH_STALE, false);
                handoff::set_condition(flags::RH_CLAMPED, clamped);
                if ipmc_core::operating_point::needs_retune(design_rh, rh) {
                    design_rh = rh;
                    RETUNE_REQUEST.signal(rh);
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
                if design_rh.is_nan() && started.elapsed() >= Duration::from_millis(2 * HUMIDITY_PERIOD_MS) {
                    design_rh = RH_FALLBACK_PCT;
                    LATEST_RH_PCT.store(RH_FALLBACK_PCT);
                    RETUNE_REQUEST.signal(RH_FALLBACK_PCT);
                }
            }
        }
        ticker.next().await;
    }
}
