//! Physics and filter core of ipmc-sense.
//!
//! One source of truth for the firmware (f32), the host tests and the host tool (f64): every
//! function is generic over [`Real`], so the device and the host run the same code.
//!
//! Data flows one way through the modules:
//! [`calibration`] (humidity laws → [`Params`]) → [`model`] (exact H(s)) →
//! [`rational`] (physics-structured rational approximation) → [`design`] (discretized,
//! band-limited, causal inverse as second-order sections) → [`filter`] (the per-sample cascade
//! and glitch-free retuning).
#![cfg_attr(not(feature = "std"), no_std)]

// The unit tests run on the host and may format.
#[cfg(test)]
extern crate std;

pub mod band;
pub mod band_limit;
pub mod block_humidity;
pub mod calibration;
#[cfg(feature = "toml")]
pub mod calibration_file;
pub mod departures;
pub mod design;
pub mod expected_error;
pub mod extension;
pub mod fft;
pub mod filter;
pub mod humidity;
pub mod humidity_fusion;
pub mod humidity_path;
pub mod humidity_trend;
pub mod instrument;
pub mod lstsq;
pub mod model;
pub mod operating_point;
pub mod rational;
pub mod rational_tables;
pub mod real;
pub mod replay;
pub mod roots;
pub mod running_spectrum;
pub mod startup;
pub mod stream;
pub mod strip_humidity;
pub mod stuck;
pub mod thermal;
pub mod uncertainty;

pub use calibration::{Calibration, Law, LawKind, ParamName, Params, ValidationError};
pub use design::{DesignConfig, DesignError, Inverse, InverseKind, MAX_SECTIONS, Sos, compensation_error, design_inverse};
pub use filter::{Cascade, Compensator};
pub use model::{current_response, tip_response};
pub use rational::RationalModel;
pub use real::{ComplexMath, Real};

/// Complex numbers over the crate's real type.
pub type C<T> = num_complex::Complex<T>;
