//! `ipmc score`: an estimate's error against the true base motion of the recording it came
//! from, by the one scoring every command uses (`ipmc_tool::scoring`; `cargo xtask qemu` scores the
//! firmware's estimates with this command).

use anyhow::{Result, anyhow, bail};
use ipmc_core::band::Band;
use ipmc_recording::looping::as_estimated;
use ipmc_recording::{Estimates, Format as _};
use ipmc_tool::input::{checked, read_time_series};
use ipmc_tool::scoring::{Scoring, coverage, stated_period_s};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// The recording (time-series format) with the true `base_m`.
    recording: PathBuf,
    /// The estimate (`t_s,base_est_m,…`, as `ipmc compensate` and `cargo xtask qemu` write it).
    estimate: PathBuf,
    /// The inverse's preview [ms], by which the true base is shifted before it goes through the
    /// band filter; by default the design's (`max_delay_s`).
    #[arg(long)]
    preview_ms: Option<f64>,
    /// The band scored in [Hz], as `LOW-HIGH`; by default the estimate file's `band_hz`, else
    /// 10–150 Hz.
    #[arg(long)]
    band_hz: Option<String>,
    /// One JSON line `{"band_error": …, "estimate_over_truth": …, "band_hz": […]}` (fractions)
    /// for scripts (with --coverage also `coverage`, `windows`, `levels_covered`, `levels`).
    #[arg(long)]
    json: bool,
    /// Also how often the estimate's stated 1σ (its `rel_err` column) contains the actual
    /// error: per burst (expected against actual) and over windows of about this many seconds
    /// (whole periods where the recording states its period).
    #[arg(long, value_name = "WINDOW_S")]
    coverage: Option<f64>,
}

/// `LOW-HIGH` in Hz.
pub fn parse_band(s: &str) -> Result<(f64, f64)> {
    let parsed = s.split_once('-').and_then(|(lo, hi)| Some((lo.trim().parse::<f64>().ok()?, hi.trim().parse::<f64>().ok()?)));
    match parsed {
        Some((lo, hi)) if lo > 0.0 && hi > lo => Ok((lo, hi)),
        _ => bail!("band `{s}`: expected LOW-HIGH in Hz with 0 < LOW < HIGH, e.g. 10-150"),
    }
}

/// The band an estimate file was kept in: its `band_hz`, else the default, in the default's shape
/// where the file does not say another.
pub fn band_of(file: &ipmc_recording::Metadata, given: Option<&str>) -> Result<Band> {
    let mut band = Band::DEFAULT;
    if let Some(spec) = given.or_else(|| file.get("band_hz")) {
        (band.low_hz, band.high_hz) = parse_band(spec)?;
    }
    Ok(band)
}

/// An estimate beside the recording it came from and the truth it is scored against, by the
/// one scoring.
pub struct Loaded {
    pub file: Estimates,
    pub ts: ipmc_recording::TimeSeries,
    pub scoring: Scoring,
    pub truth: Vec<f64>,
}

impl Loaded {
    /// `preview_ms` and `band_hz` override the design's preview and the estimate file's band.
    pub fn read(recording: &Path, estimate: &Path, preview_ms: Option<f64>, band_hz: Option<&str>) -> Result<Loaded> {
        let file = checked(Estimates::read(estimate))?;
        // An estimate `ipmc compensate` made on short bursts it looped is scored on them looped alike.
        let ts = as_estimated(read_time_series(recording)?, &file.metadata).map_err(|e| anyhow!("{}: {e}", estimate.display()))?;
        let base = ts.base_m.as_ref().ok_or_else(|| anyhow!("{}: no base_m column to score against", recording.display()))?;
        if file.base_est_m.len() > base.len() {
            bail!("{} has {} estimates for {} samples in {}", estimate.display(), file.base_est_m.len(), base.len(), recording.display());
        }
        let band = band_of(&file.metadata, band_hz)?;
        let mut scoring = Scoring::new(&band, ts.fs_hz, stated_period_s(&ts.metadata, Some(&file.metadata)))?;
        if let Some(ms) = preview_ms {
            scoring.preview = (ms * 1e-3 * ts.fs_hz).round() as usize;
        }
        // The file's own statement of its delay, where it has one, must be what the scoring assumes.
        if let Some(d) = file.metadata.get("delay_samples").and_then(|d| d.parse::<usize>().ok())
            && d != scoring.preview + scoring.band_delay
            && preview_ms.is_none()
        {
            eprintln!(
                "warning: {}: delay_samples={d}, where the preview ({}) and the band filter ({}) make {}: give --preview-ms if the chain's preview differs",
                estimate.display(),
                scoring.preview,
                scoring.band_delay,
                scoring.preview + scoring.band_delay
            );
        }
        let truth = scoring.truth(base, &ts.bursts());
        Ok(Loaded { file, ts, scoring, truth })
    }

    /// The error pooled over the scored samples (None: nothing to score).
    #[cfg(test)]
    pub fn pooled_error(&self) -> Option<f64> {
        let score = self.scoring.score(&self.file.base_est_m, &self.truth, &self.ts.bursts(), None);
        (!score.bursts.is_empty()).then(|| score.pooled.error())
    }
}

pub fn run(a: Args) -> Result<()> {
    let Loaded { file, ts, scoring, truth } = Loaded::read(&a.recording, &a.estimate, a.preview_ms, a.band_hz.as_deref())?;
    let band = scoring.band;
    let est = file.base_est_m;
    let bursts = ts.bursts();
    let covered = match a.coverage {
        Some(window_s) => {
            let rel_err = file.rel_err.as_ref().ok_or_else(|| {
                anyhow!("{}: no `rel_err` column (written by this release's `ipmc compensate` and firmware)", a.estimate.display())
            })?;
            let scored = coverage::score(&scoring, &est, &truth, rel_err, &ts.rh_pct, &bursts, window_s);
            if !a.json {
                println!("  RH [%]   expected 1σ [%]   actual [%]   windows within");
                for b in &scored {
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
            Some(coverage::coverage(&scored))
        }
        None => None,
    };
    let share = |(c, n): (usize, usize)| if n == 0 { f64::NAN } else { c as f64 / n as f64 };
    if let (Some((w, b)), false) = (covered, a.json) {
        let window = match (a.coverage, scoring.period) {
            (Some(s), Some(p)) => format!("{} s (whole periods)", ((s * ts.fs_hz / p as f64).round().max(1.0)) * p as f64 / ts.fs_hz),
            (Some(s), None) => format!("{s} s (not whole periods)"),
            _ => String::new(),
        };
        println!(
            "coverage: the actual error is within the stated 1σ in {} of {} windows of {window} ({:.1} %), {} of {} bursts",
            w.0,
            w.1,
            100.0 * share(w),
            b.0,
            b.1
        );
    }
    let score = scoring.score(&est, &truth, &bursts, None);
    if score.bursts.is_empty() {
        bail!("{}", ipmc_tool::scoring::nothing_scored(&a.recording, &ts, &scoring));
    }
    if a.json {
        let mut j = serde_json::json!({
            "band_error": score.pooled.error(),
            "rms_over_bursts": score.rms_over_bursts(),
            "per_burst": score.bursts.iter().map(|b| b.whole.error()).collect::<Vec<_>>(),
            "estimate_over_truth": score.pooled.estimate_over_truth(),
            "band_hz": [band.low_hz, band.high_hz],
            "bursts": score.bursts.len(),
            "whole_periods": scoring.period.is_some(),
        });
        if let Some((w, b)) = covered {
            j["coverage"] = share(w).into();
            j["windows"] = w.1.into();
            j["levels_covered"] = b.0.into();
            j["levels"] = b.1.into();
        }
        println!("{j}")
    } else {
        println!("{}", ipmc_tool::scoring::line(&scoring, &score));
    }
    Ok(())
}
