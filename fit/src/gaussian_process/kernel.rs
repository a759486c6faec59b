//! The squared-exponential covariance between two inputs each known up to a variance (the
//! kernel averaged over both input errors: Girard et al., Gaussian processes with uncertain
//! inputs), and one output's covariances with every observation.

use nalgebra::DVector;

/// The covariance between two inputs known up to errors of variance `var_a` and `var_b` (0:
/// known exactly) and `d` apart: the squared-exponential A²·e^(−Δ²/2ℓ²) averaged over both
/// errors, A²·√(ℓ²/(ℓ² + v))·e^(−Δ²/2(ℓ² + v)), v = var_a + var_b.
pub fn kernel(d: f64, amplitude: f64, length: f64, var: f64) -> f64 {
    let l2 = length * length;
    amplitude * amplitude * (l2 / (l2 + var)).sqrt() * (-0.5 * d * d / (l2 + var)).exp()
}

/// Covariances of output k's process at an exact input `x` with observations `obs` (output,
/// input, the input's variance); all zero when output k has no process (`has_process` false).
pub fn cross_covariances(obs: &[(usize, f64, f64)], has_process: bool, k: usize, x: f64, amplitude: f64, length: f64) -> DVector<f64> {
    DVector::from_iterator(
        obs.len(),
        obs.iter().map(|&(kk, r, v)| if kk == k && has_process { kernel(x - r, amplitude, length, v) } else { 0.0 }),
    )
}
