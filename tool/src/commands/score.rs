//! `ipmc score`: an estimate's error against the true base motion of the recording it came
//! from, scored exactly as `ipmc compensate` scores its own (one scoring for every caller,
//! including `cargo xtask qemu` for the firmware's estimates).

use super::compensate::{INBAND_HP_HZ, SETTLE_S, read_time_series, relative_error};
use crate::input::checked;
use anyhow::{Result, anyhow, bail};
use ipmc_recording::{Estimates, Format as _};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The recording (time-series format) with the true `base_m`.
    recording: PathBuf,
    /// The estimate (`t_s,base_est_m,…`, as `ipmc compensate` and `cargo xtask qemu` write it).
    estimate: PathBuf,
    /// Latency of the estimate [ms]: the design's preview delay (2 ms by default).
    #[arg(long, default_value_t = 2.0)]
    delay_ms: f64,
    /// One JSON line `{"inband": …, "broadband": …}` (relative rms errors, fractions) for scripts.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<()> {
    let ts = read_time_series(&a.recording)?;
    let base = ts.base_m.as_ref().ok_or_else(|| anyhow!("{}: no base_m column to score against", a.recording.display()))?;
    let est = checked(Estimates::read(&a.estimate))?.base_est_m;
    if est.len() > base.len() {
        bail!("{} has {} estimates for {} samples in {}", a.estimate.display(), est.len(), base.len(), a.recording.display());
    }
    let delay = (a.delay_ms * 1e-3 * ts.fs_hz).round() as usize;
    let mut burst_start = vec![0; ts.t_s.len()];
    for burst in ts.bursts() {
        burst_start[burst.clone()].fill(burst.start);
    }
    match relative_error(&est, &vec![delay; est.len()], &burst_start, base, ts.fs_hz) {
        Some((broad, inband)) if a.json => println!("{}", serde_json::json!({ "inband": inband, "broadband": broad })),
        None if a.json => bail!("not enough samples after settling to score"),
        Some((broad, inband)) => println!(
            "error vs true base (delayed {delay} samples, first {SETTLE_S} s skipped): in-band (>{INBAND_HP_HZ} Hz) {:.3} % rms, broadband {:.3} % rms",
            inband * 100.0,
            broad * 100.0
        ),
        None => println!("error vs true base: not enough samples after settling"),
    }
    Ok(())
}
