//! `ipmc_tool`: the host tool's library. The `ipmc` binary (`main.rs`, `commands/`) parses the
//! command line and calls in here; everything a command computes, reads or draws lives here, so
//! that other programs (xtask) can call it without running the binary.

pub mod brickwall;
pub mod calibration_source;
pub mod chain;
pub mod chamber_humidity;
pub mod charging;
pub mod compensation;
pub mod diagnose;
pub mod exact;
pub mod field_table;
pub mod hygrometer;
pub mod identify;
pub mod input;
pub mod limits;
pub mod monitor;
pub mod noise_floor;
pub mod overrides;
pub mod plot;
pub mod progress;
pub mod prove;
pub mod range_edges;
pub mod reading_uncertainty;
pub mod scoring;
pub mod strip_check;
pub mod synthetic;
