//! What a strip's calibration holds, the `CALIB.toml` file's tables as types: the humidity laws
//! and the parameters they give at a humidity ([`laws`]: [`Calibration`]), the strip's own
//! departures from its laws ([`departures`]), what checks in service left unknown of it ([`checked`]), what the calibration does not know
//! ([`uncertainty`]) and the response spread that follows from it ([`moments`]), the instrument
//! it was measured with ([`instrument`]) and the humidity sensor's path to the strip
//! ([`humidity_path`]), with the offset a check found given each hydration lag ([`lag_offsets`]).
//! Above the model and the band, below everything that designs with it.

pub mod checked;
pub mod departures;
pub mod humidity_path;
pub mod instrument;
pub mod lag_offsets;
pub mod laws;
pub mod moments;
pub mod uncertainty;

pub use laws::{Calibration, EXTRAPOLATION_PCT, Law, LawKind, MAX_LAW_COEFFS, ValidationError};
