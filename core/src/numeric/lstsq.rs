//! Small dense least squares by Householder QR, on the stack.
//!
//! QR rather than normal equations: the design's basis (delayed copies over a narrow band) is
//! nearly collinear, and normal equations would square its condition number, which f32 cannot
//! afford.

use crate::Real;

/// Solves min ‖A·x − b‖₂ for the first `rows` rows of `a` and `b` (rows ≥ K). Returns `None` if a
/// column is numerically zero. `a` and `b` are overwritten.
pub fn lstsq<T: Real, const R: usize, const K: usize>(a: &mut [[T; K]; R], b: &mut [T; R], rows: usize) -> Option<[T; K]> {
    let rows = rows.min(R);
    if rows < K {
        return None;
    }
    for k in 0..K {
        let mut norm = T::zero();
        for row in a.iter().take(rows).skip(k) {
            norm += row[k] * row[k];
        }
        let norm = norm.sqrt();
        if !(norm > T::zero()) || !norm.is_finite() {
            return None;
        }
        let alpha = if a[k][k] > T::zero() { -norm } else { norm };
        // v = x − α·e₁, stored in place of column k
        a[k][k] -= alpha;
        let mut vnorm2 = T::zero();
        for row in a.iter().take(rows).skip(k) {
            vnorm2 += row[k] * row[k];
        }
        if vnorm2 > T::zero() {
            for j in (k + 1)..K {
                let mut dot = T::zero();
                for row in a.iter().take(rows).skip(k) {
                    dot += row[k] * row[j];
                }
                let f = T::lit(2.0) * dot / vnorm2;
                for row in a.iter_mut().take(rows).skip(k) {
                    let vk = row[k];
                    row[j] -= f * vk;
                }
            }
            let mut dot = T::zero();
            for i in k..rows {
                dot += a[i][k] * b[i];
            }
            let f = T::lit(2.0) * dot / vnorm2;
            for i in k..rows {
                b[i] -= f * a[i][k];
            }
        }
        a[k][k] = alpha; // R's diagonal
    }
    let mut x = [T::zero(); K];
    for k in (0..K).rev() {
        let mut s = b[k];
        for j in (k + 1)..K {
            s -= a[k][j] * x[j];
        }
        x[k] = s / a[k][k];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_a_line() {
        let mut a = [[0.0f64; 2]; 5];
        let mut b = [0.0f64; 5];
        for i in 0..5 {
            a[i] = [1.0, i as f64];
            b[i] = 2.0 + 3.0 * i as f64 + if i % 2 == 0 { 0.1 } else { -0.1 };
        }
        let x = lstsq(&mut a, &mut b, 5).unwrap();
        assert!((x[0] - 2.02).abs() < 1e-9 && (x[1] - 3.0).abs() < 1e-9, "{x:?}");
    }
}
