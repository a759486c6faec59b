//! A fitted parameter and how it is kept in its physical range: the optimizer moves an
//! unconstrained coordinate u, the residuals see θ = g(u).

/// How a parameter is kept in its physical range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// Unbounded: u = θ.
    Free,
    /// Positive, usually spanning decades (moduli, damping, diffusivity): u = ln θ, so the
    /// optimizer takes relative steps and can never reach zero.
    Positive,
    /// Inside (lo, hi): θ = lo + (hi − lo)·logistic(u).
    Between(f64, f64),
}

impl Bound {
    pub(super) fn to_u(self, theta: f64) -> f64 {
        match self {
            Bound::Free => theta,
            Bound::Positive => theta.ln(),
            Bound::Between(lo, hi) => {
                let t = ((theta - lo) / (hi - lo)).clamp(1e-12, 1.0 - 1e-12);
                (t / (1.0 - t)).ln()
            }
        }
    }
    pub(super) fn to_theta(self, u: f64) -> f64 {
        match self {
            Bound::Free => u,
            Bound::Positive => u.exp(),
            Bound::Between(lo, hi) => lo + (hi - lo) / (1.0 + (-u).exp()),
        }
    }
    /// dθ/du at u.
    pub(super) fn slope(self, u: f64) -> f64 {
        match self {
            Bound::Free => 1.0,
            Bound::Positive => u.exp(),
            Bound::Between(lo, hi) => {
                let e = (-u.abs()).exp();
                (hi - lo) * e / ((1.0 + e) * (1.0 + e))
            }
        }
    }
    /// Whether θ is strictly inside the range (a start must be).
    pub fn admits(self, theta: f64) -> bool {
        theta.is_finite()
            && match self {
                Bound::Free => true,
                Bound::Positive => theta > 0.0,
                Bound::Between(lo, hi) => lo < theta && theta < hi,
            }
    }
}

/// One fitted parameter.
#[derive(Clone, Debug)]
pub struct Param {
    pub name: String,
    pub bound: Bound,
}

impl Param {
    pub fn new(name: impl Into<String>, bound: Bound) -> Self {
        Param { name: name.into(), bound }
    }
}
