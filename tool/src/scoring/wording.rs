//! The words of a score: the one line every command prints of it, and what to do when a
//! recording gave nothing to score.

use super::{SETTLE_S, Score, Scoring};

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
