//! The calibration compiled into this firmware: chosen at build time by `IPMC_CALIB` (a TOML
//! file written by `cargo ipmc calib-export`) or the core's default preset, parsed and validated
//! on the host by build.rs, so the device never holds a calibration it cannot design with.

include!(concat!(env!("OUT_DIR"), "/calibration.rs"));
