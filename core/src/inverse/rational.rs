//! Physics-structured rational approximation of H(s) at one humidity.
//!
//! Why this method and not vector fitting: the retune runs on the MCU in bounded time without a
//! heap. Vector fitting at order 12 needs a few least-squares solves of a ~200×25 system per
//! iteration, millions of flops; and fitting noise-free but infinite-order data it has no
//! guarantee of stability for parameters it was not run on. Here the structure of the model does
//! the work (see [`crate::inverse::rational_tables`] for the derivation): the mechanical poles are the roots of
//! one quadratic per mode (closed form, stable by construction), the half-order ionic element is a
//! fixed minimax table shifted by K, and only the eight zeros of the mechanical factor need an
//! iterative search, started next to the answer. Denominator order: 8 (four modes) + 5 (ionic) = 13
//! by default, or 12 with the four-pair ionic table at a measured accuracy cost.
//!
//! H_r(s) = k · Π(s − zᵢ) / Π(s − pⱼ), real coefficients (roots closed under conjugation).

use crate::inverse::rational_tables::{HALF_ORDER_4, HALF_ORDER_5, HalfOrder, IONIC_OMEGA0, MODE_Q, MODE_R, TAIL_C1, ZERO_RHO};
use crate::model::exact::q_of;
use crate::numeric::roots::{aberth, quadratic, symmetrize};
use crate::{C, ComplexMath, Params, Real};

/// Capacity of a root list: 16 zeros and 13 poles are the most the model produces.
pub const MAX_ROOTS: usize = 20;

/// A fixed-capacity list of complex roots.
#[derive(Clone, Copy, Debug)]
pub struct Roots<T> {
    pub r: [C<T>; MAX_ROOTS],
    pub n: usize,
}

impl<T: Real> Roots<T> {
    pub fn new() -> Self {
        Roots { r: [C::new(T::zero(), T::zero()); MAX_ROOTS], n: 0 }
    }
    pub fn push(&mut self, z: C<T>) {
        // Capacity is a compile-time property of the structure above; overflow is a bug.
        self.r[self.n] = z;
        self.n += 1;
    }
    pub fn as_slice(&self) -> &[C<T>] {
        &self.r[..self.n]
    }
}

impl<T: Real> Default for Roots<T> {
    fn default() -> Self {
        Self::new()
    }
}

/// Which half-order table approximates the ionic element.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum IonicOrder {
    /// 5 pole–zero pairs: total denominator order 13.
    #[default]
    Five,
    /// 4 pole–zero pairs: total denominator order 12.
    Four,
}

impl IonicOrder {
    fn table(self) -> HalfOrder {
        match self {
            IonicOrder::Five => HALF_ORDER_5,
            IonicOrder::Four => HALF_ORDER_4,
        }
    }
}

/// H_r(s) = k·Π(s − zeros)/Π(s − poles).
#[derive(Clone, Copy, Debug)]
pub struct RationalModel<T> {
    pub k: T,
    pub zeros: Roots<T>,
    pub poles: Roots<T>,
}

/// The mechanical approximation S_r(s) and its derivative, evaluated without expanding
/// polynomials (the root search needs both; expanded degree-10 polynomials lose f32).
struct Mechanical<T> {
    a2: T, // L⁴m
    a1: T, // L⁴Ca
    b1: T, // 4I·Cs
    b0: T, // 4I·Y
    c0: T,
}

impl<T: Real> Mechanical<T> {
    fn new(p: &Params<T>) -> Self {
        let l4 = p.l * p.l * p.l * p.l;
        let four_i = T::lit(4.0) * p.inertia();
        let c0 = MODE_R.iter().zip(MODE_Q).fold(T::zero(), |acc, (r, q)| acc + T::lit(r / q));
        Mechanical { a2: l4 * p.m, a1: l4 * p.ca, b1: four_i * p.cs, b0: four_i * p.y, c0 }
    }
    /// (S_r(s), S_r'(s))
    fn eval(&self, s: C<T>) -> (C<T>, C<T>) {
        let a = s * (s * self.a2 + self.a1);
        let da = s * (self.a2 * T::lit(2.0)) + self.a1;
        let b = s * self.b1 + self.b0;
        let db = self.b1;
        let mut f = C::new(self.c0, T::zero()) + a * (T::lit(TAIL_C1) / self.b0);
        let mut sum_sq = C::new(T::zero(), T::zero());
        for (r, q) in MODE_R.iter().zip(MODE_Q) {
            let den = a - b * T::lit(q);
            let inv = den.inv();
            f += b * inv * T::lit(*r);
            sum_sq += inv * inv * T::lit(*r);
        }
        let df = (a * db - b * da) * sum_sq + da * (T::lit(TAIL_C1) / self.b0);
        (f, df)
    }
    /// Roots of A − ρB = a2·s² + (a1 − ρ·b1)·s − ρ·b0.
    fn quad_roots(&self, rho: C<T>) -> [C<T>; 2] {
        quadratic(C::new(self.a2, T::zero()), C::new(self.a1, T::zero()) - rho * self.b1, -rho * self.b0)
    }
}

impl<T: Real> RationalModel<T> {
    /// The approximation at the given parameters. Returns `None` if a parameter is not positive
    /// and finite or the zero search does not converge.
    pub fn new(p: &Params<T>, ionic: IonicOrder) -> Option<Self> {
        for v in [p.y, p.cs, p.ca, p.kappa_e, p.d, p.h, p.m, p.l, p.b, p.alpha0, p.c_minus, p.t_k] {
            if !(v.is_finite() && v > T::zero()) {
                return None;
            }
        }
        let mech = Mechanical::new(p);
        let mut zeros = Roots::new();
        let mut poles = Roots::new();

        // Mode poles: A − qₙB = 0 (all coefficients positive: stable).
        for q in MODE_Q {
            for r in mech.quad_roots(C::new(T::lit(q), T::zero())) {
                poles.push(r);
            }
        }

        // Mechanical zeros: A = 0 exactly (s = 0, s = −Ca/m), then eight found by Aberth from the
        // images of the universal zeros.
        let zero = C::new(T::zero(), T::zero());
        let s_ca = C::new(-p.ca / p.m, T::zero());
        let mut found = [zero; 8];
        for (i, (re, im)) in ZERO_RHO.iter().enumerate() {
            let [r1, r2] = mech.quad_roots(C::new(T::lit(*re), T::lit(*im)));
            found[2 * i] = r1;
            found[2 * i + 1] = r2;
        }
        let mode_poles = poles;
        let ratio = |s: C<T>| {
            let (f, df) = mech.eval(s);
            // Ñ'/Ñ = S'/S + Σ 1/(s − pⱼ) − 1/s − 1/(s + Ca/m)
            let mut ld = df / f - s.inv() - (s - s_ca).inv();
            for &pj in mode_poles.as_slice() {
                ld += (s - pj).inv();
            }
            ld.inv()
        };
        // In f32 at extreme parameters the last correction can stall just above 64ε while the
        // zeros are as accurate as f32 allows; non-finite results are rejected below.
        let _ = aberth(&mut found, ratio, 60, T::epsilon() * T::lit(64.0));
        symmetrize(&mut found, T::epsilon().sqrt() * T::lit(4.0));
        zeros.push(zero); // the explicit s of eq. 5
        zeros.push(zero);
        zeros.push(s_ca);
        for z in found {
            if !(z.re.is_finite() && z.im.is_finite()) {
                return None;
            }
            zeros.push(z);
        }

        // Ionic element (s + K)^(-1/2) ≈ g·ω₀^(-1/2)·Π(s + K + zₖω₀)/(s + K + pₖω₀).
        let table = ionic.table();
        let k_ion = p.k_ionic();
        let w0 = T::lit(IONIC_OMEGA0);
        for (&pk, &zk) in table.poles.iter().zip(table.zeros) {
            poles.push(C::new(-k_ion - T::lit(pk) * w0, T::zero()));
            zeros.push(C::new(-k_ion - T::lit(zk) * w0, T::zero()));
        }

        // Gain: (bY/α0)(2/L)·h√d·g·ω₀^(-1/2) · c₁·L⁴m/(4IY) (leading coefficient of S_r's numerator
        // over that of its denominator).
        let k = p.b * p.y / p.alpha0 * (T::lit(2.0) / p.l) * p.h * p.d.sqrt() * T::lit(table.gain) / w0.sqrt()
            * (T::lit(TAIL_C1) * mech.a2 / mech.b0);
        if !k.is_finite() {
            return None;
        }
        Some(RationalModel { k, zeros, poles })
    }

    pub fn eval(&self, s: C<T>) -> C<T> {
        let mut v = C::new(self.k, T::zero());
        // interleave to keep intermediate magnitudes moderate
        let (nz, np) = (self.zeros.n, self.poles.n);
        for i in 0..nz.max(np) {
            if i < nz {
                v *= s - self.zeros.r[i];
            }
            if i < np {
                v /= s - self.poles.r[i];
            }
        }
        v
    }

    /// Denominator order.
    pub fn order(&self) -> usize {
        self.poles.n
    }

    /// Whether every pole is strictly in the left half-plane.
    pub fn is_stable(&self) -> bool {
        self.poles.as_slice().iter().all(|p| p.re < T::zero())
    }

    /// The mechanical q at s for these parameters (re-exported for callers that plot it).
    pub fn q(p: &Params<T>, s: C<T>) -> C<T> {
        q_of(p, s)
    }
}

/// Worst relative magnitude error and phase error [degrees] of `model` against the exact H over a
/// log-spaced grid of `n` frequencies in [f_lo, f_hi].
pub fn approximation_error<T: Real>(p: &Params<T>, model: &RationalModel<T>, f_lo: T, f_hi: T, n: usize) -> (T, T) {
    let mut worst_mag = T::zero();
    let mut worst_ph = T::zero();
    for i in 0..n {
        let f = f_lo * (f_hi / f_lo).powf(T::lit(i as f64 / (n - 1) as f64));
        let s = crate::model::exact::jw(f);
        let r = model.eval(s) / crate::model::exact::current_response(p, s);
        worst_mag = worst_mag.max((r.cabs() - T::one()).abs());
        worst_ph = worst_ph.max(r.carg().abs().to_degrees());
    }
    (worst_mag, worst_ph)
}
