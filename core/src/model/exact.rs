//! The paper's exact model (eqs. 1–6): tip response W(L,s)/U(s) and current H(s) = I(s)/U(s).
//!
//! Both mechanical ratios depend on s only through q = (pL)⁴ = L⁴·s(Ca + m·s)/(4I(Y + Cs·s)):
//! with z = pL, N1(L)/D1 = 2 cos z cosh z / (cosh²z + cos²z) and N3/D1 = (2/L)·S(q) where
//! S(q) = z(cos z sinh z − cosh z sin z)/(cosh²z + cos²z). Both are even under z → iz, so they are
//! functions of q alone, which is what makes the structured rational approximation possible
//! ([`crate::inverse::rational`]). Evaluation is overflow-free: small |z| uses the power series in q,
//! large |z| uses exponentials scaled by e^-(|Re z| + |Im z|).

use crate::numeric::real::cis;
use crate::{C, ComplexMath, Params, Real};

/// q = (pL)⁴ at complex frequency s.
pub fn q_of<T: Real>(p: &Params<T>, s: C<T>) -> C<T> {
    let four_i = T::lit(4.0) * p.inertia();
    let l2 = p.l * p.l;
    let num = s * (s * p.m + p.ca) * (l2 * l2);
    let den = (s * p.cs + p.y) * four_i;
    num / den
}

/// Below this |z| the series in q is both exact to rounding and free of cancellation.
const SERIES_LIMIT: f64 = 1.0;
/// Terms of each series: the 7th term at |z| = 1 is below 1e-17 relative.
const SERIES_TERMS: usize = 8;

/// Chooses the fourth root z of q with Re z ≥ 0 and Im z ≥ 0; every mechanical ratio is
/// invariant under z → iz, so any root serves and this one keeps the scaled forms simple.
fn quarter_root<T: Real>(q: C<T>) -> C<T> {
    let z = q.csqrt().csqrt();
    // principal: |Im z| ≤ Re z; rotate by i when Im z < 0.
    if z.im < T::zero() { C::new(-z.im, z.re) } else { z }
}

struct Scaled<T> {
    /// cosh z · e^-x, sinh z · e^-x, cos z · e^-y, sin z · e^-y (z = x + iy, x, y ≥ 0)
    ch: C<T>,
    sh: C<T>,
    c: C<T>,
    sn: C<T>,
    /// e^-(x+y): the scale shared by every product of one hyperbolic and one circular function.
    e_xy: T,
    /// cosh²z + cos²z, scaled by e^-2(x+y)
    d1: C<T>,
}

fn scaled<T: Real>(z: C<T>) -> Scaled<T> {
    let (x, y) = (z.re, z.im);
    let two = T::lit(2.0);
    let e_iy = cis(y);
    let e_ix = cis(x);
    let e2x = (-two * x).exp();
    let e2y = (-two * y).exp();
    let ch = (e_iy + e_iy.conj() * e2x) / two;
    let sh = (e_iy - e_iy.conj() * e2x) / two;
    let c = (e_ix * e2y + e_ix.conj()) / two;
    let sn = (e_ix * e2y - e_ix.conj()) / C::new(T::zero(), two);
    let d1 = ch * ch * e2y + c * c * e2x;
    Scaled { ch, sh, c, sn, e_xy: (-(x + y)).exp(), d1 }
}

/// Power series in q of cos z cosh z, Φ(q) = (cos z sinh z − cosh z sin z)/z³ and D1.
fn series<T: Real>(q: C<T>) -> (C<T>, C<T>, C<T>) {
    let mut cc = C::new(T::zero(), T::zero()); // Σ (−4)^j q^j/(4j)!
    let mut phi = C::new(T::zero(), T::zero()); // Σ_{j≥1} (−4)^j q^(j−1)/(4j−1)!
    let mut d1 = C::new(T::one(), T::zero()); // 1 + Σ (16q)^j/(4j)!
    let mut qj = C::new(T::one(), T::zero());
    let mut fact = 1.0f64; // (4j)!
    let mut m4 = 1.0f64; // (−4)^j
    let mut p16 = 1.0f64; // 16^j
    for j in 0..SERIES_TERMS {
        if j > 0 {
            let k = 4.0 * j as f64;
            // (4j−1)! = (4j)!/(4j) once (4j)! is known
            fact *= (k - 3.0) * (k - 2.0) * (k - 1.0) * k;
            m4 *= -4.0;
            p16 *= 16.0;
            phi += qj * T::lit(m4 / (fact / k));
            qj *= q;
        }
        cc += qj * T::lit(m4 / fact);
        d1 += qj * T::lit(p16 / fact);
    }
    (cc, phi, d1)
}

/// The mechanical functions of one q, in whichever form is exact there; both ratios are read
/// from it, so a caller that needs both pays for the fourth root and the exponentials once.
enum Mechanics<T> {
    /// |z| < 1: the series in q.
    Series { q: C<T>, cc: C<T>, phi: C<T>, d1: C<T> },
    /// Otherwise: the scaled hyperbolic and circular functions of z.
    Scaled { z: C<T>, s: Scaled<T> },
}

impl<T: Real> Mechanics<T> {
    fn of(q: C<T>) -> Self {
        if q.cabs() < T::lit(SERIES_LIMIT) {
            let (cc, phi, d1) = series(q);
            Mechanics::Series { q, cc, phi, d1 }
        } else {
            let z = quarter_root(q);
            Mechanics::Scaled { z, s: scaled(z) }
        }
    }
    /// 2 cos z cosh z / D1
    fn tip(&self) -> C<T> {
        match self {
            Mechanics::Series { cc, d1, .. } => *cc * T::lit(2.0) / *d1,
            Mechanics::Scaled { s, .. } => s.c * s.ch * (T::lit(2.0) * s.e_xy) / s.d1,
        }
    }
    /// z(cos z sinh z − cosh z sin z)/D1
    fn slope(&self) -> C<T> {
        match self {
            Mechanics::Series { q, phi, d1, .. } => *q * *phi / *d1,
            Mechanics::Scaled { z, s } => *z * (s.c * s.sh - s.ch * s.sn) * s.e_xy / s.d1,
        }
    }
}

/// [`tip_of_q`] and [`slope_of_q`] together: the mechanics evaluated once.
pub(crate) fn tip_and_slope_of_q<T: Real>(q: C<T>) -> (C<T>, C<T>) {
    let m = Mechanics::of(q);
    (m.tip(), m.slope())
}

/// Tip response W(L,s)/U(s) as a function of q: 2 cos z cosh z / D1.
pub fn tip_of_q<T: Real>(q: C<T>) -> C<T> {
    Mechanics::of(q).tip()
}

/// S(q) = z(cos z sinh z − cosh z sin z)/D1, so that N3/D1 = (2/L)·S(q).
pub fn slope_of_q<T: Real>(q: C<T>) -> C<T> {
    Mechanics::of(q).slope()
}

/// The ionic factor (βh coth βh − 1)/β², β² = (s + K)/d, of eq. 5.
pub fn ionic_factor<T: Real>(p: &Params<T>, s: C<T>) -> C<T> {
    let beta2 = (s + p.k_ionic()) / p.d;
    let x = beta2.csqrt() * p.h; // principal root: Re x ≥ 0
    let x2 = x * x;
    let h2 = p.h * p.h;
    if x.cabs() < T::lit(0.5) {
        // x coth x − 1 = x²/3 − x⁴/45 + 2x⁶/945 − x⁸/4725 + 2x¹⁰/93555 − 1382x¹²/638512875 + …
        const K: [f64; 6] = [1.0 / 3.0, -1.0 / 45.0, 2.0 / 945.0, -1.0 / 4725.0, 2.0 / 93555.0, -1382.0 / 638_512_875.0];
        let mut acc = C::new(T::zero(), T::zero());
        for &k in K.iter().rev() {
            acc = acc * x2 + T::lit(k);
        }
        acc * h2
    } else {
        let e = (-x * T::lit(2.0)).cexp(); // |e| ≤ 1 since Re x ≥ 0
        let one = C::new(T::one(), T::zero());
        let coth = (one + e) / (one - e);
        (x * coth - one) / x2 * h2
    }
}

/// W(L,s)/U(s) of eq. 2 [m/m].
pub fn tip_response<T: Real>(p: &Params<T>, s: C<T>) -> C<T> {
    tip_of_q(q_of(p, s))
}

/// H(s) = I(s)/U(s) of eq. 5 [A/m].
pub fn current_response<T: Real>(p: &Params<T>, s: C<T>) -> C<T> {
    current_of_slope(p, s, slope_of_q(q_of(p, s)))
}

/// Tip response and current together at one s: the mechanics (most of the cost of either) is
/// evaluated once. What a fit to both channels needs.
pub fn responses<T: Real>(p: &Params<T>, s: C<T>) -> (C<T>, C<T>) {
    responses_with(p, s, ionic_drive(p, s))
}

/// [`responses`] with the current's electrical part at s given ([`ionic_drive`]).
pub fn responses_with<T: Real>(p: &Params<T>, s: C<T>, drive: C<T>) -> (C<T>, C<T>) {
    let m = Mechanics::of(q_of(p, s));
    (m.tip(), current_of_slope_with(p, drive, m.slope()))
}

/// s times the ionic factor: the current's electrical part at s, which depends on the strip
/// only through its ionic rate K, diffusivity d and half thickness h. A caller that moves
/// none of them can keep it.
pub fn ionic_drive<T: Real>(p: &Params<T>, s: C<T>) -> C<T> {
    s * ionic_factor(p, s)
}

/// Eq. 5 from S(q) (= L/2 times the curvature integrated over the length, which is what
/// [`crate::model::extension`] passes for a beam whose root also turns).
pub(crate) fn current_of_slope<T: Real>(p: &Params<T>, s: C<T>, slope: C<T>) -> C<T> {
    current_of_slope_with(p, ionic_drive(p, s), slope)
}

/// [`current_of_slope`] with the electrical part given ([`ionic_drive`]).
pub(crate) fn current_of_slope_with<T: Real>(p: &Params<T>, drive: C<T>, slope: C<T>) -> C<T> {
    let mech = slope * (T::lit(2.0) / p.l);
    drive * mech * (p.b * p.y / p.alpha0)
}

/// Evaluates at s = j·2πf.
pub fn jw<T: Real>(freq_hz: T) -> C<T> {
    C::new(T::zero(), T::lit(2.0) * T::PI() * freq_hz)
}

/// The first bending mode's undamped angular frequency [rad/s], λ₁²·√(YI/(mL⁴)) with λ₁ =
/// 1.8751 the clamped-free beam's first root.
pub fn first_mode_rad_s<T: Real>(p: &Params<T>) -> T {
    let lambda1 = T::lit(1.875_104_068_711_961);
    lambda1 * lambda1 * (p.inertia() * p.y / p.m).sqrt() / (p.l * p.l)
}

/// Capacitance between the electrodes [F]: a plate capacitor of the effective dielectric
/// constant, C = κe·b·L/(2h) (h is the half thickness).
pub fn capacitance<T: Real>(p: &Params<T>) -> T {
    p.kappa_e * p.b * p.l / (T::lit(2.0) * p.h)
}

/// κe from a measured capacitance: the inverse of [`capacitance`], κe = C·2h/(b·L).
pub fn kappa_e_of_capacitance<T: Real>(p: &Params<T>, capacitance_f: T) -> T {
    capacitance_f * T::lit(2.0) * p.h / (p.b * p.l)
}

/// Current [A] at `t_s` ≥ 0 after a constant voltage is applied at t = 0, in the simplest
/// picture consistent with the model: the strip's bulk ionic resistance R = 2h/(σ·b·L), with
/// the ionic conductivity σ = F²·d·C⁻/(R_gas·T), in series with [`capacitance`] C. The current
/// (U/R)·e^(−t/RC) decays with RC = κe/σ = 1/K, the dielectric relaxation time whose rate K the
/// ionic factor of eq. 5 carries; its integral is the stored charge C·U.
pub fn step_charging_current<T: Real>(p: &Params<T>, voltage_v: T, t_s: T) -> T {
    let rate = p.k_ionic();
    voltage_v * capacitance(p) * rate * (-(rate * t_s)).exp()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Calibration;

    /// The tip's resonance, damped a little (Q ≈ 11–14), sits within 1 % of the undamped mode.
    #[test]
    fn the_tip_resonates_at_the_first_mode() {
        for rh in [45.0, 60.0, 75.0] {
            let p: Params<f64> = Calibration::default_preset().params_at(rh);
            let f1 = first_mode_rad_s(&p) / (2.0 * core::f64::consts::PI);
            let (f_peak, _) = peak(rh);
            assert!((f_peak / f1 - 1.0).abs() < 0.01, "{rh} %RH: peak {f_peak:.2} Hz, first mode {f1:.2} Hz");
        }
    }

    fn peak(rh: f64) -> (f64, f64) {
        let p: Params<f64> = Calibration::default_preset().params_at(rh);
        let mut best = (0.0, 0.0);
        let mut f = 20.0;
        while f < 60.0 {
            let g = tip_response(&p, jw(f)).cabs();
            if g > best.1 {
                best = (f, g);
            }
            f += 0.01;
        }
        best
    }

    #[test]
    fn sanity_values_of_the_physics_notes() {
        let (f45, g45) = peak(45.0);
        let (f68, _) = peak(68.0);
        assert!((f45 - 35.2).abs() < 0.15, "first resonance at 45 %: {f45}");
        assert!((f68 - 32.2).abs() < 0.15, "first resonance at 68 %: {f68}");
        assert!((g45 - 20.0).abs() < 1.5, "peak tip gain {g45}");
    }

    #[test]
    fn series_and_scaled_forms_agree_where_they_meet() {
        for k in 0..16 {
            let a = k as f64 * core::f64::consts::PI / 8.0;
            let q = C::new(a.cos(), a.sin()) * 1.0;
            let (cc, phi, d1) = series(q);
            let z = quarter_root(q);
            let s = scaled(z);
            let tip_s = cc * 2.0 / d1;
            let tip_e = s.c * s.ch * (2.0 * s.e_xy) / s.d1;
            let sl_s = q * phi / d1;
            let sl_e = z * (s.c * s.sh - s.ch * s.sn) * s.e_xy / s.d1;
            assert!((tip_s - tip_e).cabs() < 1e-14 * tip_s.cabs());
            assert!((sl_s - sl_e).cabs() < 1e-13 * sl_s.cabs(), "{q}: {sl_s} {sl_e}");
        }
    }

    #[test]
    fn responses_are_tip_and_current_bit_for_bit() {
        for rh in [20.0, 50.0, 90.0] {
            let p: Params<f64> = Calibration::default_preset().params_at(rh);
            for f in [0.5, 10.0, 35.0, 220.0, 3000.0] {
                assert_eq!(responses(&p, jw(f)), (tip_response(&p, jw(f)), current_response(&p, jw(f))), "{f} Hz");
            }
        }
    }

    #[test]
    fn no_overflow_far_outside_the_band() {
        // f32 holds to |z| ≈ 40 (≈ 30 kHz), where e^-2x and e^-2y both underflow; the spec is 5 kHz.
        let p: Params<f32> = Calibration::default_preset().params_at(50.0f32);
        for f in [1e-3f32, 0.1, 5e3, 2e4] {
            let h = current_response(&p, jw(f));
            let t = tip_response(&p, jw(f));
            assert!(h.re.is_finite() && h.im.is_finite() && t.re.is_finite() && t.im.is_finite(), "{f}");
        }
    }

    #[test]
    fn step_charge_stores_c_times_u_and_gives_kappa_e_back() {
        for rh in [20.0, 50.0, 90.0] {
            let p: Params<f64> = Calibration::default_preset().params_at(rh);
            let (c, u, tau) = (capacitance(&p), 0.1, 1.0 / p.k_ionic());
            assert!((kappa_e_of_capacitance(&p, c) / p.kappa_e - 1.0).abs() < 1e-14);
            // Trapezoid over 30 time constants: the charge that went in is C·U.
            let n = 300_000;
            let dt = 30.0 * tau / n as f64;
            let q: f64 = (0..n)
                .map(|k| 0.5 * dt * (step_charging_current(&p, u, k as f64 * dt) + step_charging_current(&p, u, (k + 1) as f64 * dt)))
                .sum();
            assert!((q / (c * u) - 1.0).abs() < 1e-6, "RH {rh}: {q} vs {}", c * u);
            // Half the excess current is gone after τ·ln 2.
            let half = step_charging_current(&p, u, tau * 2f64.ln()) / step_charging_current(&p, u, 0.0);
            assert!((half - 0.5).abs() < 1e-12);
        }
    }
}
