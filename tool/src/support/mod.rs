//! What every command needs around its work: recordings read with their warnings (`input`), the
//! calibration a `--calib` names (`calibration_source`), `--set` overrides of a parameter
//! (`overrides`), and progress bars on a terminal (`progress`).

pub mod calibration_source;
pub mod input;
pub mod overrides;
pub mod progress;
