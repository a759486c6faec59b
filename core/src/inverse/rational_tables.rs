//! Parameter-free constants of the structured rational approximation ([`crate::inverse::rational`]).
//!
//! Both tables were fitted once, offline, by nonlinear least squares on relative error, and are
//! checked by this crate's tests against the exact model on a dense grid (so a wrong digit here
//! fails a test, not a user).
//!
//! **Mechanical factor.** S(q) (see [`crate::model::exact`]) is meromorphic in q with poles exactly at
//! q = −λₙ⁴/4 (1 + cos λ cosh λ = 0: the clamped–free beam modes), and S(0) = 0. It is
//! approximated as Σₙ rₙ/(q − qₙ) + c₀ + c₁·q·B/B₀ with four modes, c₀ = Σ rₙ/qₙ so that S(0) = 0
//! exactly (this keeps the double zero of H at DC exact). The poles qₙ are negative reals, so each
//! mode maps to s through A − qₙB (A = L⁴s(Ca + ms), B = 4I(Y + Cs s)) whose coefficients are all
//! positive: every pole is stable for every positive parameter set. The last term, written with
//! B/B₀ = 1 + Cs·s/Y, is q·B/B₀ = A/(4IY): a polynomial, so the higher modes' smooth tail costs no
//! pole. The first three poles stay within 0.1 % of −λₙ⁴/4; the fourth moves from −3654 to −3302
//! to absorb modes five and up.
//!
//! **Ionic factor.** In band |βh| ≫ 1, so (βh coth βh − 1)/β² = h√d·(s + K)^(-1/2) − d/(s + K); the
//! second term is below 0.1 % of the first over 5–500 Hz and is left out. (s + K)^(-1/2) is a
//! half-order element: it is replaced by a minimax rational function of x = (s + K)/ω₀ fitted on
//! ω ∈ [ω₀, 100·ω₀] along the imaginary axis (ω₀ = 2π·5 Hz), with real interlacing poles and zeros
//! (stable, minimum phase). Five pole–zero pairs give 0.22 % / 0.12°; four give 0.86 % / 0.47°.

/// Mode poles qₙ of the mechanical approximation (negative reals).
pub const MODE_Q: [f64; 4] = [-3.0905964066041203e+00, -1.2137958883702569e+02, -9.5196821489285810e+02, -3.3020741164292986e+03];
/// Residues rₙ at [`MODE_Q`].
pub const MODE_R: [f64; 4] = [3.3310737507626977e+00, -2.5176726491161810e+02, 1.9059192227867036e+03, -4.6496695741713102e+03];
/// Coefficient c₁ of the polynomial tail c₁·A/(4IY).
pub const TAIL_C1: f64 = -1.1435648704681597e-05;
/// Nonzero roots of Σ rₙ/(q − qₙ) + c₀ + c₁q (the tail taken at B = B₀). Each maps to a quadratic
/// A − ρB in s whose roots start the search for the exact zeros; the real 236.7 is the
/// non-minimum-phase zero of the physics notes (exact: 3.9266⁴ = 237.7).
pub const ZERO_RHO: [(f64, f64); 4] =
    [(236.70592679, 0.0), (1832.17369405, -1428.02313321), (1832.17369405, 1428.02313321), (26911.06935192, 0.0)];

/// ω₀ of the ionic approximation: the low edge of the band it is accurate on [rad/s].
pub const IONIC_OMEGA0: f64 = 2.0 * core::f64::consts::PI * 5.0;

/// A rational approximation of x^(-1/2) on x ∈ j·[1, 100]: g·Π(x + zₖ)/(x + pₖ).
#[derive(Clone, Copy, Debug)]
pub struct HalfOrder {
    pub poles: &'static [f64],
    pub zeros: &'static [f64],
    pub gain: f64,
}

/// Five pole–zero pairs (the default; 0.22 % magnitude, 0.12° phase).
pub const HALF_ORDER_5: HalfOrder = HalfOrder {
    poles: &[0.18119130049859572, 1.62888937734089, 6.995533979316829, 29.20801472634947, 143.88609723535225],
    zeros: &[0.6927725790296824, 3.4168728429961037, 14.269665832579175, 61.23993216590506, 549.5509413276617],
    gain: 0.02766180435274872,
};

/// Four pole–zero pairs (total denominator order 12; 0.86 % / 0.47°).
pub const HALF_ORDER_4: HalfOrder = HalfOrder {
    poles: &[0.2589493950245068, 2.6442652196436978, 15.544537060919929, 98.31276224900927],
    zeros: &[1.0170264125224846, 6.432261143424575, 37.812798156109366, 386.11518662094807],
    gain: 0.033100320985926565,
};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::C;

    #[test]
    fn mode_poles_are_the_beam_modes() {
        // 1 + cos λ cosh λ = 0 roots
        for (q, lam) in MODE_Q.iter().zip([1.875104068711961f64, 4.694091132974175, 7.854757438237613]) {
            let exact = -lam.powi(4) / 4.0;
            assert!((q / exact - 1.0).abs() < 1e-3, "{q} vs {exact}");
        }
    }

    #[test]
    fn half_order_tables_meet_their_stated_accuracy() {
        for (t, mag, ph) in [(HALF_ORDER_5, 0.0023, 0.13f64), (HALF_ORDER_4, 0.0087, 0.48)] {
            for i in 0..=400 {
                let w = 10f64.powf(2.0 * i as f64 / 400.0);
                let x = C::new(0.0, w);
                let mut r = C::new(t.gain, 0.0);
                for (p, z) in t.poles.iter().zip(t.zeros) {
                    r = r * (x + z) / (x + p);
                }
                let e = r * x.sqrt();
                assert!((e.norm() - 1.0).abs() < mag, "{w}");
                assert!(e.arg().to_degrees().abs() < ph, "{w}");
            }
        }
    }

    #[test]
    fn zero_rho_are_roots_of_the_universal_numerator() {
        let c0: f64 = MODE_R.iter().zip(MODE_Q).map(|(r, q)| r / q).sum();
        for (re, im) in ZERO_RHO {
            let q = C::new(re, im);
            let mut f = C::new(c0, 0.0) + q * TAIL_C1;
            let mut scale = c0.abs();
            for (r, qn) in MODE_R.iter().zip(MODE_Q) {
                f += C::new(*r, 0.0) / (q - qn);
                scale += (r / (q - qn)).norm();
            }
            assert!(f.norm() < 1e-7 * scale, "{q}: {f}");
        }
    }
}
