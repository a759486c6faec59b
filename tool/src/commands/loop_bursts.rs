//! `ipmc loop-bursts`: each burst of a periodic excitation repeated by whole periods until it is
//! long enough for the compensation to settle ([`crate::looping`]), with the current's noise
//! density measured from period-to-period differences written as metadata.

use crate::input::checked;
use crate::looping::loop_bursts;
use anyhow::Result;
use ipmc_recording::{Format as _, NumberFormat, TimeSeries, write_atomically};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Time-series recording of bursts (each a steady-state periodic excitation).
    input: PathBuf,
    /// The excitation's period [s].
    #[arg(long, default_value_t = 1.0)]
    period_s: f64,
    /// Length of each looped burst [s] (whole periods, at least this long).
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let ts = checked(TimeSeries::read(&a.input))?;
    let looped = loop_bursts(&ts, a.period_s, a.seconds)?;
    write_atomically(&a.out, looped.to_csv(NumberFormat::Exact)?.as_bytes())?;
    println!("{} bursts, {} samples -> {}", looped.bursts().len(), looped.len(), a.out.display());
    Ok(())
}
