//! The figures of one estimate against its truth ([`super::Scoring::truth`]): per window, per
//! burst, pooled over the run and as an rms over the bursts (levels). Every figure is
//! rms(estimate − truth) / rms(truth) over the samples it covers, so the windows' figures pool
//! into the burst's and the bursts' into the run's.

use super::Scoring;
use std::ops::Range;

/// Sums over some scored samples.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sums {
    /// Σ(estimate − truth)².
    pub error: f64,
    /// Σ truth².
    pub truth: f64,
    /// Σ estimate².
    pub estimate: f64,
    pub samples: usize,
}

impl Sums {
    fn add(&mut self, o: &Sums) {
        self.error += o.error;
        self.truth += o.truth;
        self.estimate += o.estimate;
        self.samples += o.samples;
    }
    /// rms(estimate − truth) / rms(truth) (a fraction).
    pub fn error(&self) -> f64 {
        (self.error / self.truth).sqrt()
    }
    /// rms(estimate) / rms(truth).
    pub fn estimate_over_truth(&self) -> f64 {
        (self.estimate / self.truth).sqrt()
    }
}

/// One burst's scored windows.
#[derive(Clone, Debug)]
pub struct BurstScore {
    pub burst: Range<usize>,
    pub windows: Vec<(Range<usize>, Sums)>,
    pub whole: Sums,
}

/// One estimate's figures.
#[derive(Clone, Debug)]
pub struct Score {
    pub bursts: Vec<BurstScore>,
    pub pooled: Sums,
}

impl Score {
    /// rms over the bursts of each burst's figure: the "rms over the levels".
    pub fn rms_over_bursts(&self) -> f64 {
        let v: Vec<f64> = self.bursts.iter().map(|b| b.whole.error()).collect();
        (v.iter().map(|e| e * e).sum::<f64>() / v.len().max(1) as f64).sqrt()
    }
}

impl Scoring {
    /// The scored windows of a burst: from [`Self::skip`] on, `window` samples each (rounded to
    /// whole periods where the period is known; one window of the rest where `window` is None),
    /// only whole windows.
    pub fn windows(&self, burst: Range<usize>, window: Option<usize>) -> Vec<Range<usize>> {
        let from = burst.start + self.skip();
        if from >= burst.end {
            return vec![];
        }
        let len = burst.end - from;
        let win = match (window, self.period) {
            (Some(w), Some(p)) => (w as f64 / p as f64).round().max(1.0) as usize * p,
            (Some(w), None) => w.max(1),
            (None, Some(p)) => len / p * p,
            (None, None) => len,
        };
        if win == 0 {
            return vec![];
        }
        (0..len / win).map(|k| from + k * win..from + (k + 1) * win).collect()
    }

    /// `est` against `truth` (the same length, aligned sample by sample) in each burst's windows.
    pub fn score<E: Copy + Into<f64>>(&self, est: &[E], truth: &[f64], bursts: &[Range<usize>], window: Option<usize>) -> Score {
        let n = est.len().min(truth.len());
        let mut pooled = Sums::default();
        let mut out = vec![];
        for b in bursts {
            let b = b.start.min(n)..b.end.min(n);
            let mut whole = Sums::default();
            let mut windows = vec![];
            for w in self.windows(b.clone(), window) {
                let mut s = Sums::default();
                // A sample whose reference is unknown (NaN: a check's accelerometer record
                // interpolated past its end) is not scored.
                for k in w.clone().filter(|&k| !truth[k].is_nan()) {
                    let (e, t) = (est[k].into(), truth[k]);
                    s.error += (e - t).powi(2);
                    s.truth += t * t;
                    s.estimate += e * e;
                    s.samples += 1;
                }
                whole.add(&s);
                windows.push((w, s));
            }
            if whole.samples > 0 && whole.truth > 0.0 {
                pooled.add(&whole);
                out.push(BurstScore { burst: b, windows, whole });
            }
        }
        Score { bursts: out, pooled }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::band::Band;

    /// Windows pool into the burst's figure, and an estimate 3 % too large scores 3 %.
    #[test]
    fn windows_pool_into_the_figure() {
        let fs = 2000.0;
        let s = Scoring::new(&Band::DEFAULT, fs, Some(0.5)).unwrap();
        let n = 24_000;
        let base: Vec<f64> = (0..n).map(|k| (2.0 * std::f64::consts::PI * 40.0 * k as f64 / fs).sin()).collect();
        let truth = s.truth(&base, std::slice::from_ref(&(0..n)));
        let est: Vec<f64> = truth.iter().map(|t| 1.03 * t).collect();
        let sc = s.score(&est, &truth, std::slice::from_ref(&(0..n)), Some(500));
        let b = &sc.bursts[0];
        assert!(b.windows.iter().all(|(w, _)| w.len() == 1000), "rounded to whole periods");
        assert!((sc.pooled.error() - 0.03).abs() < 1e-9, "{}", sc.pooled.error());
        let e2: f64 = b.windows.iter().map(|(_, w)| w.error).sum();
        assert!((e2 - b.whole.error).abs() < 1e-9);
    }
}
