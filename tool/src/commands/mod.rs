//! The `ipmc` commands, one per file: each its clap arguments, their checks, the calls into the
//! library (`ipmc_tool`) and what it prints.

pub mod accuracy;
pub mod calib_export;
pub mod charging;
pub mod compensate;
pub mod design;
pub mod diagnose;
pub mod field_table;
pub mod identify;
pub mod loop_bursts;
pub mod model;
pub mod monitor;
pub mod plot;
pub mod prove;
pub mod recalibrate;
pub mod rh_sensitivity;
pub mod score;
pub mod simulate;
pub mod simulate_field;
pub mod strip_check;
pub mod vs_exact;

/// The designs a command evaluates: at which sample rate, from which calibration.
#[derive(clap::Args)]
pub struct DesignArgs {
    /// Sample rate [Hz].
    #[arg(long, default_value_t = 2000.0)]
    pub fs: f64,
    /// Calibration: `default`, `paper`, or a TOML file written by the tool.
    #[arg(long)]
    pub calib: Option<String>,
}
