//! The exact inverse: the reference the causal chain is held to. The band-limited exact (and
//! robust) inverse of the nominal model per DFT bin (`band_limited`), which inverse the host's
//! chain designs (`inverse_choice`), and the two scored alike per level of a periodic recording
//! (`against_chain`, what `ipmc vs-exact` prints).

pub mod against_chain;
pub mod band_limited;
pub mod inverse_choice;

pub use band_limited::{inverse, robust_inverse};
pub use inverse_choice::InverseChoice;
