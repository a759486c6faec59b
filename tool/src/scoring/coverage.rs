//! Whether the stated error bars hold: the actual error of an estimate (the one definition,
//! [`super::Scoring`]) against the expected error (1σ) it was stated with, window by window and
//! burst by burst. Honest bars contain the actual error about 68 % of the time.

use super::{Score, Scoring};

/// One scored stretch: the stated 1σ (rms of the per-sample `rel_err` over it) and the actual
/// relative error, as fractions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scored {
    pub stated: f64,
    pub actual: f64,
}

impl Scored {
    pub fn covered(&self) -> bool {
        self.actual <= self.stated
    }
}

/// One burst: its humidity reading, the whole burst scored, and its windows.
#[derive(Clone, Debug, PartialEq)]
pub struct Burst {
    pub rh_pct: f64,
    pub whole: Scored,
    pub windows: Vec<Scored>,
}

/// Per burst of `whole` (each burst scored as a whole, as the run's figure pools it), its
/// windows from `windowed` (the length coverage is counted over), each with its stated 1σ: the
/// burst's actual error is the figure the run's summary pools, over the same samples.
pub fn stated(windowed: &Score, whole: &Score, rel_err: &[f32], rh: &[f64]) -> Vec<Burst> {
    let ms = |r: &std::ops::Range<usize>| rel_err[r.clone()].iter().map(|&v| (v as f64).powi(2)).sum::<f64>() / r.len().max(1) as f64;
    whole
        .bursts
        .iter()
        .map(|b| {
            let windows: Vec<Scored> = windowed
                .bursts
                .iter()
                .filter(|w| w.burst == b.burst)
                .flat_map(|w| &w.windows)
                .map(|(w, s)| Scored { stated: ms(w).sqrt(), actual: s.error() })
                .collect();
            let from = b.windows.first().map_or(b.burst.start, |w| w.0.start);
            let to = b.windows.last().map_or(b.burst.end, |w| w.0.end);
            Burst {
                rh_pct: rh[from..to].iter().sum::<f64>() / (to - from).max(1) as f64,
                whole: Scored { stated: ms(&(from..to)).sqrt(), actual: b.whole.error() },
                windows,
            }
        })
        .collect()
}

/// The estimate scored in windows of `window_s` (whole periods where the recording states its
/// period), each with its stated 1σ, and each burst as a whole.
pub fn score(
    scoring: &Scoring,
    est: &[f32],
    truth: &[f64],
    rel_err: &[f32],
    rh: &[f64],
    bursts: &[std::ops::Range<usize>],
    window_s: f64,
) -> Vec<Burst> {
    let n = est.len().min(rel_err.len());
    let window = ((window_s * scoring.fs_hz).round() as usize).max(1);
    let windowed = scoring.score(&est[..n], truth, bursts, Some(window));
    stated(&windowed, &scoring.score(&est[..n], truth, bursts, None), rel_err, rh)
}

/// (covered, total) over every window of every burst, and over the bursts as wholes.
pub fn coverage(bursts: &[Burst]) -> ((usize, usize), (usize, usize)) {
    let windows = bursts.iter().flat_map(|b| &b.windows);
    let w = (windows.clone().filter(|s| s.covered()).count(), windows.count());
    let b = (bursts.iter().filter(|b| b.whole.covered()).count(), bursts.len());
    (w, b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::band::Band;

    /// An estimate off by a known gain in each burst, stated with a known error bar: the
    /// windows and the bursts come out covered exactly where the gain error is within the bar.
    #[test]
    fn counts_what_the_bars_contain() {
        let fs = 1000.0;
        let s = Scoring::new(&Band::DEFAULT, fs, Some(1.0)).unwrap();
        let len = s.skip() + 3 * 1000 + 500;
        let bursts = [0..len, len..2 * len];
        let base: Vec<f64> = (0..2 * len).map(|k| (2.0 * std::f64::consts::PI * 40.0 * k as f64 / fs).sin()).collect();
        let truth = s.truth(&base, &bursts);
        // 3 % too large in the first burst, 10 % in the second, both stated as 5 %.
        let est: Vec<f32> = (0..2 * len).map(|k| (truth[k] * if k < len { 1.03 } else { 1.10 }) as f32).collect();
        let rel_err = vec![0.05f32; 2 * len];
        let rh = vec![50.0; 2 * len];
        let b = score(&s, &est, &truth, &rel_err, &rh, &bursts, 1.0);
        assert_eq!(b.len(), 2);
        assert!((b[0].whole.actual - 0.03).abs() < 2e-3 && (b[1].whole.actual - 0.10).abs() < 5e-3, "{b:?}");
        assert!((b[0].whole.stated - 0.05).abs() < 1e-6);
        let ((wc, wn), (bc, bn)) = coverage(&b);
        assert_eq!((bc, bn), (1, 2));
        assert_eq!(wn, 2 * 3, "3 whole periods after the settling, per burst");
        assert_eq!(wc, 3);
    }

    /// A burst whose scored stretch is no whole number of windows: its actual error is the
    /// figure over all of it, as the run's summary pools it (the windows' sum left its tail
    /// out, and the table printed another figure than the summary's line).
    #[test]
    fn a_bursts_figure_is_the_summarys() {
        let fs = 1000.0;
        let s = Scoring::new(&Band::DEFAULT, fs, None).unwrap();
        let len = s.skip() + 2 * 1000 + 700;
        let whole = 0..len;
        let bursts = std::slice::from_ref(&whole);
        let base: Vec<f64> = (0..len).map(|k| (2.0 * std::f64::consts::PI * 40.0 * k as f64 / fs).sin()).collect();
        let truth = s.truth(&base, bursts);
        // 2 % too large, then 12 % in the tail that no whole window of 1 s holds.
        let est: Vec<f32> = (0..len).map(|k| (truth[k] * if k < len - 700 { 1.02 } else { 1.12 }) as f32).collect();
        let b = score(&s, &est, &truth, &vec![0.05f32; len], &vec![50.0; len], bursts, 1.0);
        let summary = s.score(&est, &truth, bursts, None).pooled.error();
        assert_eq!(b[0].windows.len(), 2);
        assert!((b[0].whole.actual - summary).abs() < 1e-12, "{} against {summary}", b[0].whole.actual);
        assert!(summary > 0.05, "the tail counts: {summary}");
    }
}
