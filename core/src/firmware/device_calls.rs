//! The device's calls with a budget of speed, for f32, made here: the conversion of the ADC's
//! codes, the compensator, a block's error bar, the stuck input's check and the hygrometer's
//! running spectrum (per sample), the running error against the board's accelerometer, a
//! retune's design, and the band's and the cascade's filters
//! alone for the bench. Built for size (the `ipmc-hygrometer-fit` crate, where the hygrometer's fit is
//! made), the design took 511 750 instructions (budget 500 000) and the spectrum 33.0 a sample
//! (budget 30).
//!
//! Why they are functions of their own: a generic function is compiled in the crate that names
//! its type, at that crate's opt-level, and these are not generic, so they are compiled here, in
//! ipmc-core, at its opt-level (2). The firmware crate is built for size; called from it directly,
//! `Compensator::<f32>::process_block` would be made there, at "s" (689 instructions a sample
//! instead of 373 when the program was linked at "s" too). `#[inline(never)]` keeps fat LTO from folding them back into
//! a caller built for size. `examples/bench.rs` times these same functions.

use crate::{
    Calibration, Cascade, Compensator, DesignConfig, DesignError, Inverse,
    band::{BandLimit, BandTaps, LinesMut},
    design_inverse,
    firmware::running_error::{Measure, Window},
    firmware::stuck::StuckDetector,
    humidity::hygrometer::{BlockHygrometer, Snapshot},
    humidity::spectrum::RunningSpectrum,
    inverse::expected_error::BlockError,
};

/// ADC codes → amperes, `(code − mid_code) · amps_per_code`; true if a code lies within `margin`
/// codes of either rail (0 and `full_scale`).
#[inline(never)]
pub fn codes_to_amps(codes: &[u16], amps: &mut [f32], mid_code: f32, amps_per_code: f32, margin: u16, full_scale: u16) -> bool {
    let mut clipped = false;
    for (a, &code) in amps.iter_mut().zip(codes) {
        clipped |= code <= margin || code >= full_scale - margin;
        *a = (code as f32 - mid_code) * amps_per_code;
    }
    clipped
}

/// [`Compensator::process_block`].
#[inline(never)]
pub fn process_block(c: &mut Compensator<f32>, block: &mut [f32]) {
    c.process_block(block)
}

/// [`Compensator::process_screened_block`]: the sample path's, after the block step's screen.
#[inline(never)]
pub fn process_screened_block(c: &mut Compensator<f32>, block: &mut [f32]) {
    c.process_screened_block(block)
}

/// [`Compensator::switch_to`].
#[inline(never)]
pub fn switch_to(c: &mut Compensator<f32>, design: &Inverse<f32>) {
    c.switch_to(design)
}

/// [`BlockError::block`].
#[inline(never)]
pub fn block_error(e: &mut BlockError<'_, f32>, design_rh_pct: f32, estimates: &[f32]) -> f32 {
    e.block(design_rh_pct, estimates)
}

/// [`design_inverse`] with the firmware's configuration ([`DesignConfig::firmware`]): a
/// constant here, so that what it does not use (the robust kind's moments, in f64, 16 KiB) is
/// not linked.
#[inline(never)]
pub fn design(calib: &Calibration, rh_pct: f32) -> Result<Inverse<f32>, DesignError> {
    design_inverse(calib, rh_pct, &DesignConfig::firmware())
}

/// [`BlockHygrometer::push`].
#[inline(never)]
pub fn push_current(h: &mut BlockHygrometer<f32>, current: &[f32], path_pct: Option<f32>) -> Option<Snapshot<f32>> {
    h.push(current, path_pct)
}

/// [`RunningSpectrum::push`], which [`push_current`] runs.
#[inline(never)]
pub fn push_spectrum(s: &mut RunningSpectrum<f32>, samples: &[f32]) -> usize {
    s.push(samples)
}

/// [`StuckDetector::observe`].
#[inline(never)]
pub fn observe_stuck(s: &mut StuckDetector<f32>, block: &[f32]) -> bool {
    s.observe(block)
}

/// [`BandLimit::process_block`], the band's part of [`process_block`].
#[inline(never)]
pub fn band_block(b: &mut BandLimit<f32>, block: &mut [f32]) {
    b.process_block(block)
}

/// [`LinesMut::process_block`]: the reference's band filter in [`running_error_block`].
#[inline(never)]
pub fn band_lines_block(b: LinesMut<'_, f32>, taps: &BandTaps<f32>, block: &mut [f32]) {
    b.process_block(taps, block)
}

/// [`Cascade::process_block`], the sections' part of [`process_block`].
#[inline(never)]
pub fn cascade_block(c: &mut Cascade<f32>, block: &mut [f32]) {
    c.process_block(block)
}

/// [`Measure::estimate`] then, where the accelerometer's block `accel` came (none before
/// [`LAG_BLOCKS`] blocks, nor on a board without the part), [`Measure::reference_through`] with
/// the lines `lines` (a `RunningError`'s parts, of whatever sizes): a block's estimate and its
/// stated error, and the accelerometer's block for the estimate's [`LAG_BLOCKS`] before; `taps`
/// the estimate's band filter's coefficients.
///
/// [`LAG_BLOCKS`]: crate::resample::track::LAG_BLOCKS
#[inline(never)]
pub fn running_error_block(
    m: &mut Measure<f32>,
    lines: LinesMut<'_, f32>,
    taps: &BandTaps<f32>,
    estimate: &[f32],
    stated: f32,
    accel: Option<&[f32]>,
    out: &mut [f32],
) -> Option<Window<f32>> {
    m.estimate(estimate, stated);
    m.reference_through(lines, taps, accel?, out, band_lines_block)
}
