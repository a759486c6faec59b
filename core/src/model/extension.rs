//! The model extended with physics the paper leaves out: what `ipmc diagnose` tests as candidate
//! missing physics, and what `ipmc prove` conceals in synthetic recordings.
//!
//! Three kinds of terms, each zero by default (then the responses equal [`crate::model::exact`]'s):
//!
//! * **Distributed terms of eq. 1.** The beam equation E*(s)·I·w'''' + μ(s)·s·w = 0 keeps its
//!   form; only its two coefficients grow: the mass/damping impedance per length
//!   μ(s) = (m + m_air)·s + Ca + c_st·√s (air moving with the beam and Stokes-type boundary-layer
//!   damping, which grows like √ω) and the complex modulus
//!   E*(s) = Y + Cs·s + Σ ΔYₖ·sτₖ/(1 + sτₖ) + iηY (relaxation branches of a generalized standard
//!   linear solid and a constant loss factor, alternatives to the paper's pure Kelvin–Voigt
//!   law), or with Cs·s replaced by the power law Cs·ω_r·(s/ω_r)^α (fractional damping). Since the
//!   mechanical ratios depend on s only through q = (pL)⁴ = L⁴·s·μ/(4I·E*), the closed forms of
//!   [`crate::model::exact`] still apply with this q.
//! * **End conditions.** A clamp with finite rotational stiffness (compliance c_θ: root slope per
//!   root moment) and a tip body (point mass M_t, rotary inertia J_t) change the boundary
//!   conditions, for which no closed form is kept: the general solution
//!   w = a₁cos λz + a₂sin λz + a₃cosh λz + a₄sinh λz is fitted to the four boundary conditions by
//!   a 4×4 complex solve ([`beam_solve`]), checked against the closed form when the terms vanish.
//!   The current follows the charge, which is proportional to the curvature integrated over the
//!   electrodes, ∫w''dz = w'(L) − w'(0): the root slope of a compliant clamp takes its share.
//! * **Measurement chain of each channel.** Factors on one channel's transfer function: the
//!   current amplifier's poles, the electrodes' surface resistance (lumped first order, or the
//!   distributed RC line tanh√(sτ)/√(sτ), whose low-frequency limit is the lumped pole with τ/3),
//!   each channel's timing relative to the base channel (e^(−sΔt)) and capacitive feedthrough of
//!   the drive into the current channel (+g·s).

use crate::model::exact::{self, current_of_slope_with, tip_and_slope_of_q};
use crate::{C, ComplexMath, Params, Real};

/// Physics beyond eqs. 1–6. SI units; every field zero means "absent".
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Extension<T> {
    /// Air mass moving with the beam, per length [kg/m].
    pub added_mass: T,
    /// Stokes-type damping: force per length c_st·√s·(velocity) [N·s^½/m²].
    pub stokes: T,
    /// Moduli ΔY [Pa] of up to two relaxation branches (a generalized standard linear solid) ...
    pub relax_modulus: [T; 2],
    /// ... and their relaxation times τ [s].
    pub relax_time: [T; 2],
    /// Constant (hysteretic) loss factor η: E* gains iηY at positive frequencies.
    pub loss_factor: T,
    /// 1 − α for a power-law (fractional, "springpot") damping that replaces Kelvin–Voigt's:
    /// Cs·s becomes Cs·ω_r·(s/ω_r)^α, the same at ω_r ([`Self::damping_ref`]), growing as ω^α
    /// instead of ω (0 < α ≤ 1; α = 0 is a constant loss).
    pub damping_order_drop: T,
    /// ω_r [rad/s], where the power-law damping equals the Kelvin–Voigt damping it replaces.
    pub damping_ref: T,
    /// Rotational compliance of the clamp c_θ [rad/(N·m)].
    pub clamp_compliance: T,
    /// Point mass at the tip M_t [kg].
    pub tip_mass: T,
    /// Rotary inertia of the tip body about the tip J_t [kg·m²].
    pub tip_inertia: T,
    /// Time constants of the current amplifier's real poles [s] (0 = no pole).
    pub amp_tau: [T; 2],
    /// Electrode surface resistance as one lumped pole, τ = R·C [s].
    pub electrode_tau_lumped: T,
    /// Electrode surface resistance as a distributed RC line, τ = r·c·L² [s].
    pub electrode_tau_distributed: T,
    /// Delay of the tip channel relative to the base channel [s].
    pub skew_tip: T,
    /// Delay of the current channel relative to the base channel [s].
    pub skew_current: T,
    /// Capacitive feedthrough of the drive into the current channel [A·s/m].
    pub feedthrough: T,
}

impl<T: Real> Extension<T> {
    /// The terms of the strip itself: the extension without the channels' measurement chains
    /// and the feedthrough (what [`strip_responses`] depends on).
    pub fn strip_terms(&self) -> Self {
        let zero = T::zero();
        Extension {
            amp_tau: [zero; 2],
            electrode_tau_lumped: zero,
            electrode_tau_distributed: zero,
            skew_tip: zero,
            skew_current: zero,
            feedthrough: zero,
            ..*self
        }
    }
    fn has_end_terms(&self) -> bool {
        self.clamp_compliance != T::zero() || self.tip_mass != T::zero() || self.tip_inertia != T::zero()
    }
    fn has_distributed_terms(&self) -> bool {
        self.added_mass != T::zero()
            || self.stokes != T::zero()
            || self.relax_modulus.iter().any(|m| *m != T::zero())
            || self.loss_factor != T::zero()
            || self.damping_order_drop != T::zero()
    }

    /// Mass/damping impedance per length μ(s) of the extended eq. 1.
    pub fn impedance(&self, p: &Params<T>, s: C<T>) -> C<T> {
        s * (p.m + self.added_mass) + p.ca + s.csqrt() * self.stokes
    }

    /// Complex modulus E*(s) of the extended eq. 1.
    pub fn modulus(&self, p: &Params<T>, s: C<T>) -> C<T> {
        let mut e = self.damping(p, s) + p.y;
        for (&dy, &tau) in self.relax_modulus.iter().zip(&self.relax_time) {
            if dy != T::zero() {
                let st = s * tau;
                e += st / (st + T::one()) * dy;
            }
        }
        if self.loss_factor != T::zero() {
            // iηY for ω > 0 (and its conjugate below, so the time response stays real).
            let sign = if s.im < T::zero() { -T::one() } else { T::one() };
            e += C::new(T::zero(), sign * self.loss_factor * p.y);
        }
        e
    }

    /// The damping part of E*: Kelvin–Voigt's Cs·s, or its power law Cs·ω_r·(s/ω_r)^α.
    fn damping(&self, p: &Params<T>, s: C<T>) -> C<T> {
        if self.damping_order_drop == T::zero() {
            return s * p.cs;
        }
        let alpha = T::one() - self.damping_order_drop;
        let w_r = self.damping_ref;
        let (sin, cos) = (alpha * s.im.atan2(s.re)).sin_cos();
        let magnitude = (s.cabs() / w_r).powf(alpha) * w_r * p.cs;
        C::new(magnitude * cos, magnitude * sin)
    }

    /// Factor of the current channel's measurement chain.
    pub fn current_chain(&self, s: C<T>) -> C<T> {
        let one = C::new(T::one(), T::zero());
        let mut g = one;
        for &tau in &self.amp_tau {
            if tau != T::zero() {
                g /= s * tau + one;
            }
        }
        if self.electrode_tau_lumped != T::zero() {
            g /= s * self.electrode_tau_lumped + one;
        }
        if self.electrode_tau_distributed != T::zero() {
            g *= rc_line(s * self.electrode_tau_distributed);
        }
        if self.skew_current != T::zero() {
            g *= (-s * self.skew_current).cexp();
        }
        g
    }

    /// Factor of the tip channel's measurement chain.
    pub fn tip_chain(&self, s: C<T>) -> C<T> {
        if self.skew_tip != T::zero() { (-s * self.skew_tip).cexp() } else { C::new(T::one(), T::zero()) }
    }
}

/// tanh(x)/x with x = √(sτ): current collected through a uniform RC line from a uniform source.
fn rc_line<T: Real>(st: C<T>) -> C<T> {
    let x = st.csqrt();
    if x.cabs() < T::lit(1e-3) {
        return C::new(T::one(), T::zero()) - st / T::lit(3.0);
    }
    // tanh through e^(−2x), |e^(−2x)| ≤ 1 since Re x ≥ 0.
    let e = (-x * T::lit(2.0)).cexp();
    let one = C::new(T::one(), T::zero());
    (one - e) / (one + e) / x
}

/// Beam quantities per unit base displacement at one s: tip displacement w(L), tip slope w'(L)
/// and root slope w'(0).
#[derive(Clone, Copy, Debug)]
pub struct BeamResponse<T> {
    pub tip: C<T>,
    pub tip_slope: C<T>,
    pub root_slope: C<T>,
}

/// Solves the extended beam at s: closed forms when no end terms are present, else the 4×4
/// boundary-value problem.
pub fn beam_solve<T: Real>(p: &Params<T>, x: &Extension<T>, s: C<T>) -> BeamResponse<T> {
    let mu = x.impedance(p, s);
    let e = x.modulus(p, s);
    let ei = e * p.inertia();
    let l = p.l;
    // q = (pL)⁴ with the paper's p⁴ = s·μ/(4·I·E*).
    let q = s * mu * (l * l * l * l) / (ei * T::lit(4.0));
    if !x.has_end_terms() {
        let zero = C::new(T::zero(), T::zero());
        let (tip, slope) = tip_and_slope_of_q(q);
        return BeamResponse { tip, tip_slope: slope * (T::lit(2.0) / l), root_slope: zero };
    }
    // Λ = λL with λ⁴ = −s·μ/(E*·I) = −4p⁴: Λ⁴ = −4q. Any fourth root spans the same solutions.
    let lam = (-q * T::lit(4.0)).csqrt().csqrt();
    let [c, sn, ch, sh] = lam.ccos_csin_ccosh_csinh();
    let one = C::new(T::one(), T::zero());
    let zero = C::new(T::zero(), T::zero());
    let (l1, l2, l3) = (lam, lam * lam, lam * lam * lam);
    // Derivatives in ζ = z/L of (cos, sin, cosh, sinh)(Λζ): order 0..3, at ζ = 0 and ζ = 1.
    let at0 = [[one, zero, one, zero], [zero, l1, zero, l1], [-l2, zero, l2, zero], [zero, -l3, zero, l3]];
    let at1 = [
        [c, sn, ch, sh],
        [-l1 * sn, l1 * c, l1 * sh, l1 * ch],
        [-l2 * c, -l2 * sn, l2 * ch, l2 * sh],
        [l3 * sn, -l3 * c, l3 * sh, l3 * ch],
    ];
    // Root: w = 1; compliant clamp w' = c_θ·E*I·w'' (dimensionless κ = c_θ·E*I/L).
    let kappa = ei * x.clamp_compliance / l;
    // Tip: E*I·w'' = −J·s²·w' and E*I·w''' = M·s²·w (Laplace domain, tip body at z = L).
    let s2 = s * s;
    let jt = s2 * x.tip_inertia * l / ei;
    let mt = s2 * x.tip_mass * (l * l * l) / ei;
    let mut a = [[zero; 4]; 4];
    let mut b = [zero; 4];
    for k in 0..4 {
        a[0][k] = at0[0][k];
        a[1][k] = at0[1][k] - kappa * at0[2][k];
        a[2][k] = at1[2][k] + jt * at1[1][k];
        a[3][k] = at1[3][k] - mt * at1[0][k];
    }
    b[0] = one;
    let coef = solve4(a, b);
    let dot = |row: &[C<T>; 4]| row.iter().zip(&coef).fold(zero, |acc, (r, k)| acc + *r * *k);
    BeamResponse { tip: dot(&at1[0]), tip_slope: dot(&at1[1]) / l, root_slope: dot(&at0[1]) / l }
}

/// Gaussian elimination with partial pivoting on a 4×4 complex system.
fn solve4<T: Real>(mut a: [[C<T>; 4]; 4], mut b: [C<T>; 4]) -> [C<T>; 4] {
    for col in 0..4 {
        // |z|² orders the pivots as |z| does, without a hypot per comparison (the fits' hot path).
        let mag2 = |z: C<T>| z.re * z.re + z.im * z.im;
        let piv = (col..4).fold(col, |best, r| if mag2(a[r][col]) > mag2(a[best][col]) { r } else { best });
        a.swap(col, piv);
        b.swap(col, piv);
        for r in (col + 1)..4 {
            let f = a[r][col] / a[col][col];
            for k in col..4 {
                let v = a[col][k];
                a[r][k] -= f * v;
            }
            let v = b[col];
            b[r] -= f * v;
        }
    }
    let mut x = [C::new(T::zero(), T::zero()); 4];
    for r in (0..4).rev() {
        let mut acc = b[r];
        for k in (r + 1)..4 {
            acc -= a[r][k] * x[k];
        }
        x[r] = acc / a[r][r];
    }
    x
}

/// Tip response W(L,s)/U(s) [m/m] and current H(s) [A/m] of the extended model, each through its
/// channel's measurement chain. With a zero extension they are [`exact::responses`].
pub fn responses<T: Real>(p: &Params<T>, x: &Extension<T>, s: C<T>) -> (C<T>, C<T>) {
    through_chains(x, s, strip_responses(p, x, s))
}

/// The tip response and current of the strip itself, before the channels' measurement chains
/// and the feedthrough: they depend on `x` only through [`Extension::strip_terms`].
pub fn strip_responses<T: Real>(p: &Params<T>, x: &Extension<T>, s: C<T>) -> (C<T>, C<T>) {
    strip_responses_with(p, x, s, exact::ionic_drive(p, s))
}

/// [`strip_responses`] with the current's electrical part at s given ([`exact::ionic_drive`]).
pub fn strip_responses_with<T: Real>(p: &Params<T>, x: &Extension<T>, s: C<T>, drive: C<T>) -> (C<T>, C<T>) {
    if x.has_end_terms() || x.has_distributed_terms() {
        let beam = beam_solve(p, x, s);
        (beam.tip, current_of_slope_with(p, drive, (beam.tip_slope - beam.root_slope) * (p.l / T::lit(2.0))))
    } else {
        exact::responses_with(p, s, drive)
    }
}

/// The strip's responses at s ([`strip_responses`]) through each channel's measurement chain,
/// the feedthrough added to the current.
pub fn through_chains<T: Real>(x: &Extension<T>, s: C<T>, (tip, current): (C<T>, C<T>)) -> (C<T>, C<T>) {
    let current = current + s * x.feedthrough;
    (tip * x.tip_chain(s), current * x.current_chain(s))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Calibration;
    use crate::model::exact::{current_response, jw, q_of, slope_of_q, tip_of_q, tip_response};

    fn params(rh: f64) -> Params<f64> {
        Calibration::default_preset().params_at(rh)
    }

    fn rel(a: C<f64>, b: C<f64>) -> f64 {
        (a - b).cabs() / b.cabs()
    }

    /// The 4×4 solve with vanishing end terms against the closed form (forced through the
    /// general path by a compliance far below anything measurable).
    #[test]
    fn general_solve_meets_the_closed_form() {
        for rh in [30.0, 50.0, 80.0] {
            let p = params(rh);
            let x = Extension { clamp_compliance: 1e-12, ..Default::default() };
            for f in [1.0, 10.0, 35.0, 100.0, 220.0, 600.0, 1500.0] {
                let s = jw(f);
                let general = beam_solve(&p, &x, s);
                let q = q_of(&p, s);
                assert!(rel(general.tip, tip_of_q(q)) < 1e-7, "tip at {f} Hz, {rh} %");
                assert!(rel(general.tip_slope, slope_of_q(q) * (2.0 / p.l)) < 1e-7, "slope at {f} Hz");
                let (t, i) = responses(&p, &x, s);
                assert!(rel(t, tip_response(&p, s)) < 1e-7 && rel(i, current_response(&p, s)) < 1e-7);
            }
        }
    }

    fn first_peak(p: &Params<f64>, x: &Extension<f64>) -> f64 {
        let mut best = (0.0, 0.0);
        let mut f = 10.0;
        while f < 60.0 {
            let g = responses(p, x, jw(f)).0.cabs();
            if g > best.1 {
                best = (f, g);
            }
            f += 0.01;
        }
        best.0
    }

    /// Rayleigh's estimate for a tip mass M: the first mode falls as 1/√(1 + M/(0.2427·mL)). A
    /// root spring has no such one-line estimate: its direction and order are checked.
    #[test]
    fn end_terms_lower_the_first_resonance_as_physics_says() {
        let p = params(50.0);
        let f0 = first_peak(&p, &Extension::default());
        let mass = 0.1 * p.m * p.l;
        let fm = first_peak(&p, &Extension { tip_mass: mass, ..Default::default() });
        let rayleigh = f0 / (1.0f64 + 0.1 / 0.2427).sqrt();
        assert!((fm / rayleigh - 1.0).abs() < 0.01, "tip mass: {fm} vs Rayleigh {rayleigh}");
        let ei = p.y * p.inertia();
        let fc = first_peak(&p, &Extension { clamp_compliance: 0.1 * p.l / ei, ..Default::default() });
        assert!(fc < f0 * 0.99 && fc > f0 * 0.8, "clamp: {fc} vs {f0}");
        // A compliant root carries part of the curvature: the root slope is no longer zero.
        let b = beam_solve(&p, &Extension { clamp_compliance: 0.1 * p.l / ei, ..Default::default() }, jw(20.0));
        assert!(b.root_slope.cabs() > 0.01 * b.tip_slope.cabs());
    }

    /// Added air mass is the same as heavier beam material in the mechanics.
    #[test]
    fn added_mass_is_beam_mass() {
        let p = params(60.0);
        let mut heavy = p;
        heavy.m = p.m * 1.05;
        let x = Extension { added_mass: 0.05 * p.m, ..Default::default() };
        for f in [10.0, 33.0, 90.0] {
            assert!(rel(responses(&p, &x, jw(f)).0, tip_response(&heavy, jw(f))) < 1e-9);
        }
    }

    /// The strip's own responses ignore the measurement chains, and the chains are all the
    /// strip's terms leave out.
    #[test]
    fn strip_terms_are_all_the_strip_responses_see() {
        let p = params(55.0);
        let x = Extension {
            added_mass: 0.02 * p.m,
            stokes: 1e-3,
            loss_factor: 0.01,
            tip_mass: 0.05 * p.m * p.l,
            amp_tau: [1e-4, 2e-5],
            electrode_tau_lumped: 3e-5,
            electrode_tau_distributed: 1e-4,
            skew_tip: 1e-5,
            skew_current: -2e-5,
            feedthrough: 1e-9,
            ..Default::default()
        };
        let strip = x.strip_terms();
        for f in [5.0, 33.0, 400.0] {
            let s = jw(f);
            assert_eq!(strip_responses(&p, &x, s), strip_responses(&p, &strip, s));
            assert_eq!(responses(&p, &strip, s), strip_responses(&p, &x, s));
            assert_ne!(responses(&p, &x, s), strip_responses(&p, &x, s));
        }
    }

    /// The distributed RC line tends to the lumped pole with τ/3 at low frequency and to a
    /// half-order roll-off (−45°) far above it.
    #[test]
    fn electrode_line_limits() {
        let x = Extension { electrode_tau_distributed: 3e-4, ..Default::default() };
        let lumped = Extension { electrode_tau_lumped: 1e-4, ..Default::default() };
        let s = jw(20.0);
        assert!(rel(x.current_chain(s), lumped.current_chain(s)) < 2e-3);
        let far = x.current_chain(jw(1e6));
        let phase = far.carg().to_degrees();
        assert!((phase + 45.0).abs() < 1.0, "{phase}");
    }
}
