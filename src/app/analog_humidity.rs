//! HIH-4030 front end (feature `humidity-hih4030`): ADC code at A1 → RH, with the supply,
//! divider and temperature of `config`. The sensor's own transfer function and temperature
//! compensation are `ipmc_core::humidity::hih4030_rh_pct` (host-tested).
#![cfg_attr(not(feature = "humidity-hih4030"), allow(dead_code))] // hardware board with this feature only

use ipmc_core::humidity::hih4030_rh_pct;

use super::{
    config::{ADC_FULL_SCALE_CODE, ADC_VREF_V, HIH4030_DIVIDER, HIH4030_SUPPLY_V, HIH4030_TEMPERATURE_C},
    ports::HumidityError,
};

/// RH [%] for one 12-bit conversion of A1; a reading that is no humidity (open or shorted
/// wire) is `Implausible`, so the humidity task keeps the last good value.
pub fn rh_pct_from_code(code: u16) -> Result<f32, HumidityError> {
    let v_out = code as f32 * (ADC_VREF_V / ADC_FULL_SCALE_CODE as f32) / HIH4030_DIVIDER;
    hih4030_rh_pct(v_out / HIH4030_SUPPLY_V, HIH4030_TEMPERATURE_C).map_err(|_| HumidityError::Implausible)
}
