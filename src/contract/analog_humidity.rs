//! HIH-4030 front end (feature `humidity-hih4030`): ADC code at A1 → RH, with the ADC reference
//! measured at start-up (VREFINT), the supply from the calibration's `[humidity]` table
//! (`supply_v`), the divider and temperature of `config`. The sensor's own transfer function and
//! temperature compensation are `ipmc_sensors::hih4030::rh_pct_at_pin` (host-tested).
#![cfg_attr(not(feature = "humidity-hih4030"), allow(dead_code))] // hardware board with this feature only

use ipmc_sensors::hih4030;

use super::{
    config::{ADC_FULL_SCALE_CODE, HIH4030_DIVIDER, HIH4030_TEMPERATURE_C},
    sources::HumidityError,
};

/// RH [%] for one 12-bit conversion of A1 with the ADC's reference at `vdda_v`; a reading that
/// is no humidity (open or shorted wire) is `Implausible`, so the humidity task keeps the last
/// good value.
pub fn rh_pct_from_code(code: u16, vdda_v: f32) -> Result<f32, HumidityError> {
    let v_pin = code as f32 * (vdda_v / ADC_FULL_SCALE_CODE as f32);
    let supply_v = super::calibration::CALIBRATION.humidity.supply_v() as f32;
    hih4030::rh_pct_at_pin(v_pin, HIH4030_DIVIDER, supply_v, HIH4030_TEMPERATURE_C).map_err(|_| HumidityError::Implausible)
}
