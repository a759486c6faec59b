//! Physics and filter core of ipmc-sense.
//!
//! One source of truth for the firmware (f32), the host tests and the host tool (f64): every
//! function is generic over [`Real`], so the device and the host run the same code.
//!
//! The rooms, bottom to top; each imports only from the rooms listed before it (`cargo xtask
//! imports --list core` prints them by level, and a step of `cargo xtask test` fails on a circle):
//! - [`numeric`]: the scalar type and the numerical tools with no physics in them;
//! - [`timing`]: the firmware's clock (sample rate, block length, humidity period);
//! - [`wire`]: the formats that cross the board's edge (the stream out, the replay file in);
//! - [`resample`]: the board's accelerometer onto the ADC's clock (clock map, interpolation);
//! - [`band`]: the band an estimate is good in, and the FIR that keeps it;
//! - [`model`]: the paper's exact model H(s), its parameters, and the physics it leaves out;
//! - [`calibration`]: a strip's humidity laws, departures, uncertainty, instrument and humidity
//!   path: what the `CALIB.toml` file holds, and the parameters it gives at a humidity;
//! - [`inverse`]: rational approximation, discretized band-limited inverse, its expected error,
//!   and the per-sample filter with glitch-free retuning;
//! - [`humidity`]: the humidity chain, from a sensor's reading and the strip's own current to the
//!   humidity each block's design is for;
//! - [`firmware`]: what the firmware decides with no hardware (operating point, start-up, a stuck
//!   input), so the host runs it too;
//! - [`calibration_file`]: the one reader of the calibration file, which checks that the inverse
//!   designs over its range.
#![cfg_attr(not(feature = "std"), no_std)]

// The unit tests run on the host and may format.
#[cfg(test)]
extern crate std;

pub mod band;
pub mod calibration;
#[cfg(feature = "toml")]
pub mod calibration_file;
pub mod firmware;
pub mod humidity;
pub mod inverse;
pub mod model;
pub mod numeric;
pub mod resample;
pub mod timing;
pub mod wire;

pub use calibration::laws::{Calibration, Law, LawKind, ValidationError};
pub use inverse::design::{DesignConfig, DesignError, Inverse, InverseKind, MAX_SECTIONS, Sos, compensation_error, design_inverse};
pub use inverse::filter::{Cascade, Compensator};
pub use inverse::rational::RationalModel;
pub use model::exact::{current_response, tip_response};
pub use model::params::{ParamName, Params};
pub use numeric::real::{C, ComplexMath, Real};
