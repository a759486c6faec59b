//! Filter retunes: designs the inverse for a requested RH in thread mode (lowest priority) and
//! hands it to the sample path, which switches at its next block.

use ipmc_core::firmware::startup::Designed;

use super::{
    compensation,
    handoff::{self, DESIGN_OUTCOME, DESIGN_READY, RETUNE_REQUEST},
};
use crate::contract::flags;

#[embassy_executor::task]
pub async fn retune_task() {
    let calibration = compensation::calibration();
    loop {
        let request = RETUNE_REQUEST.wait().await;
        match compensation::design(calibration, request.rh_pct) {
            Ok(design) => {
                handoff::set_condition(flags::DESIGN_FAILED, false);
                handoff::set_condition(flags::RH_FALLBACK, request.fallback);
                DESIGN_READY.signal(design);
                DESIGN_OUTCOME.signal(Designed::Ok);
                // What will limit the estimates of this design: the calibration's part of the
                // stated error, and the base motion the current's noise alone amounts to.
                let errors = compensation::error_table();
                defmt::info!(
                    "design ready for {} %RH: calibration part {} %, noise-equivalent base motion {} um rms in band",
                    request.rh_pct,
                    100.0 * errors.calibration_part(request.rh_pct),
                    1e6 * errors.noise_equivalent_m(request.rh_pct)
                );
            }
            Err(_) => {
                // Keep the active design; the next humidity change asks again, and before the
                // first design the start-up does (`ipmc_core::firmware::startup`).
                handoff::set_condition(flags::DESIGN_FAILED, true);
                DESIGN_OUTCOME.signal(Designed::Failed);
                defmt::warn!("design failed for {} %RH, keeping the active filter", request.rh_pct);
            }
        }
    }
}
