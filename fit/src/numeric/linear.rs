//! Weighted linear least squares by SVD of the weighted design, refusing or truncating the
//! directions the rows do not determine.

use nalgebra::{DMatrix, DVector};

/// How [`weighted_least_squares`] treats a design that does not determine every coefficient.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Singular {
    /// No fit: every coefficient must be determined (a law written into a calibration is).
    Refuse,
    /// Directions with a singular value under 1e-10 are left out (minimum-norm solution): a
    /// prediction from the rows at hand is still wanted.
    Truncate,
}

/// Weighted linear least squares: the coefficients c minimizing Σ wᵢ (yᵢ − rowsᵢ·c)², by SVD of
/// the weighted design. `None` with fewer rows than coefficients, or when singular and refused.
pub fn weighted_least_squares(rows: &[Vec<f64>], y: &[f64], w: &[f64], singular: Singular) -> Option<Vec<f64>> {
    let (n, k) = (rows.len(), rows.first()?.len());
    if n < k {
        return None;
    }
    let a = DMatrix::from_fn(n, k, |i, j| rows[i][j] * w[i].sqrt());
    let b = DVector::from_fn(n, |i, _| y[i] * w[i].sqrt());
    let svd = a.svd(true, true);
    let eps = match singular {
        Singular::Refuse => {
            let smax = svd.singular_values.max();
            // (NaN singular values fail the comparison too)
            if !svd.singular_values.iter().all(|&s| s > smax * 1e-12) {
                return None;
            }
            0.0
        }
        Singular::Truncate => 1e-10,
    };
    svd.solve(&b, eps).ok().map(|c| c.iter().copied().collect())
}
