//! A check's own course of humidity: which hydration lag of the strip it supports.
//!
//! A check's response is measured over the whole check, and its fit gives the strip one
//! humidity. But the air moves during a check (a minute of service wanders by tenths of a %RH to
//! a whole one), and the strip's humidity follows it through its hydration lag. Measured over
//! parts of the check, with the strip's parameters, its electrode and the accelerometer where
//! the whole check's fit put them (they are one through a check), the strip's humidity per part
//! traces its course; the reading through a lag predicts a course of its own. Each lag's
//! course, shifted by the offset that fits it best (the sensor's bias, a constant), leaves the
//! parts a χ². What the calibration does not know of the strip's parameters moves every part's
//! humidity alike and leaves with the offset.
//!
//! The parts are read in the calibration's band ([`band_hz`]), not over the whole check's: the
//! course is what the strip's hygrometer follows between checks, the humidity the compensation
//! is designed at, and the compensation uses the response in the band only. Below and above it
//! the bench's laws are not what the compensation relies on, and where they follow the humidity
//! otherwise than the strip does there, those bins pull each part's humidity toward the whole
//! check's: on a shared strip the course over the whole check band came out 0.7 of the strip's
//! (in band 1.0), and the lags it favoured were twice the strip's.
//!
//! The lag is continuous; the hygrometer weighs the lags of its grid (`HYDRATION_LAGS_S`). The
//! course is read on a grid [`FINE_STEPS`] times finer, log-uniform as the hygrometer's prior,
//! and each fine lag's probability is shared between the two grid lags around it in proportion
//! to its distance from each: on a ramp a path lagged by τ trails it by rate·τ, and a mixture of
//! two paths trails by the mixture of their lags, so the grid's mixture trails as the fine lag
//! does. The parts' 1σ are the data's; where the best lag's χ² exceeds its degrees of freedom,
//! the course holds something the lags do not (the calibration's humidity scale, the path's
//! shape) and the χ² is read in units of its reduced value.

use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_core::calibration::lag_offsets::HYDRATION_LAGS_S;
use ipmc_fit::stats::autocorrelation_time;
use ipmc_recording::TimeSeries;

use super::cross_spectrum::{Measured, measure_part};
use super::response_fit::CheckFit;

/// A part's length [s]: long enough that its response (Welch segments of a second) fixes its
/// humidity to a few hundredths of a %RH, short enough that a minute's check has three.
pub const PART_S: f64 = 20.0;
/// Fine lags between two of the grid's.
pub const FINE_STEPS: usize = 8;
/// Newton steps of a part's humidity, and the difference step of its χ² [%RH].
const NEWTON_STEPS: usize = 8;
const STEP_PCT: f64 = 0.05;

/// The band the parts are read in [Hz]: the calibration's (module doc).
fn band_hz(calib: &Calibration) -> (f64, f64) {
    (calib.band.low_hz, calib.band.high_hz)
}

/// One part of a check: the strip's humidity over it with its 1σ [%RH], and its span in the
/// check's samples.
#[derive(Clone, Debug)]
pub struct Part {
    pub rh_pct: f64,
    pub sd_pct: f64,
    pub samples: (usize, usize),
}

/// The parts of check `c` of the fit `f` (its recording `s`, its whole response `whole`), read
/// in [`band_hz`], in time order; empty where the check is too short for two parts or a part's
/// response cannot be fitted.
pub fn parts(calib: &Calibration, f: &CheckFit, c: usize, s: &TimeSeries, whole: &Measured) -> Result<Vec<Part>> {
    let band = band_hz(calib);
    let Some(accel) = s.accel_mps2.as_ref() else { return Ok(vec![]) };
    let n = s.current_a.len();
    let count = (n as f64 / s.fs_hz / PART_S).floor() as usize;
    if count < 2 {
        return Ok(vec![]);
    }
    let (h0, _) = f.value(f.layout.check(c)[0]);
    let mut out = vec![];
    for p in 0..count {
        let (a, b) = (p * n / count, (p + 1) * n / count);
        let measured = measure_part(&s.current_a[a..b], &accel[a..b], s.fs_hz, band, a as f64 / s.fs_hz, whole.rate_ppm)?;
        let chi2 = |h: f64| f.part_residuals(calib, c, h, &measured, whole, count).iter().map(|r| r * r).sum::<f64>();
        let Some((h, curvature)) = newton(&chi2, h0) else { return Ok(vec![]) };
        // Against the whole check's response, what the model leaves of the strip is common and
        // drops out; the bins' 1σ are still widened as the whole check's fit widens them, by
        // any misfit beyond them and by the bins' correlation along frequency.
        let res = f.part_residuals(calib, c, h, &measured, whole, count);
        let every = |k: usize| res.iter().skip(k).step_by(2).copied().collect::<Vec<f64>>();
        let tau = 0.5 * (autocorrelation_time(&every(0)) + autocorrelation_time(&every(1)));
        let scale2 = (chi2(h) / (res.len() as f64 - 1.0)).max(1.0) * tau.max(1.0);
        out.push(Part { rh_pct: h, sd_pct: (2.0 * scale2 / curvature).sqrt(), samples: (a, b) });
    }
    Ok(out)
}

/// The minimum of a smooth χ²(h) near `start` by Newton's steps on central differences, and
/// its curvature there; None where it is not convex.
fn newton(chi2: &impl Fn(f64) -> f64, start: f64) -> Option<(f64, f64)> {
    let mut h = start;
    for _ in 0..NEWTON_STEPS {
        let (lo, mid, hi) = (chi2(h - STEP_PCT), chi2(h), chi2(h + STEP_PCT));
        let curvature = (hi - 2.0 * mid + lo) / (STEP_PCT * STEP_PCT);
        if !(curvature > 0.0) {
            return None;
        }
        let step = (-(hi - lo) / (2.0 * STEP_PCT) / curvature).clamp(-1.0, 1.0);
        h += step;
        if step.abs() < 1e-3 {
            let (lo, mid, hi) = (chi2(h - STEP_PCT), chi2(h), chi2(h + STEP_PCT));
            let curvature = (hi - 2.0 * mid + lo) / (STEP_PCT * STEP_PCT);
            return (curvature > 0.0).then_some((h, curvature));
        }
    }
    None
}

/// The fine lags: [`FINE_STEPS`] between each two of the grid's, evenly in ln [s].
pub fn fine_lags() -> Vec<f64> {
    let mut out = vec![HYDRATION_LAGS_S[0]];
    for w in HYDRATION_LAGS_S.windows(2) {
        out.extend((1..=FINE_STEPS).map(|i| w[0] * (w[1] / w[0]).powf(i as f64 / FINE_STEPS as f64)));
    }
    out
}

/// The course's χ² for one lag: per check, its parts' humidities less the path through the lag
/// averaged over each part, about their weighted mean (the offset, each check its own).
pub fn course_chi2(parts: &[Vec<Part>], through: &[Vec<f64>]) -> f64 {
    let mut chi2 = 0.0;
    for (ps, th) in parts.iter().zip(through).filter(|(p, _)| p.len() >= 2) {
        let w: Vec<f64> = ps.iter().map(|p| p.sd_pct.powi(-2)).collect();
        let d: Vec<f64> = ps.iter().zip(th).map(|(p, t)| p.rh_pct - t).collect();
        let mean = w.iter().zip(&d).map(|(w, d)| w * d).sum::<f64>() / w.iter().sum::<f64>();
        chi2 += w.iter().zip(&d).map(|(w, d)| w * (d - mean).powi(2)).sum::<f64>();
    }
    chi2
}

/// The grid lags' probabilities from the checks' courses (module doc), `through(c, lag)` the
/// reading through the strip's `lag` averaged over each part of check `c`; None where no check
/// has two parts.
pub fn lag_weights(parts: &[Vec<Part>], through: impl Fn(usize, f64) -> Vec<f64>) -> Option<GridLags> {
    let dof: usize = parts.iter().filter(|p| p.len() >= 2).map(|p| p.len() - 1).sum();
    if dof == 0 {
        return None;
    }
    let fine = fine_lags();
    let chi2: Vec<f64> = fine
        .iter()
        .map(|&lag| {
            let paths: Vec<Vec<f64>> = (0..parts.len()).map(|c| if parts[c].len() >= 2 { through(c, lag) } else { vec![] }).collect();
            course_chi2(parts, &paths)
        })
        .collect();
    Some(grid_weights(&fine, &chi2, dof))
}

/// A path per tenth of a second (`block` samples each) averaged over each part's samples.
pub fn over_parts(path: &[f64], block: usize, parts: &[Part]) -> Vec<f64> {
    parts
        .iter()
        .map(|p| {
            let a = (p.samples.0 / block).min(path.len().saturating_sub(1));
            let b = (p.samples.1 / block).clamp(a + 1, path.len());
            path[a..b].iter().sum::<f64>() / (b - a) as f64
        })
        .collect()
}

/// The course's lag on the hygrometer's grid: each grid lag's probability, and per two
/// neighbouring lags how much of their paths' spread is one lag between them
/// ([`ipmc_core::calibration::lag_offsets::LagOffsets::between`]).
#[derive(Clone, Debug, PartialEq)]
pub struct GridLags {
    pub weight: Vec<f64>,
    pub between: Vec<f64>,
}

/// The fine lags' posterior (χ² in units of the best one's reduced value where that exceeds 1;
/// one degree of freedom goes to the lag) shared onto the grid: a fine lag at x of the way from
/// one grid lag to the next gives (1 − x) of its probability to the one and x to the other, and
/// x·(1 − x) of it is the pair's mixture's own (a lag between them, no spread of the two).
pub fn grid_weights(fine: &[f64], chi2: &[f64], dof: usize) -> GridLags {
    let best = chi2.iter().copied().fold(f64::INFINITY, f64::min);
    let scale = if dof > 1 { (best / (dof - 1) as f64).max(1.0) } else { 1.0 };
    let n = HYDRATION_LAGS_S.len();
    let (mut grid, mut pair) = (vec![0.0; n], vec![0.0; n - 1]);
    for (&lag, &c) in fine.iter().zip(chi2) {
        let p = (-(c - best) / (2.0 * scale)).exp();
        let k = HYDRATION_LAGS_S.windows(2).position(|w| lag <= w[1]).unwrap_or(n - 2);
        let (lo, hi) = (HYDRATION_LAGS_S[k], HYDRATION_LAGS_S[k + 1]);
        let frac = ((lag - lo) / (hi - lo)).clamp(0.0, 1.0);
        grid[k] += p * (1.0 - frac);
        grid[k + 1] += p * frac;
        pair[k] += p * frac * (1.0 - frac);
    }
    let total: f64 = grid.iter().sum();
    let weight: Vec<f64> = grid.iter().map(|w| w / total).collect();
    let between = (0..n - 1)
        .map(|k| {
            let both = weight[k] * weight[k + 1];
            if both > 1e-12 { pair[k] / total / both } else { 0.0 }
        })
        .collect();
    GridLags { weight, between }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(rh: f64, sd: f64) -> Part {
        Part { rh_pct: rh, sd_pct: sd, samples: (0, 1) }
    }

    #[test]
    fn the_lag_whose_course_the_parts_follow_is_the_likelier() {
        // The strip rose 0.6 %RH over the check; a quick path rose 0.6, a slow one 0.2.
        let parts = vec![vec![part(70.0, 0.05), part(70.3, 0.05), part(70.6, 0.05)]];
        let quick = course_chi2(&parts, &[vec![69.0, 69.3, 69.6]]);
        let slow = course_chi2(&parts, &[vec![71.0, 71.1, 71.2]]);
        assert!(quick < 1e-9 && slow > 10.0, "{quick} {slow}");
        // Two checks add their evidence; a check of one part adds none.
        let two = course_chi2(
            &[parts[0].clone(), parts[0].clone(), vec![part(70.0, 0.01)]],
            &[vec![71.0, 71.1, 71.2], vec![71.0, 71.1, 71.2], vec![60.0]],
        );
        assert!((two - 2.0 * slow).abs() < 1e-9);
    }

    #[test]
    fn a_lag_between_the_grids_is_shared_by_its_neighbours() {
        let fine = fine_lags();
        assert_eq!(fine.len(), 1 + FINE_STEPS * (HYDRATION_LAGS_S.len() - 1));
        assert!((fine[FINE_STEPS] - HYDRATION_LAGS_S[1]).abs() < 1e-9);
        // The course decides a lag of 30 s sharply: the grid's 20 and 40 s share it equally,
        // and the mixture's lag is 30 s.
        let chi2: Vec<f64> = fine.iter().map(|l| 1e4 * (l / 30.0).ln().powi(2)).collect();
        let lags = grid_weights(&fine, &chi2, 2);
        let w = &lags.weight;
        let mean: f64 = w.iter().zip(HYDRATION_LAGS_S).map(|(w, l)| w * l).sum();
        assert!((mean - 30.0).abs() < 1.0 && w[0] < 1e-6 && w[3] < 1e-6, "{w:?}");
        // Decided between 20 and 40 s, their mixture is the lag: their spread is its own.
        assert!(lags.between[1] > 0.9 && lags.between[0] == 0.0, "{:?}", lags.between);
        // A χ² that cannot tell the lags leaves the grid near its prior.
        let flat = grid_weights(&fine, &vec![1.0; fine.len()], 2);
        assert!(flat.weight.iter().all(|&x| x > 0.1) && (flat.weight.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{flat:?}");
        // Either way, for a path linear in the lag between the grid's (on a ramp a path trails
        // by rate·τ), the grid's spread less the neighbours' `between` is the fine posterior's.
        for (c2, g) in [(&chi2, &lags), (&vec![1.0; fine.len()], &flat)] {
            // The posterior `grid_weights` reads (two degrees of freedom: χ² in units of the best's).
            let best = c2.iter().copied().fold(f64::INFINITY, f64::min);
            let p: Vec<f64> = c2.iter().map(|c| (-(c - best) / (2.0 * best.max(1.0))).exp()).collect();
            let total: f64 = p.iter().sum();
            let fine_mean = fine.iter().zip(&p).map(|(&l, p)| p * l).sum::<f64>() / total;
            let fine_var = fine.iter().zip(&p).map(|(&l, p)| p * (l - fine_mean).powi(2)).sum::<f64>() / total;
            let h = HYDRATION_LAGS_S;
            let mean: f64 = g.weight.iter().zip(&h).map(|(w, h)| w * h).sum();
            let spread: f64 = g.weight.iter().zip(&h).map(|(w, h)| w * (h - mean).powi(2)).sum();
            let own: f64 = (0..h.len() - 1).map(|k| g.between[k] * g.weight[k] * g.weight[k + 1] * (h[k] - h[k + 1]).powi(2)).sum();
            assert!((spread - own - fine_var).abs() < 1e-9 * (1.0 + fine_var), "{spread} − {own} against {fine_var}");
        }
        // A best lag whose χ² is far above its degrees of freedom is read in its units: the
        // same differences decide less.
        let misfit: Vec<f64> = chi2.iter().map(|c| c + 100.0).collect();
        let soft = grid_weights(&fine, &misfit, 2).weight;
        assert!(soft[3] > 10.0 * w[3] && soft[0] > 10.0 * w[0], "{soft:?} against {w:?}");
    }

    #[test]
    fn newton_finds_a_parabola_and_refuses_a_hump() {
        let (h, c) = newton(&|h: f64| 3.0 * (h - 71.3).powi(2) + 5.0, 70.0).unwrap();
        assert!((h - 71.3).abs() < 1e-6 && (c - 6.0).abs() < 1e-6, "{h} {c}");
        assert!(newton(&|h: f64| -(h - 71.3).powi(2), 70.0).is_none());
    }
}
