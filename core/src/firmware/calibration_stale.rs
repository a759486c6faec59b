//! Whether the measured error exceeds the stated one beyond chance (`CALIBRATION_STALE`): a test
//! at p < 0.01 over the last [`K`] windows of the running error ([`super::running_error`]).
//!
//! A window's stated error σ is the rms its blocks stated (1σ), with the reference's own in
//! quadrature: the accelerometer's sensitivity, ±1 % (1σ) by its datasheet, which nothing on the
//! device measures. A calibration that holds makes each window's squared error m² a variable of
//! mean σ², normal in its parts: z = m²/σ² is a weighted sum of χ²₁ variables whose weights sum to
//! one, however many independent parts it has (the current's noise) and however the windows share
//! them (the calibration's part is the same in every window, the humidity's drifts slowly). The
//! mean of z over K windows is such a sum too, and for any weights summing to one such a sum
//! exceeds x ≥ 1.54 no more often than one χ²₁ variable does (Székely and Bakirov, 2003). So the
//! test is the mean of z over the last K windows against χ²₁'s 0.99 quantile, 6.635: p ≤ 0.01
//! whatever the windows share, which the χ²_K quantile would not be (it assumes windows
//! independent: a calibration's error that is the same in every window, 1.7σ of it, would pass
//! it in 9 % of calibrations that hold).
//!
//! K sets only how long a change must last to be called: [`K`] windows of 5 s, 30 s, half of a
//! check's minute.

use crate::calibration::instrument::ACCELEROMETER_SENSITIVITY_1SIGMA;
use crate::numeric::real::Real;

/// Windows the test takes the mean over.
pub const K: usize = 6;
/// χ²₁'s 0.99 quantile (2.5758² : the normal's two-sided 0.01).
pub const CHI2_1_099: f64 = 6.634_897;

/// The last [`K`] windows' z.
#[derive(Debug, Clone, Copy)]
pub struct StaleTest<T> {
    z: [T; K],
    seen: usize,
}

impl<T: Real> Default for StaleTest<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> StaleTest<T> {
    pub fn new() -> Self {
        Self::empty(T::zero())
    }

    /// No windows yet (`zero` is the scalar's zero: the constructor stays `const`).
    pub const fn empty(zero: T) -> Self {
        StaleTest { z: [zero; K], seen: 0 }
    }

    /// A window's measured and stated error (fractions): whether the mean z over the last
    /// windows, up to [`K`], lies beyond the quantile. A window without a statement is not taken.
    pub fn push(&mut self, measured: T, stated: T) -> bool {
        let g = T::lit(ACCELEROMETER_SENSITIVITY_1SIGMA);
        let variance = stated * stated + g * g;
        if measured.is_finite() && variance.is_finite() {
            self.z[self.seen % K] = measured * measured / variance;
            self.seen += 1;
        }
        let (sum, n) = self.sum();
        n > 0 && sum > T::lit(CHI2_1_099) * T::lit(n as f64)
    }

    /// The sum of z over the last windows, up to [`K`], and their number.
    fn sum(&self) -> (T, usize) {
        let n = self.seen.min(K);
        (self.z[..n].iter().fold(T::zero(), |a, &z| a + z), n)
    }

    /// The test's statistic: the mean z over the last windows, up to [`K`] (None before the
    /// first window with a statement).
    pub fn mean_z(&self) -> Option<T> {
        let (sum, n) = self.sum();
        (n > 0).then(|| sum / T::lit(n as f64))
    }
}

/// Where the bound holds ([`chance_at_most`]): at and above this mean z.
pub const BOUND_FROM_Z: f64 = 1.54;

/// The most often a calibration that holds shows a mean z of at least `mean_z`, whatever its
/// windows share: χ²₁'s upper tail, erfc(√(z/2)), where the bound holds (`mean_z` ≥
/// [`BOUND_FROM_Z`]); None below, where the test can say no more than that it is not rare
/// (more than one in five).
pub fn chance_at_most(mean_z: f64) -> Option<f64> {
    (mean_z >= BOUND_FROM_Z).then(|| libm::erfc(libm::sqrt(0.5 * mean_z)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Windows at the stated error pass, a calibration three times off is called, within a
    /// window where it is, and one window at 2.6σ among holding ones is not.
    #[test]
    fn a_stale_calibration_is_called_and_a_holding_one_is_not() {
        let mut t = StaleTest::<f64>::new();
        for _ in 0..20 {
            assert!(!t.push(0.05, 0.05));
        }
        assert!(!t.push(0.13, 0.05), "one window at 2.6σ among five at 1σ");
        let mut fresh = StaleTest::<f64>::new();
        assert!(fresh.push(0.16, 0.05), "3.1σ in the first window");
        let mut t = StaleTest::<f64>::new();
        for _ in 0..K {
            t.push(0.05, 0.05);
        }
        let called = (1..=K).find(|_| t.push(0.30, 0.05)).expect("called");
        assert!(called <= 2, "called after {called} windows");
        assert!(!StaleTest::<f64>::new().push(f64::NAN, 0.05));
    }

    /// The statistic is the mean over the last windows, and the chance at the test's quantile
    /// is its level: 0.01 at 6.635, 0.05 at 3.841 (χ²₁'s tables), none where no bound holds.
    #[test]
    fn the_chance_is_chi2_1s_tail_of_the_mean() {
        let mut t = StaleTest::<f64>::new();
        assert_eq!(t.mean_z(), None);
        let g = ACCELEROMETER_SENSITIVITY_1SIGMA;
        let stated = 0.05;
        let measured = |z: f64| (z * (stated * stated + g * g)).sqrt();
        t.push(measured(1.0), stated);
        t.push(measured(3.0), stated);
        assert!((t.mean_z().unwrap() - 2.0).abs() < 1e-12);
        for _ in 0..K {
            t.push(measured(4.0), stated);
        }
        assert!((t.mean_z().unwrap() - 4.0).abs() < 1e-12, "the last K windows only");
        assert!((chance_at_most(CHI2_1_099).unwrap() - 0.01).abs() < 1e-6);
        assert!((chance_at_most(3.841_458_820_694_124).unwrap() - 0.05).abs() < 1e-9);
        assert_eq!(chance_at_most(1.0), None);
    }
}
