//! `ipmc loop-bursts`: each burst of a periodic excitation repeated by whole periods until it is
//! long enough for the compensation to settle ([`ipmc_recording::looping`], which `ipmc
//! compensate` loops short bursts with too), with the current's noise density measured from
//! period-to-period differences and the new layout written as metadata.

use anyhow::Result;
use ipmc_recording::looping::{DEFAULT_PERIOD_S, DEFAULT_SECONDS, loop_bursts};
use ipmc_recording::{Format as _, NumberFormat, TimeSeries, write_atomically};
use ipmc_tool::support::input::checked;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Time-series recording of bursts (each a steady-state periodic excitation).
    input: PathBuf,
    /// The excitation's period [s].
    #[arg(long, default_value_t = DEFAULT_PERIOD_S)]
    period_s: f64,
    /// Length of each looped burst [s] (whole periods, at least this long).
    #[arg(long, default_value_t = DEFAULT_SECONDS)]
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
