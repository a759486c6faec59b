//! Root finding without a heap: closed-form quadratics and Aberth–Ehrlich iteration.

use crate::{C, ComplexMath, Real};

/// Roots of a·s² + b·s + c (complex coefficients, a ≠ 0), in the cancellation-free form.
pub fn quadratic<T: Real>(a: C<T>, b: C<T>, c: C<T>) -> [C<T>; 2] {
    let disc = (b * b - a * c * T::lit(4.0)).csqrt();
    // pick the sign that adds magnitudes in b ± √disc
    let sum_plus = b + disc;
    let sum_minus = b - disc;
    let big = if sum_plus.norm_sqr() >= sum_minus.norm_sqr() { sum_plus } else { sum_minus };
    if big.norm_sqr() == T::zero() {
        let z = C::new(T::zero(), T::zero());
        return [z, z];
    }
    let r1 = -big / (a * T::lit(2.0));
    let r2 = -(c * T::lit(2.0)) / big;
    [r1, r2]
}

/// Refines all roots at once (Aberth–Ehrlich). `ratio(s)` must return f(s)/f'(s) for the
/// function whose simple roots are sought. Starting points close to the answer make it converge
/// in a few iterations; it returns whether every correction fell below `rel_tol` relative.
pub fn aberth<T: Real>(roots: &mut [C<T>], ratio: impl Fn(C<T>) -> C<T>, max_iter: usize, rel_tol: T) -> bool {
    let n = roots.len();
    for _ in 0..max_iter {
        let mut converged = true;
        for i in 0..n {
            let si = roots[i];
            let w = ratio(si);
            if !(w.re.is_finite() && w.im.is_finite()) {
                continue;
            }
            let mut sum = C::new(T::zero(), T::zero());
            for (j, &sj) in roots.iter().enumerate() {
                if j != i {
                    let d = si - sj;
                    if d.norm_sqr() > T::zero() {
                        sum += d.inv();
                    }
                }
            }
            let one = C::new(T::one(), T::zero());
            let step = w / (one - w * sum);
            if !(step.re.is_finite() && step.im.is_finite()) {
                continue;
            }
            roots[i] = si - step;
            // |step| > tol·|root|, squared: no square roots in the inner loop.
            if step.norm_sqr() > rel_tol * rel_tol * roots[i].norm_sqr() {
                converged = false;
            }
        }
        if converged {
            return true;
        }
    }
    false
}

/// p(s)/p'(s) for a real polynomial with coefficients in ascending powers.
pub fn poly_ratio<T: Real>(coeffs: &[T], s: C<T>) -> C<T> {
    let mut p = C::new(T::zero(), T::zero());
    let mut dp = C::new(T::zero(), T::zero());
    for &c in coeffs.iter().rev() {
        dp = dp * s + p;
        p = p * s + c;
    }
    p / dp
}

/// Roots of a real polynomial (ascending coefficients, nonzero leading term) of small degree,
/// from starting points on a circle of the roots' mean magnitude.
pub fn poly_roots<T: Real>(coeffs: &[T], out: &mut [C<T>]) -> bool {
    let deg = coeffs.len() - 1;
    debug_assert_eq!(out.len(), deg);
    let lead = coeffs[deg];
    let radius = (coeffs[0] / lead).abs().powf(T::one() / T::lit(deg as f64)).max(T::lit(1e-3));
    for (k, r) in out.iter_mut().enumerate() {
        // an angle offset that avoids symmetric starts on the real axis
        let a = T::lit(2.0) * T::PI() * T::lit(k as f64 + 0.25) / T::lit(deg as f64) + T::lit(0.4);
        *r = C::new(a.cos(), a.sin()) * radius;
    }
    // Clustered roots of an ill-conditioned polynomial stall short of a 16ε step while already
    // as accurate as the coefficients allow; accept any finite result and let callers judge it
    // by what they need (the design checks the stability and response of the sections it builds).
    let _ = aberth(out, |s| poly_ratio(coeffs, s), 200, T::epsilon() * T::lit(16.0));
    symmetrize(out, T::epsilon().sqrt());
    out.iter().all(|r| r.re.is_finite() && r.im.is_finite())
}

/// Makes a root set of a real polynomial exactly closed under conjugation: near-real roots
/// become real, the rest are replaced by the mean of each root and its nearest conjugate.
pub fn symmetrize<T: Real>(roots: &mut [C<T>], rel_tol: T) {
    let n = roots.len();
    for i in 0..n {
        let r = roots[i];
        if r.im.abs() <= rel_tol * r.cabs() {
            roots[i] = C::new(r.re, T::zero());
        }
    }
    for i in 0..n {
        let r = roots[i];
        if r.im <= T::zero() {
            continue;
        }
        // nearest root to conj(r) among those with negative imaginary part
        let mut best = None;
        let mut best_d = T::infinity();
        for (j, &q) in roots.iter().enumerate() {
            if q.im < T::zero() {
                let d = (q - r.conj()).cabs();
                if d < best_d {
                    best_d = d;
                    best = Some(j);
                }
            }
        }
        if let Some(j) = best {
            let m = (r + roots[j].conj()) * T::lit(0.5);
            roots[i] = m;
            roots[j] = m.conj();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quartic_roots() {
        // (s−1)(s+2)(s²+2s+5)
        let c = [-10.0f64, 1.0, 5.0, 3.0, 1.0];
        let mut r = [C::new(0.0, 0.0); 4];
        assert!(poly_roots(&c, &mut r));
        let mut want = [C::new(1.0, 0.0), C::new(-2.0, 0.0), C::new(-1.0, 2.0), C::new(-1.0, -2.0)];
        for w in want.iter_mut() {
            assert!(r.iter().any(|x| (x - *w).cabs() < 1e-10), "{w} not in {r:?}");
        }
    }

    #[test]
    fn quadratic_is_accurate_for_widely_separated_roots() {
        let [a, b] = quadratic(C::new(1.0f64, 0.0), C::new(1e8, 0.0), C::new(1.0, 0.0));
        let small = if a.cabs() < b.cabs() { a } else { b };
        assert!((small.re + 1e-8).abs() < 1e-20);
    }
}
