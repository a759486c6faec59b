//! How an estimate is scored against the true base motion: one definition for every figure the
//! tool prints (`score`, `compensate`, `strip-check`, `vs-exact`, `field-table`, the plot's
//! error trace) and for the firmware's estimates (`cargo xtask qemu` runs `ipmc score`).
//!
//! The truth is the base motion shifted by the inverse's preview and put through the same band
//! filter the estimate went through; the error is rms(estimate − truth) / rms(truth) sample by
//! sample, after each burst's settling and the filter's start-up, over windows of whole periods
//! of the excitation where the recording states its period (and said not to be otherwise).
//!
//! - `definition`: the truth through the band, the samples skipped, the period;
//! - `figures`: the sums per window and burst, pooled and as an rms over the bursts;
//! - `coverage`: whether the stated error bars hold, window by window;
//! - `spectral`: where in frequency an error lies (a diagnostic, not the score).

pub mod coverage;
mod definition;
mod figures;
pub mod spectral;

pub use definition::{Scoring, stated_period_s};
pub use figures::{Score, Sums};
pub use ipmc_core::firmware::operating_point::SETTLE_S;

/// The one wording of the run's figure for every command (`cargo xtask qemu` splits it at
/// "skipped): ": how it was scored, then the figure).
pub fn line(scoring: &Scoring, score: &Score) -> String {
    let (lo, hi) = (scoring.band.low_hz, scoring.band.high_hz);
    let levels = if score.bursts.len() > 1 {
        format!(" ({:.3} % rms over the {} bursts)", 100.0 * score.rms_over_bursts(), score.bursts.len())
    } else {
        String::new()
    };
    format!(
        "error in {lo}–{hi} Hz ({}; each burst's first {:.2} s, its settling {SETTLE_S} s and the filter's start-up, skipped): {:.3} % rms{levels}; the estimate's rms is {:.2}× the truth's",
        scoring.describe(),
        scoring.skip() as f64 / scoring.fs_hz,
        100.0 * score.pooled.error(),
        score.pooled.estimate_over_truth()
    )
}

/// Why a recording gave nothing to score, and what to do: bursts shorter than the chain's
/// settling are the common case (a bench session's 2 s bursts of a periodic excitation).
pub fn nothing_scored(recording: &std::path::Path, ts: &ipmc_recording::TimeSeries, scoring: &Scoring) -> String {
    let longest = ts.bursts().iter().map(|b| b.len()).max().unwrap_or(0) as f64 / ts.fs_hz;
    let skip_s = scoring.skip() as f64 / ts.fs_hz;
    if longest <= skip_s + scoring.period.map_or(0.0, |p| p as f64 / ts.fs_hz) {
        format!(
            "{}: nothing to score: its longest burst is {longest:.1} s, and the chain needs {skip_s:.2} s to settle ({SETTLE_S} s, \
             and the band filter's start-up); bursts of a periodic excitation can be repeated by whole periods until they settle: \
             `ipmc loop-bursts {} --out LOOPED.csv` (`--period-s`, `--seconds`), then compensate and score LOOPED.csv \
             (`ipmc vs-exact` does this per burst)",
            recording.display(),
            recording.display()
        )
    } else {
        format!(
            "{}: nothing to score: the true base has nothing in {}–{} Hz after each burst's settling",
            recording.display(),
            scoring.band.low_hz,
            scoring.band.high_hz
        )
    }
}
