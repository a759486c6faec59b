//! `ipmc_tool`: the host tool's library. The `ipmc` binary (`main.rs`, `commands/`) parses the
//! command line and calls in here; everything a command computes, reads, writes or draws lives
//! here, so that other programs (xtask) can call it without running the binary.
//!
//! Rooms, bottom to top: the leaves (`support`: recordings, calibrations, progress; `brickwall`:
//! the FFT's ideal band limit; `humidity`: the strip's own hygrometer and the chamber's
//! setpoints; `charging`; `monitor`: the firmware's stream; `synthetic`: a test recording), then
//! `chain` (the firmware's chain on the host), `scoring` (the one definition of an estimate's
//! error), `error_budget` and `prove`; then `exact` (the reference inverse), `compensation`,
//! `identify` and `plot`; at the top `diagnose` (its figures and report), `field_table` and
//! `strip_check`.

pub mod brickwall;
pub mod chain;
pub mod charging;
pub mod compensation;
pub mod diagnose;
pub mod error_budget;
pub mod exact;
pub mod field_table;
pub mod humidity;
pub mod identify;
pub mod monitor;
pub mod plot;
pub mod prove;
pub mod recalibrate;
pub mod scoring;
pub mod strip_check;
pub mod support;
pub mod synthetic;
