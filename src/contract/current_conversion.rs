//! ADC code → short-circuit current, and clipping detection, for the TIA front end in
#![allow(dead_code)] // each board uses a subset: codes on hardware, amperes in replay
//! `config`. Boards that deliver amperes directly (replay) still use `is_clipped_amps`, so a
//! saturated recording is flagged the same way a saturated ADC is.

use super::config::{ADC_CLIP_MARGIN_CODES, ADC_FULL_SCALE_CODE, ADC_VREF_V, TIA_BIAS_V, TIA_GAIN_V_PER_A};

const VOLTS_PER_CODE: f32 = ADC_VREF_V / ADC_FULL_SCALE_CODE as f32;

/// Current in amperes for one ADC code with the nominal reference (`config::ADC_VREF_V`).
#[inline(always)]
pub fn code_to_amps(code: u16) -> f32 {
    FrontEnd::NOMINAL.amps(code)
}

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

    #[inline(always)]
    pub fn amps(&self, code: u16) -> f32 {
        (code as f32 - MID_SCALE_CODE) * self.amps_per_code
    }

    /// A block of codes → `amps`, as [`Self::amps`] each; true if one of them is clipped
    /// ([`is_clipped_code`]). Per sample: made in ipmc-core for speed (`ipmc_core::firmware::device_calls`).
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

#[inline(always)]
pub fn is_clipped_code(code: u16) -> bool {
    code <= ADC_CLIP_MARGIN_CODES || code >= ADC_FULL_SCALE_CODE - ADC_CLIP_MARGIN_CODES
}

/// Largest current the front end can represent without clipping, either sign.
pub const CLIP_LIMIT_AMPS: f32 = (TIA_BIAS_V - ADC_CLIP_MARGIN_CODES as f32 * VOLTS_PER_CODE) / TIA_GAIN_V_PER_A;

#[inline(always)]
pub fn is_clipped_amps(amps: f32) -> bool {
    amps.abs() >= CLIP_LIMIT_AMPS
}
