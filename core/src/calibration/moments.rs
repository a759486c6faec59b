//! The strip's response relative to the nominal model, over what its calibration does not know:
//! its first two moments. The robust design shapes the inverse by them and the expected error
//! states what is left; both read the calibration's spread through this one function.

use crate::C;
use crate::calibration::checked::{Checked, PARAMS};
use crate::calibration::laws::Calibration;
use crate::model::exact::{current_response, jw};
use crate::model::params::Params;
use crate::numeric::real::Real;

/// The strip's response at `freq_hz` relative to the nominal H₀ at `rh_pct`, r = H/H₀, over
/// what the calibration does not know: the humidity reading (standard uncertainty `rh_sd_pct`)
/// and each parameter's log-normal scatter (`[uncertainty]`), independent. Returns (E[r],
/// E|r|²) by the three-point Gauss–Hermite rule along each axis (nodes 0, ±√3σ, weights 2/3,
/// 1/6, 1/6): for independent causes the mixed second moments vanish, so summing the axes'
/// departures from the centre is exact to second order, where a first-order propagation has
/// E[r] = 1 and misses the bias that the curvature of H (near a resonance, large) puts in.
pub fn response_moments(calib: &Calibration, rh_pct: f64, rh_sd_pct: f64, freq_hz: f64) -> (C<f64>, f64) {
    let unknown = calib.uncertainty_at(rh_pct);
    let sds = unknown.relative_sds();
    let p: Params<f64> = calib.params_at(rh_pct);
    moments_along(calib, rh_pct, rh_sd_pct, freq_hz, sds.len(), |j, k| {
        let mut z = [0.0; 5];
        z[j] = k;
        (sds[j].1 > 0.0).then(|| unknown.scattered(p, &z))
    })
}

/// [`response_moments`] with what checks left unknown of the strip in place of the
/// calibration's `[uncertainty]` (`checked`, [`crate::calibration::checked`]): each of its causes
/// at `rh_pct` an independent axis along ln of the checked parameters.
pub fn response_moments_checked(calib: &Calibration, checked: &Checked, rh_pct: f64, rh_sd_pct: f64, freq_hz: f64) -> (C<f64>, f64) {
    let (causes, n) = checked.causes_at(calib, rh_pct);
    let p: Params<f64> = calib.params_at(rh_pct);
    moments_along(calib, rh_pct, rh_sd_pct, freq_hz, n, |j, k| {
        let mut q = p;
        for (name, ln) in PARAMS.into_iter().zip(causes[j]) {
            q.set(name, q.get(name) * Real::exp(k * ln));
        }
        Some(q)
    })
}

/// The quadrature of [`response_moments`] over the humidity's axis and `axes` more, axis `j` at
/// `k` of its standard deviations given by `at(j, k)` (None: no spread along it).
fn moments_along(
    calib: &Calibration,
    rh_pct: f64,
    rh_sd_pct: f64,
    freq_hz: f64,
    axes: usize,
    at: impl Fn(usize, f64) -> Option<Params<f64>>,
) -> (C<f64>, f64) {
    let p: Params<f64> = calib.params_at(rh_pct);
    let s = jw(freq_hz);
    let h0 = current_response(&p, s);
    let (mut mean, mut power) = (C::new(1.0, 0.0), 1.0);
    let mut axis = |plus: &Params<f64>, minus: &Params<f64>| {
        let (a, b) = (current_response(plus, s) / h0, current_response(minus, s) / h0);
        // (2/3)·1 + (1/6)(a + b) − 1 = ((a − 1) + (b − 1))/6
        mean += ((a - 1.0) + (b - 1.0)) / 6.0;
        power += ((a.norm_sqr() - 1.0) + (b.norm_sqr() - 1.0)) / 6.0;
    };
    let node = Real::sqrt(3.0);
    if rh_sd_pct > 0.0 {
        let (wet, dry): (Params<f64>, Params<f64>) =
            (calib.params_at(rh_pct + node * rh_sd_pct), calib.params_at(rh_pct - node * rh_sd_pct));
        axis(&wet, &dry);
    }
    for j in 0..axes {
        if let (Some(plus), Some(minus)) = (at(j, node), at(j, -node)) {
            axis(&plus, &minus);
        }
    }
    (mean, power)
}
