//! ADC code → short-circuit current, and clipping detection, for the TIA front end in
#![allow(dead_code)] // each board uses a subset: codes on hardware, amperes in replay
//! `config`. Boards that deliver amperes directly (replay) still use `is_clipped_amps`, so a
//! saturated recording is flagged the same way a saturated ADC is.

use super::config::{ADC_CLIP_MARGIN_CODES, ADC_FULL_SCALE_CODE, ADC_VREF_V, TIA_BIAS_V, TIA_GAIN_V_PER_A};

const VOLTS_PER_CODE: f32 = ADC_VREF_V / ADC_FULL_SCALE_CODE as f32;

/// ADC code → current for a reference voltage measured at start-up. The TIA's bias is a
/// divider of the same supply, so it stays at mid-scale in codes; only the scale follows VDDA.
#[derive(Clone, Copy)]
pub struct FrontEnd {
    amps_per_code: f32,
}

impl FrontEnd {
    pub const NOMINAL: FrontEnd = FrontEnd::with_vref(ADC_VREF_V);

    pub const fn with_vref(vref_v: f32) -> FrontEnd {
        FrontEnd { amps_per_code: vref_v / ADC_FULL_SCALE_CODE as f32 / TIA_GAIN_V_PER_A }
    }

    /// A block of codes → `amps`, (code − mid-scale) · amperes per code; true if a code lies
    /// within `ADC_CLIP_MARGIN_CODES` of either rail. Per sample: made in ipmc-core for speed
    /// (`ipmc_core::firmware::device_calls`), the one place the conversion is written.
    #[inline(always)]
    pub fn convert(&self, codes: &[u16], amps: &mut [f32]) -> bool {
        ipmc_core::firmware::device_calls::codes_to_amps(
            codes,
            amps,
            MID_SCALE_CODE,
            self.amps_per_code,
            ADC_CLIP_MARGIN_CODES,
            ADC_FULL_SCALE_CODE,
        )
    }
}

const MID_SCALE_CODE: f32 = TIA_BIAS_V / VOLTS_PER_CODE;

/// Largest current the front end can represent without clipping, either sign.
pub const CLIP_LIMIT_AMPS: f32 = (TIA_BIAS_V - ADC_CLIP_MARGIN_CODES as f32 * VOLTS_PER_CODE) / TIA_GAIN_V_PER_A;

#[inline(always)]
pub fn is_clipped_amps(amps: f32) -> bool {
    amps.abs() >= CLIP_LIMIT_AMPS
}
