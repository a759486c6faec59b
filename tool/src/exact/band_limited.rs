//! The exact inverse of the nominal model, band-limited: X(f) = I(f)/H(f) at every bin of the
//! band, nothing outside it, back to time. Non-causal, with no regularization, no approximation
//! and no arithmetic to speak of: what the model itself allows, the reference the causal f32
//! chain is held to (`ipmc vs-exact`).

use crate::brickwall;
use ipmc_core::{C, Calibration, current_response};
use std::f64::consts::PI;

/// Base displacement [m] from the current [A] sampled at `fs_hz`, through the calibration's
/// model at `rh_pct`, in the band `lo_hz`–`hi_hz` (the signal taken as one period: exact for a
/// whole number of periods of a periodic recording).
pub fn inverse(calib: &Calibration, rh_pct: f64, current_a: &[f64], fs_hz: f64, (lo_hz, hi_hz): (f64, f64)) -> Vec<f64> {
    let n = current_a.len();
    let p = calib.params_at(rh_pct);
    let ks = brickwall::bins(n, fs_hz, lo_hz, hi_hz);
    let base: Vec<C<f64>> = brickwall::dft(current_a, ks.clone())
        .into_iter()
        .zip(ks.clone())
        .map(|(i, k)| i / current_response(&p, C::new(0.0, 2.0 * PI * k as f64 * fs_hz / n as f64)))
        .collect();
    brickwall::synthesize(&base, ks, n)
}

/// The inverse that minimizes the expected squared error over what the calibration does not
/// know, per DFT bin: G = E[H*]/E[|H|²] (the bin's error E|H·G − 1|² is least there), the
/// expectation over the humidity reading's error (σ `rh_sd_pct`) and each parameter's scatter
/// about its law (the `[uncertainty]` table, log-normal), by `draws` pseudo-random draws.
/// Non-causal like [`inverse`]: what a robust design could at best reach.
pub fn robust_inverse(
    calib: &Calibration,
    rh_pct: f64,
    rh_sd_pct: f64,
    draws: usize,
    current_a: &[f64],
    fs_hz: f64,
    (lo_hz, hi_hz): (f64, f64),
) -> Vec<f64> {
    let n = current_a.len();
    let ks = brickwall::bins(n, fs_hz, lo_hz, hi_hz);
    let mut rng = ipmc_sim::random::SplitMix64(0x9e37_79b9_7f4a_7c15u64);
    let mut normal = || rng.normal();
    let strips: Vec<ipmc_core::Params<f64>> = (0..draws)
        .map(|_| {
            let p = calib.params_at(rh_pct + rh_sd_pct * normal());
            calib.uncertainty_at(rh_pct).scattered(p, &std::array::from_fn(|_| normal()))
        })
        .collect();
    let base: Vec<C<f64>> = brickwall::dft(current_a, ks.clone())
        .into_iter()
        .zip(ks.clone())
        .map(|(i, k)| {
            let s = C::new(0.0, 2.0 * PI * k as f64 * fs_hz / n as f64);
            let (mut mean, mut power) = (C::new(0.0, 0.0), 0.0);
            for p in &strips {
                let h = current_response(p, s);
                mean += h;
                power += h.norm_sqr();
            }
            i * mean.conj() / power
        })
        .collect();
    brickwall::synthesize(&base, ks, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undoes_the_model_in_the_band() {
        // A current made from two base tones through H: the inverse gives back the in-band tone
        // and nothing of the one outside.
        let calib = Calibration::default_preset();
        let (n, fs, rh) = (2000, 2000.0, 55.0);
        let p = calib.params_at(rh);
        let tone = |f: f64, a: f64, i: usize| {
            let h = current_response(&p, C::new(0.0, 2.0 * PI * f));
            let ph = 2.0 * PI * f * i as f64 / fs;
            (a * ph.sin(), a * (h * C::from_polar(1.0, ph - PI / 2.0)).re)
        };
        let (mut base, mut cur) = (vec![0.0; n], vec![0.0; n]);
        for i in 0..n {
            let (b1, c1) = tone(37.0, 1e-4, i);
            let (_, c2) = tone(400.0, 1e-5, i);
            base[i] = b1;
            cur[i] = c1 + c2;
        }
        let x = inverse(&calib, rh, &cur, fs, (10.0, 150.0));
        let worst = x.iter().zip(&base).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-12, "{worst}");
    }
}
