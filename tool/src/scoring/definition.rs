//! What an estimate is compared with: the true base motion shifted by the inverse's preview and
//! passed through the very band filter the estimate went through (`BandLimit::new(&band, fs)`,
//! a fresh one per burst as the chain starts one), so that both carry the filter's delay and
//! response alike, whatever its shape (linear-phase or not). Compared sample by sample, after
//! the chain's settling and the filter's own start-up.

use super::SETTLE_S;
use anyhow::{Result, anyhow};
use ipmc_core::DesignConfig;
use ipmc_core::band::{Band, BandDesign, BandLimit};
use std::ops::Range;

/// The one definition every figure of error is taken by.
#[derive(Clone, Copy, Debug)]
pub struct Scoring {
    /// The band the estimate was kept in (its shape included): the filter the truth goes through.
    pub band: Band,
    pub fs_hz: f64,
    /// The inverse's preview [samples]: how far the estimate lags before its band filter.
    pub preview: usize,
    /// Samples of the band filter's response to an impulse that matter: its start-up.
    pub start_up: usize,
    /// The band filter's own stated delay [samples] (for the wording only: the truth carries
    /// whatever the filter does, not this number).
    pub band_delay: usize,
    /// The excitation's period [samples], where the recording says it.
    pub period: Option<usize>,
    /// What the truth is made from.
    pub reference: Reference,
}

/// What an estimate is compared with: the recording's true base motion (a laser, a simulator's
/// truth), or on a check its accelerometer's displacement, the chain's delay fitted.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reference {
    Base,
    Accelerometer { delay_s: f64, rate_ppm: f64 },
}

/// The tail of the impulse response left out of the start-up, as a share of its energy: far
/// below what an f32 estimate resolves, so a finite response (FIR) ends exactly where it ends.
const START_UP_TAIL: f64 = 1e-12;

/// The inverse's preview at `fs_hz` [samples], as the design rounds it.
fn preview_samples(fs_hz: f64) -> usize {
    let c = DesignConfig::<f64>::at_rate(fs_hz);
    (c.max_delay_s * fs_hz + 1e-6).floor() as usize
}

impl Scoring {
    /// `period_s`: the excitation's period where known (a whole number of samples, else none).
    pub fn new(band: &Band, fs_hz: f64, period_s: Option<f64>) -> Result<Self> {
        let mut f = filter(band, fs_hz)?;
        let band_delay = f.delay_samples();
        let start_up = start_up(&mut f, fs_hz);
        let period = period_s.map(|p| p * fs_hz).filter(|p| *p >= 1.0 && (p - p.round()).abs() < 1e-6).map(|p| p.round() as usize);
        Ok(Scoring { band: *band, fs_hz, preview: preview_samples(fs_hz), start_up, band_delay, period, reference: Reference::Base })
    }

    /// Samples skipped at the start of each burst: the chain's settling and the filter's start-up.
    pub fn skip(&self) -> usize {
        (SETTLE_S * self.fs_hz).round() as usize + self.start_up
    }

    /// `x` through the band filter, a fresh one per burst, each burst's samples taken as `x`
    /// `shift` samples earlier (NaN where that lies before the burst).
    fn through_band(&self, x: &[f64], bursts: &[Range<usize>], shift: usize) -> Vec<f64> {
        let mut out = vec![f64::NAN; x.len()];
        for b in bursts {
            let r = b.start.min(x.len())..b.end.min(x.len());
            if r.len() <= shift {
                continue;
            }
            let mut f = filter(&self.band, self.fs_hz).expect("checked in new");
            // Run from the burst's first sample as the estimate's filter is: a multirate filter
            // decimates in step with its input's start, and one started `shift` samples later
            // would differ from it by its aliases.
            let mut v: Vec<f64> = std::iter::repeat_n(0.0, shift).chain(x[r.start..r.end - shift].iter().copied()).collect();
            f.process_block(&mut v);
            v[..shift].fill(f64::NAN);
            out[r].copy_from_slice(&v);
        }
        out
    }

    /// The truth an estimate is compared with: `base` shifted by the preview, through the band.
    pub fn truth(&self, base: &[f64], bursts: &[Range<usize>]) -> Vec<f64> {
        self.through_band(base, bursts, self.preview)
    }

    /// An estimate made without the band filter (the exact band-limited inverse, no preview)
    /// put through it, to be scored against [`Self::truth_unshifted`] alike.
    pub fn filtered(&self, x: &[f64], bursts: &[Range<usize>]) -> Vec<f64> {
        self.through_band(x, bursts, 0)
    }

    /// `base` through the band without the preview: the truth for [`Self::filtered`].
    pub fn truth_unshifted(&self, base: &[f64], bursts: &[Range<usize>]) -> Vec<f64> {
        self.through_band(base, bursts, 0)
    }

    /// Where the band filter lets anything through (`BandDesign::support_hz`) [Hz]. An ideal
    /// estimate scored through the filter carries what lies there, transitions included.
    pub fn support_hz(&self) -> Result<(f64, f64)> {
        let d = BandDesign::design(&self.band, self.fs_hz)
            .map_err(|e| anyhow!("the band {}–{} Hz at {} Hz: {e}", self.band.low_hz, self.band.high_hz, self.fs_hz))?;
        Ok(d.support_hz(&self.band))
    }

    /// How the scored samples were taken, for every command's output.
    pub fn describe(&self) -> String {
        let (lo, hi) = (self.band.low_hz, self.band.high_hz);
        let windows = match self.period {
            Some(p) => format!("windows of whole {} s periods", p as f64 / self.fs_hz),
            None => "windows NOT whole periods (the recording states no period)".to_string(),
        };
        let what = match self.reference {
            Reference::Base => "the true base".to_string(),
            Reference::Accelerometer { delay_s, rate_ppm } => format!(
                "the accelerometer's displacement (a check: integrated twice; its chain's delay and its clock's residual rate fitted, \
                 {:.3} ms and {rate_ppm:+.1} ppm; its ±1 % gain not)",
                1e3 * delay_s
            ),
        };
        format!(
            "against {what} shifted {} samples (the preview) and put through the same {lo}–{hi} Hz band filter \
             (its delay {} samples), {windows}",
            self.preview, self.band_delay
        )
    }
}

fn filter(band: &Band, fs_hz: f64) -> Result<BandLimit<f64>> {
    BandLimit::<f64>::new(band, fs_hz).map_err(|e| anyhow!("the band {}–{} Hz at {fs_hz} Hz: {e}", band.low_hz, band.high_hz))
}

/// Samples until all but [`START_UP_TAIL`] of the impulse response's energy has come out.
fn start_up(f: &mut BandLimit<f64>, fs_hz: f64) -> usize {
    f.reset();
    let n = ((4.0 * fs_hz) as usize).max(8 * f.delay_samples() + 64);
    let mut h = vec![0.0; n];
    h[0] = 1.0;
    f.process_block(&mut h);
    f.reset();
    let total: f64 = h.iter().map(|v| v * v).sum();
    let mut tail = total;
    for (k, v) in h.iter().enumerate() {
        if tail <= START_UP_TAIL * total {
            return k;
        }
        tail -= v * v;
    }
    n
}

/// The period [s] a recording or its estimate states: the estimate's looping
/// (`looped_period_s`), else the recording's `# excitation=… period X s`.
pub fn stated_period_s(recording: &ipmc_recording::Metadata, estimate: Option<&ipmc_recording::Metadata>) -> Option<f64> {
    let looped = estimate.and_then(|m| m.get(ipmc_recording::looping::LOOPED_PERIOD_KEY)).and_then(|v| v.parse().ok());
    looped.or_else(|| period_in(recording.get("excitation")?))
}

/// "periodic multisine, period 1 s, steady state" → 1.
fn period_in(text: &str) -> Option<f64> {
    let lower = text.to_ascii_lowercase();
    if !lower.contains("periodic") {
        return None;
    }
    let rest = &lower[lower.find("period ")? + "period ".len()..];
    let num: String = rest.chars().take_while(|c| c.is_ascii_digit() || *c == '.').collect();
    let unit = rest[num.len()..].trim_start();
    let v: f64 = num.parse().ok()?;
    if unit.starts_with("ms") {
        Some(v * 1e-3)
    } else if unit.starts_with('s') {
        Some(v)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_period_a_recording_states() {
        assert_eq!(period_in("periodic multisine, period 1 s, steady state"), Some(1.0));
        assert_eq!(period_in("periodic multisine, period 250 ms"), Some(0.25));
        assert_eq!(period_in("unknown broadband base motion (field)"), None);
    }

    /// A tone through the chain's band is the tone through the truth's: the error of an
    /// estimate that is exactly the base through the band, shifted by the preview, is nil.
    #[test]
    fn the_band_filtered_truth_is_the_estimate_of_a_perfect_chain() {
        let fs = 2000.0;
        let s = Scoring::new(&Band::DEFAULT, fs, Some(1.0)).unwrap();
        // A linear-phase FIR's response lasts twice its delay.
        assert!(s.start_up > s.band_delay && s.start_up <= 2 * s.band_delay + 1, "{s:?}");
        let n = 30_000;
        let base: Vec<f64> = (0..n).map(|k| (2.0 * std::f64::consts::PI * 37.0 * k as f64 / fs).sin()).collect();
        let mut f = BandLimit::<f64>::new(&Band::DEFAULT, fs).unwrap();
        let mut est: Vec<f64> = std::iter::repeat_n(0.0, s.preview).chain(base[..n - s.preview].iter().copied()).collect();
        f.process_block(&mut est);
        let truth = s.truth(&base, std::slice::from_ref(&(0..n)));
        let worst = (s.skip()..n).map(|k| (est[k] - truth[k]).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-12, "{worst}");
    }
}
