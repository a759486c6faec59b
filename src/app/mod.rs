//! Application: identical for every board. Sources come in through `ports`, the compensation
//! comes from ipmc-core through `compensation`, results leave through `report`.

pub mod analog_humidity;
pub mod calibration;
pub mod compensation;
pub mod config;
pub mod current_conversion;
pub mod flags;
pub mod handoff;
pub mod humidity;
pub mod hygrometer;
pub mod ports;
pub mod report;
pub mod retune;
pub mod sample_path;
