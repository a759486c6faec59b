//! Humidity: polls the board's sensor about once a second and keeps the last good reading
//! for the sample path, which turns it into the strip's humidity block by block
//! (`ipmc_core::humidity::block`) and asks for retunes. Before sampling starts this task is the
//! start-up path: it asks for the first design, at the first reading or at a fallback, retries a
//! failed one and feeds the watchdog while the start-up makes progress (`ipmc_core::firmware::startup`,
//! host-tested, decides all three).

use embassy_time::{Duration, Instant, Ticker, with_timeout};
use ipmc_core::{
    firmware::startup::{Poll, Startup},
    timing::STALE_AFTER_PERIODS,
};

use crate::board::{self, Humidity};

use super::handoff::{self, DESIGN_OUTCOME, LATEST_READ_RH_PCT, RETUNE_REQUEST};
use crate::contract::{
    config::{HUMIDITY_PERIOD_MS, RH_FALLBACK_PCT},
    flags,
    sources::{HumidityError, HumiditySource},
};

/// A reading that takes longer than this counts as no response.
const READ_TIMEOUT: Duration = Duration::from_millis(HUMIDITY_PERIOD_MS / 2);

#[embassy_executor::task]
pub async fn humidity_task(mut sensor: Humidity) {
    let mut ticker = Ticker::every(Duration::from_millis(HUMIDITY_PERIOD_MS));
    // Later designs come from the sample path.
    let mut startup = Startup::new(super::compensation::calibration(), RH_FALLBACK_PCT);
    let mut failures: u32 = 0;
    let mut last_new = Instant::now();
    loop {
        let reading = match with_timeout(READ_TIMEOUT, sensor.read_rh_pct()).await {
            Ok(r) => r,
            Err(_) => Err(HumidityError::NoResponse),
        };
        let poll = match reading {
            Ok(raw) => {
                last_new = Instant::now();
                LATEST_READ_RH_PCT.store(raw);
                handoff::reading_taken_at(last_new);
                if failures > 0 {
                    defmt::info!("humidity back after {} failed readings", failures);
                }
                failures = 0;
                handoff::set_condition(flags::RH_STALE, false);
                // The strip starts settled at the first reading: the sample path's first block
                // will be at exactly this humidity.
                match super::compensation::first_design_rh(raw) {
                    Some(rh_pct) => Poll::Reading(rh_pct),
                    None => Poll::Failed,
                }
            }
            // The sensor is fine, only not faster than the poll: the last value holds, unless
            // no new sample has come for several periods (a sensor that stopped converting).
            Err(HumidityError::NoNewData) => {
                if last_new.elapsed() > Duration::from_millis(STALE_AFTER_PERIODS * HUMIDITY_PERIOD_MS) {
                    handoff::set_condition(flags::RH_STALE, true);
                }
                Poll::NothingNew
            }
            Err(e) => {
                failures += 1;
                handoff::set_condition(flags::RH_STALE, true);
                if failures == 1 {
                    defmt::warn!("humidity reading failed ({}), keeping the last good value", e);
                }
                Poll::Failed
            }
        };
        if !startup.is_done() {
            let now_ms = Instant::now().as_millis();
            if let Some(request) = startup.poll(now_ms, poll, DESIGN_OUTCOME.try_take()) {
                if request.fallback {
                    defmt::warn!("no humidity reading: design at the fallback {} %RH", request.rh_pct);
                }
                RETUNE_REQUEST.signal(request);
            }
            if startup.feeds_watchdog(now_ms) {
                board::feed_startup_watchdog();
            }
        }
        ticker.next().await;
    }
}
