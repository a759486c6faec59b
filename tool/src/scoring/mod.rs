//! How an estimate is scored against the true base motion: the same samples (after each burst's
//! settling, against the base delayed by the design's delay) for every figure the tool prints.
//!
//! - [`band_score`]: the error and the estimate's size in the calibration's band.
//! - [`band_error`]: the error's content in a band of DFT lines (`crate::band`).
//! - [`coverage`]: whether the stated error bars hold, window by window.

pub mod coverage;

pub use ipmc_core::firmware::operating_point::SETTLE_S;

/// What an estimate is scored by, in its calibration's band.
#[derive(Clone, Copy, Debug)]
pub struct BandScore {
    /// The band [Hz].
    pub band: (f64, f64),
    /// The error's content in the band over the true base's there (rms ratio).
    pub error: f64,
    /// The raw estimate's rms over the true base's rms in the band: what a user sees as it
    /// comes against what there is to see.
    pub estimate_over_truth: f64,
    /// Bursts with samples scored.
    pub bursts: usize,
}

impl BandScore {
    /// The one wording of the figure for every command (`cargo xtask qemu` reads what follows
    /// "skipped): ").
    pub fn line(&self, delay_samples: usize) -> String {
        let (lo, hi) = self.band;
        format!(
            "error in {lo}–{hi} Hz against the true base in {lo}–{hi} Hz (delayed {delay_samples} samples, first {SETTLE_S} s of each \
             burst skipped): {:.3} % rms; the estimate's rms is {:.2}× the true base's in band",
            100.0 * self.error,
            self.estimate_over_truth
        )
    }
}

/// The estimate's error and size in `band`, on the samples every figure is taken on (after
/// each burst's settling, against the base delayed by the chain's delay). None when no burst
/// has samples after settling or the base has nothing in the band.
pub fn band_score<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
    band: (f64, f64),
) -> Option<BandScore> {
    let (mut se, mut sb, mut sx, mut n, mut bursts) = (0.0f64, 0.0f64, 0.0f64, 0usize, 0usize);
    let settle = (SETTLE_S * fs_hz).round() as usize;
    for ((err, truth), est) in
        scored_bursts(est, delay, burst_start, base, fs_hz).into_iter().zip(scored_estimates(est, delay, burst_start, settle))
    {
        if err.len() > 2 {
            se += crate::band::energy(&err, fs_hz, band.0, band.1);
            sb += crate::band::energy(&truth, fs_hz, band.0, band.1);
            sx += est.iter().map(|v| v * v).sum::<f64>();
            n += err.len();
            bursts += 1;
        }
    }
    (sb > 0.0 && n > 0).then(|| BandScore { band, error: (se / sb).sqrt(), estimate_over_truth: (sx / sb).sqrt(), bursts })
}

/// Why a recording gave nothing to score, and what to do: bursts shorter than the chain's
/// settling are the common case (a bench session's 2 s bursts of a periodic excitation).
pub fn nothing_scored(recording: &std::path::Path, ts: &ipmc_recording::TimeSeries, band: (f64, f64)) -> String {
    let longest = ts.bursts().iter().map(|b| b.len()).max().unwrap_or(0) as f64 / ts.fs_hz;
    if longest <= SETTLE_S {
        format!(
            "{}: nothing to score: its longest burst is {longest:.1} s, and the chain needs {SETTLE_S} s to settle; bursts of a \
             periodic excitation can be repeated by whole periods until they settle: `ipmc loop-bursts {} --out LOOPED.csv` \
             (`--period-s`, `--seconds`), then compensate and score LOOPED.csv (`ipmc vs-exact` does this per burst)",
            recording.display(),
            recording.display()
        )
    } else {
        format!(
            "{}: nothing to score: the true base has nothing in {}–{} Hz after each burst's settling",
            recording.display(),
            band.0,
            band.1
        )
    }
}

/// Per burst, the estimate on the samples [`scored_bursts`] scores.
fn scored_estimates<E: Copy + Into<f64>>(est: &[E], delay: &[usize], burst_start: &[usize], settle: usize) -> Vec<Vec<f64>> {
    let n = est.len().min(delay.len()).min(burst_start.len());
    let mut out: Vec<Vec<f64>> = vec![];
    for k in 0..n {
        if k == 0 || burst_start[k] != burst_start[k - 1] {
            out.push(vec![]);
        }
        let b0 = burst_start[k];
        if k >= b0 + settle && k >= b0 + delay[k] {
            out.last_mut().expect("pushed").push(est[k].into());
        }
    }
    out
}

/// Error of an estimate in a band: the error's content in `band` over the true base's content
/// in `reference` (each `(lo_hz, hi_hz)`; `band::energy`, per burst, on the same samples as
/// [`band_score`]), as a ratio of rms values. With both the design band: the error in the
/// band the inverse is asked to get right, and nothing else, the figure the exact band-limited
/// inverse is held to as well (`ipmc vs-exact`); with another `band`, what the estimate adds
/// there, on the scale of the signal in the design band.
pub fn band_error<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
    band: (f64, f64),
    reference: (f64, f64),
) -> Option<f64> {
    let (mut se, mut sb) = (0.0f64, 0.0f64);
    for (err, truth) in scored_bursts(est, delay, burst_start, base, fs_hz) {
        if err.len() > 2 {
            se += crate::band::energy(&err, fs_hz, band.0, band.1);
            sb += crate::band::energy(&truth, fs_hz, reference.0, reference.1);
        }
    }
    (sb > 0.0).then(|| (se / sb).sqrt())
}

/// Per burst, the samples scored: (estimate − delayed true base, delayed true base), after the
/// first [`SETTLE_S`] of the burst.
fn scored_bursts<E: Copy + Into<f64>>(
    est: &[E],
    delay: &[usize],
    burst_start: &[usize],
    base: &[f64],
    fs_hz: f64,
) -> Vec<(Vec<f64>, Vec<f64>)> {
    let settle = (SETTLE_S * fs_hz).round() as usize;
    let n = est.len().min(base.len()).min(delay.len()).min(burst_start.len());
    let mut out = vec![];
    let mut i = 0;
    while i < n {
        let b0 = burst_start[i];
        let mut j = i;
        while j < n && burst_start[j] == b0 {
            j += 1;
        }
        let (mut err, mut truth) = (vec![], vec![]);
        for k in i..j {
            if k < b0 + settle || k < b0 + delay[k] {
                continue;
            }
            let t = base[k - delay[k]];
            err.push(est[k].into() - t);
            truth.push(t);
        }
        out.push((err, truth));
        i = j;
    }
    out
}
