//! A record's amplitude and phase at one frequency (a rotating phasor, any frequency, any
//! window), and the median a spectrum's floor is read from.

use ipmc_core::C;
use std::f64::consts::PI;

/// Amplitude and phase of `x` at `f_hz`: 2/Σw · Σ w·x·e^{−jωn/fs}, by a rotating phasor.
pub(super) fn project(x: &[f64], w: Option<&[f64]>, f_hz: f64, fs_hz: f64) -> C<f64> {
    let step = C::from_polar(1.0, -2.0 * PI * f_hz / fs_hz);
    let mut z = C::new(1.0, 0.0);
    let mut acc = C::new(0.0, 0.0);
    let mut wsum = 0.0;
    for (n, &v) in x.iter().enumerate() {
        let wn = w.map_or(1.0, |w| w[n]);
        acc += z * (v * wn);
        wsum += wn;
        z *= step;
        if n % 1024 == 1023 {
            // Keeps |z| = 1 against rounding over long records.
            z /= z.norm();
        }
    }
    acc * (2.0 / wsum)
}

pub(super) fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
