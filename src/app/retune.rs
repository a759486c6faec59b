//! Filter retunes: designs the inverse for a requested RH in thread mode (lowest priority) and
//! hands it to the sample path, which switches at its next block.

use super::{
    compensation, flags,
    handoff::{self, DESIGN_READY, RETUNE_REQUEST},
};

#[embassy_executor::task]
pub async fn retune_task() {
    let calibration = compensation::calibration();
    loop {
        let rh_pct = RETUNE_REQUEST.wait().await;
        match compensation::design(&calibration, rh_pct) {
            Ok(design) => {
                handoff::set_condition(flags::DESIGN_FAILED, false);
                DESIGN_READY.signal(design);
                defmt::debug!("design ready for {} %RH", rh_pct);
            }
            Err(_) => {
                // Keep the active design; the next humidity change asks again.
                handoff::set_condition(flags::DESIGN_FAILED, true);
                defmt::warn!("design failed for {} %RH, keeping the active filter", rh_pct);
            }
        }
    }
}
