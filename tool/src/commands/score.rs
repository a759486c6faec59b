//! `ipmc score`: an estimate's error against the true base motion of the recording it came
//! from, scored exactly as `ipmc compensate` scores its own (one scoring for every caller,
//! including `cargo xtask qemu` for the firmware's estimates).

use super::compensate::{INBAND_HP_HZ, SETTLE_S, bursts, read_time_series, relative_error};
use anyhow::{Context, Result, anyhow, bail};
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
}

/// The `base_est_m` column of an estimate file, by name; errors name file, line and column.
fn read_estimate(path: &std::path::Path) -> Result<Vec<f32>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut col = None;
    let mut out = vec![];
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(c) = col else {
            col = Some(fields.iter().position(|f| *f == "base_est_m").ok_or_else(|| anyhow!("{}:{}: no base_est_m column", path.display(), i + 1))?);
            continue;
        };
        let field = fields.get(c).ok_or_else(|| anyhow!("{}:{}: missing column {} (base_est_m)", path.display(), i + 1, c + 1))?;
        let v: f32 = field.parse().map_err(|e| anyhow!("{}:{}:{}: base_est_m {field:?}: {e}", path.display(), i + 1, c + 1))?;
        out.push(v);
    }
    Ok(out)
}

pub fn run(a: Args) -> Result<()> {
    let ts = read_time_series(&a.recording)?;
    let base = ts.base_m.as_ref().ok_or_else(|| anyhow!("{}: no base_m column to score against", a.recording.display()))?;
    let est = read_estimate(&a.estimate)?;
    if est.len() > base.len() {
        bail!("{} has {} estimates for {} samples in {}", a.estimate.display(), est.len(), base.len(), a.recording.display());
    }
    let delay = (a.delay_ms * 1e-3 * ts.fs_hz).round() as usize;
    let mut burst_start = vec![0; ts.t_s.len()];
    for (s, e) in bursts(&ts.t_s, ts.fs_hz) {
        burst_start[s..e].fill(s);
    }
    match relative_error(&est, &vec![delay; est.len()], &burst_start, base, ts.fs_hz) {
        Some((broad, inband)) => println!(
            "error vs true base (delayed {delay} samples, first {SETTLE_S} s skipped): in-band (>{INBAND_HP_HZ} Hz) {:.3} % rms, broadband {:.3} % rms",
            inband * 100.0,
            broad * 100.0
        ),
        None => println!("error vs true base: not enough samples after settling"),
    }
    Ok(())
}
