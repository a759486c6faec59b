//! Kaiser's windowed-sinc method: the length a stop-band depth and a transition need, the window
//! itself, and the windowed ideal filters. All of the band's filters (the band-pass at the low
//! rate, the lower edge's low-pass and the half-bands around both) are designed by it, in f64.

use crate::numeric::real::Real;

/// Kaiser's estimate of the taps a transition `transition_hz` wide needs at `fs_hz` for a
/// stop band `attenuation_db` deep (before rounding to a filter's own form).
pub fn length(attenuation_db: f64, transition_hz: f64, fs_hz: f64) -> usize {
    let dw = 2.0 * core::f64::consts::PI * transition_hz / fs_hz;
    Real::ceil((attenuation_db - 7.95) / (2.285 * dw)) as usize + 1
}

/// The window's shape parameter β for a stop band `attenuation_db` deep (21–50 dB).
pub fn beta(attenuation_db: f64) -> f64 {
    if attenuation_db > 50.0 {
        0.1102 * (attenuation_db - 8.7)
    } else {
        0.5842 * Real::powf(attenuation_db - 21.0, 0.4) + 0.07886 * (attenuation_db - 21.0)
    }
}

/// The window at offset `j` from the centre of a filter `2m + 1` taps long.
pub fn window(beta: f64, j: f64, m: f64) -> f64 {
    let r = j / m;
    bessel_i0(beta * Real::sqrt((1.0 - r * r).max(0.0))) / bessel_i0(beta)
}

/// The ideal band-pass from `w1` to `w2` [cycles a sample] (`w1` = 0: a low-pass), windowed for
/// a stop band `attenuation_db` deep: `half[k]` = h[k] = h[2m − k] for k ≤ m, the centre at m.
pub fn band_pass(half: &mut [f64], m: usize, w1: f64, w2: f64, attenuation_db: f64) {
    let pi = core::f64::consts::PI;
    let beta = beta(attenuation_db);
    for (k, h) in half.iter_mut().enumerate().take(m + 1) {
        let j = k as f64 - m as f64;
        let ideal = if k == m { 2.0 * (w2 - w1) } else { (Real::sin(2.0 * pi * w2 * j) - Real::sin(2.0 * pi * w1 * j)) / (pi * j) };
        *h = ideal * window(beta, j, m as f64);
    }
}

/// A half-band `taps` long (4k + 3), the ideal low-pass at a quarter of the rate windowed for a
/// stop band `attenuation_db` deep. Its even taps beside the centre are zero and its centre ½:
/// `pairs[j]` is its tap at ±(2j + 1) from the centre.
pub fn half_band(pairs: &mut [f64], taps: usize, attenuation_db: f64) {
    let pi = core::f64::consts::PI;
    let beta = beta(attenuation_db);
    let m = (taps - 1) / 2;
    for (j, c) in pairs.iter_mut().enumerate().take(m.div_ceil(2)) {
        let k = (2 * j + 1) as f64;
        *c = Real::sin(pi * k / 2.0) / (pi * k) * window(beta, k, m as f64);
    }
}

/// The modified Bessel function I₀ by its power series (converges for the β ≤ 10 used here).
fn bessel_i0(x: f64) -> f64 {
    let (mut sum, mut term) = (1.0, 1.0);
    let q = x * x / 4.0;
    for k in 1..40 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}
