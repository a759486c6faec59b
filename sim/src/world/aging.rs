//! A strip in service, aged: its parameters drifted by stated factors since its bench session, and
//! its electrodes cracked into a distributed RC line tanh√(sτ)/√(sτ) (the core's extension), both
//! stated inputs. IPMC output in air falls as the electrodes crack and the membrane loses water and
//! ions (Park et al. 2010); no published per-month rates, so the ages are what a case states.

use crate::world::physics::Physics;
use ipmc_core::model::extension::Extension;
use ipmc_core::{C, ParamName, Params};

/// An aged strip: `inner` with each named parameter scaled and the electrodes' RC line.
pub struct Aged<'a> {
    pub inner: &'a dyn Physics,
    pub factors: Vec<(ParamName, f64)>,
    /// The electrodes' distributed RC time constant [s] (0: intact).
    pub electrode_tau_s: f64,
}

impl Physics for Aged<'_> {
    fn response(&self, params: &Params<f64>, rh_pct: f64, temp_c: f64, s: C<f64>) -> (C<f64>, C<f64>) {
        let mut p = *params;
        for &(name, f) in &self.factors {
            p.set(name, p.get(name) * f);
        }
        let (tip, current) = self.inner.response(&p, rh_pct, temp_c, s);
        let line = Extension { electrode_tau_distributed: self.electrode_tau_s, ..Default::default() };
        (tip, current * line.current_chain(s))
    }
}
