//! `ipmc score`: an estimate's error against the true base motion of the recording it came
//! from, scored exactly as `ipmc compensate` scores its own (one scoring for every caller,
//! including `cargo xtask qemu` for the firmware's estimates).

use crate::input::{checked, read_time_series};
use crate::scoring::{SETTLE_S, band_score, coverage};
use anyhow::{Result, anyhow, bail};
use ipmc_recording::looping::as_estimated;
use ipmc_recording::{Estimates, Format as _};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// The recording (time-series format) with the true `base_m`.
    recording: PathBuf,
    /// The estimate (`t_s,base_est_m,…`, as `ipmc compensate` and `cargo xtask qemu` write it).
    estimate: PathBuf,
    /// Latency of the estimate [ms]; by default the estimate file's `delay_samples` (which
    /// `ipmc compensate` and `cargo xtask qemu` write: the preview's and the band FIR's delay).
    #[arg(long)]
    delay_ms: Option<f64>,
    /// The band scored in [Hz], as `LOW-HIGH`; by default the estimate file's `band_hz`, else
    /// 10–150 Hz.
    #[arg(long)]
    band_hz: Option<String>,
    /// One JSON line `{"band_error": …, "estimate_over_truth": …, "band_hz": […]}` (fractions)
    /// for scripts (with --coverage also `coverage`, `windows`, `levels_covered`, `levels`).
    #[arg(long)]
    json: bool,
    /// Also how often the estimate's stated 1σ (its `rel_err` column) contains the actual
    /// in-band error: per burst (expected against actual) and over windows of this many seconds.
    #[arg(long, value_name = "WINDOW_S")]
    coverage: Option<f64>,
    /// With --coverage: seconds skipped at the start of each burst (the chain's start-up, which
    /// the expected error does not speak of; at least the scoring's 5 s).
    #[arg(long, default_value_t = SETTLE_S)]
    settle_s: f64,
}

/// `LOW-HIGH` in Hz.
pub fn parse_band(s: &str) -> Result<(f64, f64)> {
    let parsed = s.split_once('-').and_then(|(lo, hi)| Some((lo.trim().parse::<f64>().ok()?, hi.trim().parse::<f64>().ok()?)));
    match parsed {
        Some((lo, hi)) if lo > 0.0 && hi > lo => Ok((lo, hi)),
        _ => bail!("band `{s}`: expected LOW-HIGH in Hz with 0 < LOW < HIGH, e.g. 10-150"),
    }
}

/// An estimate beside the recording it came from, aligned as every score takes them.
pub struct Scoring {
    pub file: Estimates,
    pub ts: ipmc_recording::TimeSeries,
    pub delay: usize,
    pub band: (f64, f64),
    pub burst_start: Vec<usize>,
}

impl Scoring {
    /// `delay_ms` and `band_hz` override the estimate file's own (`delay_samples`, `band_hz`).
    pub fn load(recording: &Path, estimate: &Path, delay_ms: Option<f64>, band_hz: Option<String>) -> Result<Scoring> {
        let file = checked(Estimates::read(estimate))?;
        // An estimate `ipmc compensate` made on short bursts it looped is scored on them looped alike.
        let ts = as_estimated(read_time_series(recording)?, &file.metadata).map_err(|e| anyhow!("{}: {e}", estimate.display()))?;
        let base = ts.base_m.as_ref().ok_or_else(|| anyhow!("{}: no base_m column to score against", recording.display()))?;
        if file.base_est_m.len() > base.len() {
            bail!("{} has {} estimates for {} samples in {}", estimate.display(), file.base_est_m.len(), base.len(), recording.display());
        }
        let delay = match (delay_ms, file.metadata.get("delay_samples")) {
            (Some(ms), _) => (ms * 1e-3 * ts.fs_hz).round() as usize,
            (None, Some(d)) => d.parse().map_err(|_| anyhow!("{}: delay_samples={d} is not a whole number", estimate.display()))?,
            (None, None) => bail!(
                "{}: the file does not say its delay (no `# delay_samples=`): give --delay-ms (the chain's preview and band filter)",
                estimate.display()
            ),
        };
        let band_spec = band_hz.or_else(|| file.metadata.get("band_hz").map(str::to_string));
        let band = match band_spec {
            Some(b) => parse_band(&b)?,
            None => (ipmc_core::band::Band::DEFAULT.low_hz, ipmc_core::band::Band::DEFAULT.high_hz),
        };
        let mut burst_start = vec![0; ts.t_s.len()];
        for burst in ts.bursts() {
            burst_start[burst.clone()].fill(burst.start);
        }
        Ok(Scoring { file, ts, delay, band, burst_start })
    }

    /// The in-band error (None: nothing to score).
    #[cfg(test)]
    pub fn band_score(&self) -> Option<crate::scoring::BandScore> {
        let est = &self.file.base_est_m;
        band_score(est, &vec![self.delay; est.len()], &self.burst_start, self.ts.base_m.as_ref()?, self.ts.fs_hz, self.band)
    }
}

pub fn run(a: Args) -> Result<()> {
    let Scoring { file, ts, delay, band, burst_start } = Scoring::load(&a.recording, &a.estimate, a.delay_ms, a.band_hz.clone())?;
    let base = ts.base_m.as_ref().expect("checked by load");
    let est = file.base_est_m;
    let covered = match a.coverage {
        Some(window_s) => {
            let rel_err = file.rel_err.as_ref().ok_or_else(|| {
                anyhow!("{}: no `rel_err` column (written by this release's `ipmc compensate` and firmware)", a.estimate.display())
            })?;
            let bursts = coverage::score(&est, rel_err, base, &ts.rh_pct, &ts.bursts(), delay, ts.fs_hz, window_s, a.settle_s);
            if !a.json {
                println!("  RH [%]   expected 1σ [%]   actual [%]   windows within");
                for b in &bursts {
                    let inside = b.windows.iter().filter(|w| w.covered()).count();
                    println!(
                        "  {:6.2}   {:15.2}   {:10.2}   {inside}/{}",
                        b.rh_pct,
                        100.0 * b.whole.stated,
                        100.0 * b.whole.actual,
                        b.windows.len()
                    );
                }
            }
            Some(coverage::coverage(&bursts))
        }
        None => None,
    };
    let share = |(c, n): (usize, usize)| if n == 0 { f64::NAN } else { c as f64 / n as f64 };
    if let (Some((w, b)), false) = (covered, a.json) {
        println!(
            "coverage: the actual in-band error is within the stated 1σ in {} of {} windows of {} s ({:.1} %), {} of {} bursts",
            w.0,
            w.1,
            a.coverage.unwrap_or_default(),
            100.0 * share(w),
            b.0,
            b.1
        );
    }
    match band_score(&est, &vec![delay; est.len()], &burst_start, base, ts.fs_hz, band) {
        Some(score) if a.json => {
            let mut j = serde_json::json!({
                "band_error": score.error,
                "estimate_over_truth": score.estimate_over_truth,
                "band_hz": [band.0, band.1],
                "bursts": score.bursts,
            });
            if let Some((w, b)) = covered {
                j["coverage"] = share(w).into();
                j["windows"] = w.1.into();
                j["levels_covered"] = b.0.into();
                j["levels"] = b.1.into();
            }
            println!("{j}")
        }
        Some(score) => println!("{}", score.line(delay)),
        None => bail!("{}", crate::scoring::nothing_scored(&a.recording, &ts, band)),
    }
    Ok(())
}
