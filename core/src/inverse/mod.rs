//! From a calibration at one humidity to compensated base motion, sample by sample: the
//! physics-structured rational approximation of H(s) ([`rational`], its constants in
//! [`rational_tables`]), the discretized, stable, band-limited inverse as second-order sections
//! ([`design`]), the error it is expected to leave ([`expected_error`]), and the per-sample
//! cascade with glitch-free retuning ([`filter`]).

pub mod design;
pub mod expected_error;
pub mod filter;
pub mod rational;
pub mod rational_tables;
