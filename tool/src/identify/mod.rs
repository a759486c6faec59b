//! Identification of a sample's calibration from its frequency-response recording (`ipmc
//! identify`): the rows grouped into humidity levels (`ipmc_recording`), each level's Y, Cs, Ca
//! and d fitted (`ipmc_fit::identify`), κe measured from charging recordings at a level (`kappa`)
//! or taken from the base calibration, and the humidity laws through the levels
//! (`ipmc_fit::laws`) making the calibration (`session`); what it prints (`printed`) and the
//! per-level JSON (`levels_json`).

pub mod kappa;
pub mod levels_json;
pub mod printed;
pub mod session;

pub use session::{Identified, base_calibration, identify};
