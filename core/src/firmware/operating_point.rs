//! The firmware's operating point at its clock ([`crate::timing`]): the design it runs, when it
//! retunes, its preview delay and the settling a score skips. The firmware, its QEMU replay, the
//! host's replica of the chain and the host tests all take these from here, so none of them can
//! drift from the device.

use crate::band::{Band, check};
use crate::inverse::design::DesignConfig;
use crate::numeric::real::Real;
use crate::timing::SAMPLE_RATE_HZ;

impl<T: Real> DesignConfig<T> {
    /// The design the firmware runs: the default design at the firmware's sample rate.
    pub fn firmware() -> Self {
        DesignConfig::at_rate(T::lit(SAMPLE_RATE_HZ as f64))
    }
}

/// A retune is due when the humidity moved by more than this [% RH] from the RH of the active
/// (or already requested) design: about a tenth of the compensation error a 1 % RH mismatch
/// causes (≈ 3 %, `ipmc accuracy`), at ~1 retune per second during a fast 0.25 %/s drift.
pub const RETUNE_THRESHOLD_PCT: f32 = 0.25;

/// Whether a reading at `rh_pct` calls for a new design, given the RH of the last one (NaN:
/// none yet).
pub fn needs_retune(design_rh_pct: f32, rh_pct: f32) -> bool {
    design_rh_pct.is_nan() || (rh_pct - design_rh_pct).abs() > RETUNE_THRESHOLD_PCT
}

/// Whether the sample path asks for a design now: the humidity moved (`needs_retune`) and no
/// retune is under way. A design asked for during one would wait for it to end, up to a whole
/// retune later than the moment `block_humidity::design_lead_s` reads the humidity ahead for.
pub fn asks_for_design(design_rh_pct: f32, rh_pct: f32, retuning: bool) -> bool {
    !retuning && needs_retune(design_rh_pct, rh_pct)
}

/// Settling skipped at the start of each burst when an estimate is scored [s]. The regularizing
/// high-pass's start-up rings at ~1 Hz, decaying as e^(−1.94 t) (its Butterworth poles' least
/// damped pair), from an amplitude of the 1/ω² double integration's, thousands of times the
/// signal; the band's FIR takes 40 dB off its ~1 Hz content, but the tail of its spectrum
/// reaches into the band and measured 3–15 % of a clean sweep for 4 s. By 5 s it is 6·10⁻⁵
/// of its start. The band's filter spreads it over its own 2.2 s, centred on its delay (1.11 s),
/// where the estimate is aligned: from 5 s the chain's start-up, as measured against the same
/// input run 20 s before, is 1·10⁻⁵ of the estimate's rms at 40 %RH (3·10⁻⁵ in the half second
/// before), and the external recordings score the same skipping 7 s.
pub const SETTLE_S: f64 = 5.0;

/// Samples the firmware's estimate lags the true base motion by, keeping `band`: its design's
/// preview (`max_delay_s`) and the band's linear-phase FIR ([`crate::band`]) at the firmware's
/// rate (a band the firmware cannot keep is refused when its calibration loads).
pub fn delay_samples(band: &Band) -> usize {
    let c = DesignConfig::<f64>::firmware();
    let fir = check(band, c.fs_hz).map_or(0, |p| p.delay_samples());
    preview_samples() + fir
}

/// The firmware's designs' preview (`max_delay_s`) [samples at its rate]: the estimate leads
/// the base motion by it before the band's filter (the running error reads its reference so).
pub fn preview_samples() -> usize {
    let c = DesignConfig::<f64>::firmware();
    (c.max_delay_s * c.fs_hz).round() as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_preview_is_whole_samples() {
        let c = DesignConfig::<f64>::firmware();
        let band = Band::DEFAULT;
        let fir = crate::band::BandDesign::design(&band, c.fs_hz).unwrap().delay_samples();
        assert_eq!((super::delay_samples(&band) - fir) as f64, c.max_delay_s * c.fs_hz);
        assert_eq!(super::delay_samples(&band), 4 + fir, "the preview is 2 ms, 4 samples");
    }
}
