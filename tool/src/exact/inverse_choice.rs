//! Which inverse the host's chain designs (`--inverse`): the nominal strip's, or the one of least
//! expected error over what the calibration does not know (`ipmc_core::InverseKind`).

use ipmc_core::{InverseKind, Real};

#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum InverseChoice {
    /// The nominal model's inverse (the firmware's).
    Exact,
    /// E[H*]/E[|H|²] over the humidity reading's uncertainty and the `[uncertainty]` scatter.
    Robust,
}

impl InverseChoice {
    /// The core's kind, for a humidity reading of standard uncertainty `rh_sd_pct`.
    pub fn kind<T: Real>(self, rh_sd_pct: f64) -> InverseKind<T> {
        match self {
            InverseChoice::Exact => InverseKind::Exact,
            InverseChoice::Robust => InverseKind::Robust { rh_sd_pct: T::lit(rh_sd_pct) },
        }
    }
}
