//! The strip's physics: the paper's exact model of the current H(s) = I(s)/U(s) and the tip
//! response ([`exact`]), the parameters it takes at one humidity ([`params`]), the physics the
//! paper leaves out that `ipmc diagnose` tests for ([`extension`]), and the polymer's temperature
//! dependence ([`thermal`]). No humidity law lives here: the model is evaluated at one set of
//! parameters, which the calibration supplies.

pub mod exact;
pub mod extension;
pub mod params;
pub mod thermal;

pub use params::{ParamName, Params};
