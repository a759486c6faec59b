//! Humidity: polls the board's sensor about once a second, keeps the last good value on
//! failure, turns the reading into the strip's humidity (the calibration's humidity path: the
//! sensor's correction, then the strip's hydration lag, run between readings), clamps that to
//! the calibrated range and asks for a retune when it moved enough.

use embassy_time::{Duration, Instant, Ticker, with_timeout};
use ipmc_core::humidity_path::Hydration;

use crate::board::Humidity;

use super::{
    config::{HUMIDITY_PERIOD_MS, RH_FALLBACK_PCT},
    flags,
    handoff::{self, LATEST_READ_RH_PCT, LATEST_RH_PCT, RETUNE_REQUEST},
    ports::{HumidityError, HumiditySource},
};

/// A reading that takes longer than this counts as no response.
const READ_TIMEOUT: Duration = Duration::from_millis(HUMIDITY_PERIOD_MS / 2);

/// Polls in a row without a new sample after which the reading counts as stale.
const NO_NEW_DATA_PERIODS: u64 = 3;

/// Makes the strip's humidity the one the blocks report, clamped to the calibration's declared
/// range, and asks for a design at it when it moved away from `design_rh` (the active or already
/// requested design's).
fn publish(strip_pct: f32, design_rh: &mut f32) {
    let (rh, clamped) = super::compensation::calibration().clamp_rh(strip_pct);
    LATEST_RH_PCT.store(rh);
    handoff::set_condition(flags::RH_CLAMPED, clamped);
    if ipmc_core::operating_point::needs_retune(*design_rh, rh) {
        *design_rh = rh;
        RETUNE_REQUEST.signal(rh);
    }
}

#[embassy_executor::task]
pub async fn humidity_task(mut sensor: Humidity) {
    let mut ticker = Ticker::every(Duration::from_millis(HUMIDITY_PERIOD_MS));
    // RH of the design that is active or already requested; NaN until the first request.
    let mut design_rh = f32::NAN;
    let mut failures: u32 = 0;
    let started = Instant::now();
    let mut last_new = Instant::now();
    let path = super::compensation::calibration().humidity;
    let mut strip = Hydration::<f32>::new(&path);
    // The air's humidity at the strip (the last corrected reading) and since when the strip's
    // model has run: it keeps relaxing toward that air while no new reading comes.
    let mut air: Option<(f32, Instant)> = None;
    let mut advance = |air_pct: f32, since: Instant| {
        let now = Instant::now();
        (strip.update(air_pct, (now - since).as_micros() as f32 * 1e-6), now)
    };
    loop {
        let reading = match with_timeout(READ_TIMEOUT, sensor.read_rh_pct()).await {
            Ok(r) => r,
            Err(_) => Err(HumidityError::NoResponse),
        };
        match reading {
            Ok(raw) => {
                last_new = Instant::now();
                let air_pct = path.correct(raw);
                let (strip_pct, now) = advance(air_pct, air.map_or(last_new, |(_, t)| t));
                air = Some((air_pct, now));
                LATEST_READ_RH_PCT.store(raw);
                if failures > 0 {
                    defmt::info!("humidity back after {} failed readings", failures);
                }
                failures = 0;
                handoff::set_condition(flags::RH_STALE, false);
                publish(strip_pct, &mut design_rh);
            }
            // The sensor is fine, only not faster than the poll: the last value holds, unless
            // no new sample has come for several periods (a sensor that stopped converting).
            Err(HumidityError::NoNewData) => {
                if let Some((air_pct, since)) = air {
                    let (strip_pct, now) = advance(air_pct, since);
                    air = Some((air_pct, now));
                    publish(strip_pct, &mut design_rh);
                }
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
