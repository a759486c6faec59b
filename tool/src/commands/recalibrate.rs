//! `ipmc recalibrate CALIB.toml CHECK.csv… --out NEW.toml`: the strip's calibration kept true by
//! checks made in service with the board's accelerometer.

use anyhow::{Context, Result};
use ipmc_recording::write_atomically;
use ipmc_tool::recalibrate::{DRIFT_PRIOR_SD, recalibrate, update};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The strip's calibration (from `ipmc identify` on its bench session, or an earlier
    /// recalibration).
    calib: String,
    /// Checks: time series with the board's accelerometer (`accel_mps2`), one or more, at one
    /// humidity or several.
    #[arg(required = true)]
    checks: Vec<PathBuf>,
    /// Write the new calibration here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// The drift's prior 1σ on each parameter's ln since the calibration (a few % a month over
    /// up to a year).
    #[arg(long, default_value_t = DRIFT_PRIOR_SD)]
    drift_prior: f64,
}

pub fn run(a: Args) -> Result<()> {
    let calib = ipmc_tool::support::calibration_source::load(Some(&a.calib))?;
    let outcome = recalibrate(&calib, &a.checks, a.drift_prior)?;
    print!("{}", update::table(&outcome));
    if let Some(out) = &a.out {
        let bench_text = std::fs::read_to_string(&a.calib).with_context(|| format!("cannot read {}", a.calib))?;
        let new = update::updated(&calib, &outcome);
        ipmc_core::calibration_file::check(&new).map_err(|e| anyhow::anyhow!("the updated calibration is not usable: {e}"))?;
        let text = update::file_text(&a.calib, &bench_text, &new, &outcome, &update::iso_date(std::time::SystemTime::now()));
        write_atomically(out, text.as_bytes())?;
        println!("wrote {}", out.display());
    }
    Ok(())
}
