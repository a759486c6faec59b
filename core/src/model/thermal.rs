//! How the polymer follows the room's temperature away from the temperature its humidity laws
//! hold at: the modulus softens by α per kelvin, and ion transport is thermally activated
//! (Arrhenius, activation energy E_a). K's own 1/T is in [`crate::Params::t_k`] already. One
//! law for the simulator that conceals a temperature effect and the diagnosis that fits it.

use crate::numeric::real::Real;

/// The polymer's response to temperature.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Thermal<T> {
    /// Activation energy of ion transport [J/mol].
    pub ea_j_per_mol: T,
    /// Softening of the modulus, −d ln Y/dT [1/K].
    pub alpha_y_per_k: T,
}

impl<T: Real> Thermal<T> {
    /// ln of the factors on Y and on d at `t_k` against `t_ref_k` [K] (`r_gas` in J/(mol·K)).
    pub fn ln_factors(&self, t_k: T, t_ref_k: T, r_gas: T) -> (T, T) {
        let ln_y = -self.alpha_y_per_k * (t_k - t_ref_k);
        let ln_d = -self.ea_j_per_mol / r_gas * (T::one() / t_k - T::one() / t_ref_k);
        (ln_y, ln_d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 10 K warmer with 15 kJ/mol: d rises by exp(15000/8.314·(1/293.15 − 1/303.15)) ≈ 22 %;
    /// Y falls by α per kelvin.
    #[test]
    fn warmer_is_faster_and_softer() {
        let t = Thermal { ea_j_per_mol: 15e3, alpha_y_per_k: 0.01 };
        let (ln_y, ln_d) = t.ln_factors(303.15, 293.15, 8.314);
        assert!((ln_y + 0.1).abs() < 1e-12);
        assert!((ln_d.exp() - 1.2249).abs() < 1e-3, "{}", ln_d.exp());
        assert_eq!(t.ln_factors(293.15, 293.15, 8.314), (0.0, 0.0));
    }
}
