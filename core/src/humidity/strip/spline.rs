//! The excitation's spectrum as a smooth unknown: cubic B-splines on uniform knots in ln f, and
//! the least-squares projection onto them over the bins a fit uses (the Cholesky factor of the
//! normal equations), which the fit profiles out of its cost.

use crate::Real;
use crate::humidity::spectrum::MAX_BINS;

/// Knot spacing of the excitation's spline in ln f: a host resonance of Q ≲ 3 spans more than
/// one knot interval (its half-power width f/Q ≥ 0.33 f), the strip's first mode (Q ≳ 10, width
/// ≤ 0.1 f) less than half of one, so the spline follows the first and not the second.
pub const KNOT_SPACING_LN: f64 = 0.2;
/// Most spline functions.
pub const MAX_BASIS: usize = 24;

/// Cubic B-splines on uniform knots in ln f: the four nonzero functions at a frequency.
#[derive(Clone, Copy)]
pub(super) struct Spline<T> {
    u0: T,
    /// The knot spacing: [`KNOT_SPACING_LN`] or a little less, so that the knots span the band.
    h: T,
    pub(super) count: usize,
}

impl<T: Real> Spline<T> {
    fn new(f_lo: T, f_hi: T) -> Self {
        let span = (f_hi.ln() - f_lo.ln()).to_f64();
        let intervals = libm::ceil(span / KNOT_SPACING_LN).max(1.0) as usize;
        let intervals = intervals.min(MAX_BASIS - 3);
        Spline { u0: f_lo.ln(), h: T::lit(span / intervals as f64), count: intervals + 3 }
    }
    fn at(&self, f: T) -> (usize, [T; 4]) {
        let x = (f.ln() - self.u0) / self.h;
        let i = (x.floor().to_f64().max(0.0) as usize).min(self.count - 4);
        let t = x - T::lit(i as f64);
        let six = T::lit(6.0);
        let s = T::one() - t;
        let (t2, t3) = (t * t, t * t * t);
        (
            i,
            [
                s * s * s / six,
                (T::lit(3.0) * t3 - T::lit(6.0) * t2 + T::lit(4.0)) / six,
                (T::lit(-3.0) * t3 + T::lit(3.0) * t2 + T::lit(3.0) * t + T::one()) / six,
                t3 / six,
            ],
        )
    }
}

/// The least-squares projection onto the excitation's spline over the used bins: the spline's
/// rows at the bins and the Cholesky factor of its normal equations.
pub(super) struct Projection<T> {
    pub(super) n: usize,
    pub(super) used: [bool; MAX_BINS],
    pub(super) spline: Spline<T>,
    rows: [(usize, [T; 4]); MAX_BINS],
    chol: [[T; MAX_BASIS]; MAX_BASIS],
    pub(super) ok: bool,
}

impl<T: Real> Projection<T> {
    /// Over the `n` bins at `f`, all used.
    pub(super) fn new(f: &[T; MAX_BINS], n: usize) -> Self {
        let spline = Spline::new(f[0], f[n.max(1) - 1]);
        let mut rows = [(0, [T::zero(); 4]); MAX_BINS];
        for k in 0..n {
            rows[k] = spline.at(f[k]);
        }
        let mut used = [false; MAX_BINS];
        used[..n].fill(true);
        Projection { n, used, spline, rows, chol: [[T::zero(); MAX_BASIS]; MAX_BASIS], ok: false }
    }

    pub(super) fn used_count(&self) -> usize {
        self.used[..self.n].iter().filter(|&&u| u).count()
    }

    /// Cholesky factor of BᵀWB over the used bins.
    pub(super) fn factor(&mut self) {
        let m = self.spline.count;
        let mut g = [[T::zero(); MAX_BASIS]; MAX_BASIS];
        for k in 0..self.n {
            if !self.used[k] {
                continue;
            }
            let (i, b) = self.rows[k];
            for a in 0..4 {
                for c in 0..4 {
                    g[i + a][i + c] += b[a] * b[c];
                }
            }
        }
        self.ok = true;
        for j in 0..m {
            let mut d = g[j][j];
            for k in 0..j {
                d -= self.chol[j][k] * self.chol[j][k];
            }
            // A spline function with (almost) no used bin under it: the problem is singular.
            if !(d > T::lit(1e-5) * g[j][j]) || !(g[j][j] > T::zero()) {
                self.ok = false;
                return;
            }
            let d = d.sqrt();
            self.chol[j][j] = d;
            for i in j + 1..m {
                let mut v = g[i][j];
                for k in 0..j {
                    v -= self.chol[i][k] * self.chol[j][k];
                }
                self.chol[i][j] = v / d;
            }
        }
    }

    /// (I − P)v over the used bins (zero elsewhere): what the spline cannot explain of v.
    pub(super) fn residual(&self, v: &[T; MAX_BINS]) -> [T; MAX_BINS] {
        let m = self.spline.count;
        let mut rhs = [T::zero(); MAX_BASIS];
        for k in 0..self.n {
            if self.used[k] {
                let (i, b) = self.rows[k];
                for a in 0..4 {
                    rhs[i + a] += b[a] * v[k];
                }
            }
        }
        for i in 0..m {
            let mut s = rhs[i];
            for k in 0..i {
                s -= self.chol[i][k] * rhs[k];
            }
            rhs[i] = s / self.chol[i][i];
        }
        for i in (0..m).rev() {
            let mut s = rhs[i];
            for k in i + 1..m {
                s -= self.chol[k][i] * rhs[k];
            }
            rhs[i] = s / self.chol[i][i];
        }
        let mut r = [T::zero(); MAX_BINS];
        for k in 0..self.n {
            if self.used[k] {
                let (i, b) = self.rows[k];
                let fit = b[0] * rhs[i] + b[1] * rhs[i + 1] + b[2] * rhs[i + 2] + b[3] * rhs[i + 3];
                r[k] = v[k] - fit;
            }
        }
        r
    }
}

pub(super) fn dot<T: Real>(a: &[T; MAX_BINS], b: &[T; MAX_BINS], n: usize) -> T {
    let mut s = T::zero();
    for k in 0..n {
        s += a[k] * b[k];
    }
    s
}
