//! A least-squares line through points whose weights fall by a constant factor a point, so that
//! it follows a slow change while the points' scatter averages out: the sums it keeps, and the
//! slope and means read from them. The clock map between two oscillators and the running error's
//! delay loop both fit one.

use crate::numeric::real::Real;

/// The weighted sums of the points: weight, x, y, x², xy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForgettingLine<T> {
    w: T,
    sx: T,
    sy: T,
    sxx: T,
    sxy: T,
}

impl<T: Real> ForgettingLine<T> {
    /// No points yet (`zero` is the scalar's zero: the constructor stays `const`).
    pub const fn empty(zero: T) -> Self {
        Self { w: zero, sx: zero, sy: zero, sxx: zero, sxy: zero }
    }

    /// Adds a point after the earlier ones' weights fell by `forget`.
    pub fn push(&mut self, x: T, y: T, forget: T) {
        let f = forget;
        self.w = f * self.w + T::one();
        self.sx = f * self.sx + x;
        self.sy = f * self.sy + y;
        self.sxx = f * self.sxx + x * x;
        self.sxy = f * self.sxy + x * y;
    }

    /// The points' total weight (one point: 1; it tends to 1 / (1 − forget)).
    pub fn weight(&self) -> T {
        self.w
    }

    /// The slope, where the points span more than one x.
    pub fn slope(&self) -> Option<T> {
        let var = self.sxx * self.w - self.sx * self.sx;
        (var > T::zero()).then(|| (self.sxy * self.w - self.sx * self.sy) / var)
    }

    /// The weighted means of x and y, the point the line passes through (no points: NaN).
    pub fn means(&self) -> (T, T) {
        (self.sx / self.w, self.sy / self.w)
    }
}
