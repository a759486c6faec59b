//! An estimate file (`t_s,base_est_m,…`, as `ipmc compensate` and `cargo xtask qemu` write it)
//! scored against the true base motion of the recording it came from (a check's: its
//! accelerometer's displacement): the figures `ipmc score`
//! prints, as a struct for programs ([`figures`]).

use super::{Reference, Score, Scoring, accelerometer, coverage, nothing_scored, stated_period_s};
use crate::support::input::{checked, read_time_series};
use anyhow::{Result, anyhow, bail};
use ipmc_core::band::Band;
use ipmc_recording::looping::as_estimated;
use ipmc_recording::{Estimates, Format as _};
use std::path::Path;

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
        if file.base_est_m.len() > ts.current_a.len() {
            bail!(
                "{} has {} estimates for {} samples in {}",
                estimate.display(),
                file.base_est_m.len(),
                ts.current_a.len(),
                recording.display()
            );
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
        let truth = match (&ts.base_m, &ts.accel_mps2) {
            (Some(base), _) => scoring.truth(base, &ts.bursts()),
            (None, Some(accel)) => {
                let (truth, delay_s, rate_ppm) = accelerometer::fitted_truth(&scoring, accel, &file.base_est_m, &ts.bursts());
                scoring.reference = Reference::Accelerometer { delay_s, rate_ppm };
                truth
            }
            (None, None) => bail!(
                "{}: nothing to score against: no base_m column (the true base motion) and no accel_mps2 (a check's accelerometer)",
                recording.display()
            ),
        };
        Ok(Loaded { file, ts, scoring, truth })
    }

    /// The error pooled over the scored samples (None: nothing to score).
    pub fn pooled_error(&self) -> Option<f64> {
        let score = self.scoring.score(&self.file.base_est_m, &self.truth, &self.ts.bursts(), None);
        (!score.bursts.is_empty()).then(|| score.pooled.error())
    }
}

/// How to score: the overrides of [`Loaded::read`], and the window of the coverage of the stated
/// error bars (None: no coverage).
#[derive(Clone, Copy, Debug, Default)]
pub struct Options<'a> {
    pub preview_ms: Option<f64>,
    pub band_hz: Option<&'a str>,
    pub coverage_window_s: Option<f64>,
}

/// The stated error bars' coverage: per burst, and (covered, total) over the windows and over
/// the bursts as wholes.
pub struct Coverage {
    pub window_s: f64,
    pub bursts: Vec<coverage::Burst>,
    pub windows_covered: (usize, usize),
    pub bursts_covered: (usize, usize),
}

/// An estimate file scored: what it was scored against, and how it scored (a score without
/// bursts: nothing to score).
pub struct Scored {
    pub loaded: Loaded,
    pub coverage: Option<Coverage>,
    pub score: Score,
}

/// Scores the estimate file `estimate` against `recording`. Nothing scored is no error here
/// (see [`Scored::figures`]); an estimate without its stated error bars is, when the coverage is
/// asked for.
pub fn score(recording: &Path, estimate: &Path, options: &Options) -> Result<Scored> {
    let loaded = Loaded::read(recording, estimate, options.preview_ms, options.band_hz)?;
    let Loaded { file, ts, scoring, truth } = &loaded;
    let est = &file.base_est_m;
    let bursts = ts.bursts();
    let coverage = match options.coverage_window_s {
        Some(window_s) => {
            let rel_err = file.rel_err.as_ref().ok_or_else(|| {
                anyhow!("{}: no `rel_err` column (written by this release's `ipmc compensate` and firmware)", estimate.display())
            })?;
            let scored = coverage::score(scoring, est, truth, rel_err, &ts.rh_pct, &bursts, window_s);
            let (windows_covered, bursts_covered) = coverage::coverage(&scored);
            Some(Coverage { window_s, bursts: scored, windows_covered, bursts_covered })
        }
        None => None,
    };
    let score = scoring.score(est, truth, &bursts, None);
    Ok(Scored { loaded, coverage, score })
}

/// The share `covered / total` (NaN of nothing).
pub fn share((covered, total): (usize, usize)) -> f64 {
    if total == 0 { f64::NAN } else { covered as f64 / total as f64 }
}

/// The figures of a score, as `ipmc score --json` prints them (fractions).
#[derive(Clone, Debug, PartialEq)]
pub struct Figures {
    /// The error pooled over the scored samples of every burst.
    pub band_error: f64,
    pub rms_over_bursts: f64,
    pub per_burst: Vec<f64>,
    pub estimate_over_truth: f64,
    pub band_hz: [f64; 2],
    pub bursts: usize,
    /// Scored over whole periods of the excitation (the recording states its period).
    pub whole_periods: bool,
    pub coverage: Option<CoverageFigures>,
}

/// The coverage's figures: the share of windows whose actual error is within the stated 1σ, of
/// how many windows, and the bursts (levels) covered as wholes, of how many.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CoverageFigures {
    pub coverage: f64,
    pub windows: usize,
    pub levels_covered: usize,
    pub levels: usize,
}

impl Scored {
    /// The figures, None when nothing was scored.
    pub fn figures(&self) -> Option<Figures> {
        let (score, scoring) = (&self.score, &self.loaded.scoring);
        if score.bursts.is_empty() {
            return None;
        }
        Some(Figures {
            band_error: score.pooled.error(),
            rms_over_bursts: score.rms_over_bursts(),
            per_burst: score.bursts.iter().map(|b| b.whole.error()).collect(),
            estimate_over_truth: score.pooled.estimate_over_truth(),
            band_hz: [scoring.band.low_hz, scoring.band.high_hz],
            bursts: score.bursts.len(),
            whole_periods: scoring.period.is_some(),
            coverage: self.coverage.as_ref().map(|c| CoverageFigures {
                coverage: share(c.windows_covered),
                windows: c.windows_covered.1,
                levels_covered: c.bursts_covered.0,
                levels: c.bursts_covered.1,
            }),
        })
    }
}

/// `ipmc score RECORDING ESTIMATE` as a function: the estimate's figures against the recording's
/// true base motion; an error where nothing could be scored, saying why.
pub fn figures(recording: &Path, estimate: &Path, options: &Options) -> Result<Figures> {
    let scored = score(recording, estimate, options)?;
    scored.figures().ok_or_else(|| anyhow!("{}", nothing_scored(recording, &scored.loaded.ts, &scored.loaded.scoring)))
}
