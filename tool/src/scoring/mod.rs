//! How an estimate is scored against the true base motion: the same samples (after each burst's
//! settling, against the base delayed by the design's delay) for every figure the tool prints.
//!
//! - [`relative_error`]: broadband and in-band (error high-passed at [`INBAND_HP_HZ`]).
//! - [`band_error`]: the error's content in a band of DFT lines (`crate::band`).
//! - [`coverage`]: whether the stated error bars hold, window by window.

pub mod coverage;

use ipmc_core::{Cascade, Sos};

/// Filter settling skipped at the start of each burst when scoring [s].
pub const SETTLE_S: f64 = 5.0;

/// Corner of the high-pass applied to the error before the in-band figure [Hz]: half the
/// design band's lower edge (10 Hz), so only the band the inverse is designed for is scored.
pub const INBAND_HP_HZ: f64 = 5.0;

/// Zero-phase high-pass of `x` in place: a 2nd-order Butterworth section (bilinear, the core's
/// filter) run forward and backward, 4th order with no phase shift.
fn highpass_zero_phase(x: &mut [f64], fc_hz: f64, fs_hz: f64) {
    let w0 = 2.0 * std::f64::consts::PI * fc_hz / fs_hz;
    let alpha = w0.sin() / (2.0 * std::f64::consts::FRAC_1_SQRT_2);
    let (a0, c) = (1.0 + alpha, w0.cos());
    let section = Sos::from_ba([(1.0 + c) / 2.0 / a0, -(1.0 + c) / a0, (1.0 + c) / 2.0 / a0], [1.0, -2.0 * c / a0, (1.0 - alpha) / a0]);
    Cascade::from_sections(&[section], 1.0).process_block(x);
    x.reverse();
    Cascade::from_sections(&[section], 1.0).process_block(x);
    x.reverse();
}

/// Error of an estimate against the true base: (broadband, in-band), each
/// rms(estimate − delayed true base) / rms(delayed true base). The estimate at sample n is
/// compared with base[n − delay[n]]; the first [`SETTLE_S`] of each burst is skipped. The
/// in-band figure high-passes the error at [`INBAND_HP_HZ`] first (per burst, zero-phase).
pub fn relative_error<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
) -> Option<(f64, f64)> {
    let (mut se, mut sh, mut sb) = (0.0f64, 0.0f64, 0.0f64);
    for (mut err, truth) in scored_bursts(est, delay, burst_start, base, fs_hz) {
        se += err.iter().map(|e| e * e).sum::<f64>();
        sb += truth.iter().map(|t| t * t).sum::<f64>();
        highpass_zero_phase(&mut err, INBAND_HP_HZ, fs_hz);
        sh += err.iter().map(|e| e * e).sum::<f64>();
    }
    (sb > 0.0).then(|| ((se / sb).sqrt(), (sh / sb).sqrt()))
}

/// Error of an estimate in a band: the error's content in `band` over the true base's content
/// in `reference` (each `(lo_hz, hi_hz)`; `band::energy`, per burst, on the same samples as
/// [`relative_error`]), as a ratio of rms values. With both the design band: the error in the
/// band the inverse is asked to get right, and nothing else, the figure the exact band-limited
/// inverse is held to as well (`ipmc vs-exact`); with another `band`, what the estimate adds
/// there, on the scale of the signal in the design band.
pub fn band_error<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
    band: (f64, f64),
    reference: (f64, f64),
) -> Option<f64> {
    let (mut se, mut sb) = (0.0f64, 0.0f64);
    for (err, truth) in scored_bursts(est, delay, burst_start, base, fs_hz) {
        if err.len() > 2 {
            se += crate::band::energy(&err, fs_hz, band.0, band.1);
            sb += crate::band::energy(&truth, fs_hz, reference.0, reference.1);
        }
    }
    (sb > 0.0).then(|| (se / sb).sqrt())
}

/// Per burst, the samples scored: (estimate − delayed true base, delayed true base), after the
/// first [`SETTLE_S`] of the burst.
fn scored_bursts<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let settle = (SETTLE_S * fs_hz).round() as usize;
    let n = est.len().min(base.len()).min(delay.len()).min(burst_start.len());
    let mut out = vec![];
    let mut i = 0;
    while i < n {
        let b0 = burst_start[i];
        let mut j = i;
        while j < n && burst_start[j] == b0 {
            j += 1;
        }
        let (mut err, mut truth) = (vec![], vec![]);
        for k in i..j {
            if k < b0 + settle || k < b0 + delay[k] {
                continue;
            }
            let t = base[k - delay[k]];
            err.push(est[k].into() - t);
            truth.push(t);
        }
        out.push((err, truth));
        i = j;
    }
    out
}
