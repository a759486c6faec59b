//! Kaiser's windowed-sinc method: the length a stop-band depth and a transition need, and the
//! window itself. Both of the band's filters (the band-pass at the low rate and the half-bands
//! around it) are designed by it, in f64.

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
