//! Humidity laws over levels: how the per-level base parameters follow humidity, and through
//! which humidity. This is where the held-out levels get their parameters (from laws fitted on
//! the other levels), and where candidates that change the humidity the sample lives at
//! (hydration lag, humidity sensor error, temperature) are fitted and scored.
//!
//! ln θ_j is regressed on the humidity x (quadratic, as the paper's laws; linear or constant when
//! there are few levels), weighted by 1/(SE² + τ_j²): SE from the level's fit and τ_j the scatter
//! between levels that no law explains (estimated once, under the plain law, and then held for
//! every candidate so that their χ² are comparable).

use crate::fits::{BASE, Theta};
use crate::input::data::{LevelData, RhHistory};
use ipmc_core::calibration::humidity_path::{HumidityPath, Hydration};
use ipmc_fit::laws::{Singular, weighted_least_squares};
use ipmc_fit::scalar::minimize_log;

/// The humidity each level's parameters follow, and optional extra regressors.
#[derive(Clone, Debug)]
pub struct Regressors {
    /// Humidity per level [%].
    pub x: Vec<f64>,
    /// Temperature minus its mean per level [K], when a temperature term is fitted (for ln Y
    /// and ln Cs only).
    pub temperature: Option<Vec<f64>>,
}

/// The laws' weighted fit: a law that cannot be determined from the training levels still
/// predicts (minimum-norm), as a held-out level needs a prediction.
fn wls(rows: &[Vec<f64>], y: &[f64], w: &[f64]) -> Option<Vec<f64>> {
    weighted_least_squares(rows, y, w, Singular::Truncate)
}

fn row(reg: &Regressors, l: usize, j: usize, degree: usize) -> Vec<f64> {
    let u = (reg.x[l] - 60.0) / 20.0;
    let mut r: Vec<f64> = (0..=degree).map(|d| u.powi(d as i32)).collect();
    if let Some(t) = &reg.temperature
        && j < 2
    {
        r.push(t[l]);
    }
    r
}

/// The calibration's law degree for component j ([`ipmc_fit::laws::law_degree`]), lowered
/// when few levels leave no degrees of freedom to judge the law by.
fn degree_for(n_train: usize, j: usize) -> usize {
    let cap = match n_train {
        0..=2 => 0,
        3..=4 => 1,
        _ => 3,
    };
    ipmc_fit::laws::law_degree(BASE[j], n_train).min(cap)
}

/// Scatter between levels per component and the weights it gives.
#[derive(Clone, Debug)]
pub struct LawWeights {
    pub tau2: [f64; 4],
}

impl LawWeights {
    /// 1/(SE² + τ²), with SE capped at 1 (a factor e): a parameter a fit leaves undetermined
    /// weighs like a poorly known one, not like none. Components not fitted (NaN) weigh 0.
    pub fn weight(&self, se: &Theta, j: usize) -> f64 {
        if se[j].is_nan() {
            return 0.0;
        }
        let v = se[j].min(1.0).powi(2) + self.tau2[j];
        if v > 0.0 { 1.0 / v } else { 0.0 }
    }

    /// τ_j² by moments from the plain law's residuals: their mean square minus the fits' own
    /// variance, iterated with the weights it gives.
    pub fn estimate(reg: &Regressors, theta: &[Theta], se: &[Theta]) -> Self {
        let mut w = LawWeights { tau2: [0.0; 4] };
        let all: Vec<usize> = (0..theta.len()).collect();
        for _ in 0..3 {
            for j in 0..4 {
                let rows: Vec<usize> = all.iter().copied().filter(|&l| !se[l][j].is_nan()).collect();
                let deg = degree_for(rows.len(), j);
                if rows.len() <= deg + 1 {
                    continue;
                }
                let x: Vec<Vec<f64>> = rows.iter().map(|&l| row(reg, l, j, deg)).collect();
                let y: Vec<f64> = rows.iter().map(|&l| theta[l][j]).collect();
                let wt: Vec<f64> = rows.iter().map(|&l| w.weight(&se[l], j)).collect();
                let Some(c) = wls(&x, &y, &wt) else { continue };
                let dof = (rows.len() - c.len()).max(1) as f64;
                let ms = rows.iter().zip(&x).map(|(&l, r)| (theta[l][j] - dot(r, &c)).powi(2)).sum::<f64>() / dof;
                let own = rows.iter().map(|&l| se[l][j].min(1.0).powi(2)).sum::<f64>() / rows.len() as f64;
                w.tau2[j] = (ms - own).max(1e-8);
            }
        }
        w
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Fits the laws on `train` and predicts θ at `at` (components without data predict NaN).
pub fn predict(reg: &Regressors, theta: &[Theta], se: &[Theta], w: &LawWeights, train: &[usize], at: usize) -> Theta {
    let mut out = [f64::NAN; 4];
    for (j, o) in out.iter_mut().enumerate() {
        let rows: Vec<usize> = train.iter().copied().filter(|&l| !se[l][j].is_nan()).collect();
        let deg = degree_for(rows.len(), j);
        let x: Vec<Vec<f64>> = rows.iter().map(|&l| row(reg, l, j, deg)).collect();
        let y: Vec<f64> = rows.iter().map(|&l| theta[l][j]).collect();
        let wt: Vec<f64> = rows.iter().map(|&l| w.weight(&se[l], j)).collect();
        if let Some(c) = wls(&x, &y, &wt) {
            *o = dot(&row(reg, at, j, deg), &c);
        }
    }
    out
}

/// Weighted χ² of the laws fitted on all levels, and their parameter count.
pub fn chi2(reg: &Regressors, theta: &[Theta], se: &[Theta], w: &LawWeights) -> (f64, usize) {
    let mut total = 0.0;
    let mut k = 0;
    for j in 0..4 {
        let rows: Vec<usize> = (0..theta.len()).filter(|&l| !se[l][j].is_nan()).collect();
        let deg = degree_for(rows.len(), j);
        let x: Vec<Vec<f64>> = rows.iter().map(|&l| row(reg, l, j, deg)).collect();
        let y: Vec<f64> = rows.iter().map(|&l| theta[l][j]).collect();
        let wt: Vec<f64> = rows.iter().map(|&l| w.weight(&se[l], j)).collect();
        if let Some(c) = wls(&x, &y, &wt) {
            k += c.len();
            total += rows.iter().zip(&x).zip(&wt).map(|((&l, r), wi)| wi * (theta[l][j] - dot(r, &c)).powi(2)).sum::<f64>();
        }
    }
    (total, k)
}

/// RH where the sensor-error candidate pivots its gain [%]: the middle of the range, so that
/// offset and gain are nearly uncorrelated.
pub const SENSOR_PIVOT_PCT: f64 = 60.0;

/// RH_true = RH_read + o + (g − 1)(RH_read − 60), as the calibration's sensor correction
/// (RH_true = gain·RH_read + offset_pct).
pub fn sensor_correction(offset: f64, gain: f64) -> HumidityPath {
    HumidityPath { gain, offset_pct: offset - (gain - 1.0) * SENSOR_PIVOT_PCT, ..HumidityPath::NONE }
}

pub fn mapped_rh(read: f64, offset: f64, gain: f64) -> f64 {
    sensor_correction(offset, gain).correct(read)
}

/// The polymer's humidity behind a first-order lag τ [s] of the readings, averaged over each
/// level's time span. The chamber is taken to move to each reading right after the one before
/// (a bench sets the next level when a sweep ends and then waits for it): interpolating
/// linearly across the wait instead would put the change half a wait late and fit a lag a
/// quarter of the true one for 600 s waits. The lag starts in equilibrium with the first
/// reading.
pub fn lagged_rh(levels: &[LevelData], histories: &[RhHistory], tau_s: f64) -> Vec<f64> {
    let lagged: Vec<Vec<f64>> = histories
        .iter()
        .enumerate()
        .map(|(session, h)| {
            // The strip's model of the calibration's humidity path, settled at the first reading.
            let mut strip = Hydration::<f64>::new(&HumidityPath { tau_wet_s: tau_s, tau_dry_s: tau_s, ..HumidityPath::NONE });
            let mut last: Option<f64> = None;
            // A level is one chamber humidity: its mean reading, not the first noisy one, stands
            // for the whole wait before it (the wait is most of the lag's drive). The session's
            // levels' spans, in the levels' order (the first level whose span holds a reading
            // is its level).
            let spans: Vec<(f64, (f64, f64))> =
                levels.iter().filter(|l| l.session == session).filter_map(|l| l.time_span.map(|s| (l.rh_pct, s))).collect();
            h.t_s
                .iter()
                .zip(&h.rh_pct)
                .map(|(&t, &rh)| {
                    let in_level = spans.iter().find(|(_, (t0, t1))| t >= *t0 && t <= *t1);
                    let rh = in_level.map_or(rh, |(level_rh, _)| *level_rh);
                    let dt = last.map_or(0.0, |l| t - l);
                    last = Some(t);
                    strip.update(rh, dt)
                })
                .collect()
        })
        .collect();
    levels
        .iter()
        .map(|l| {
            let (Some((t0, t1)), Some(h)) = (l.time_span, histories.get(l.session)) else { return l.rh_pct };
            let vals: Vec<f64> = h.t_s.iter().zip(&lagged[l.session]).filter(|(t, _)| **t >= t0 && **t <= t1).map(|(_, v)| *v).collect();
            if vals.is_empty() { l.rh_pct } else { vals.iter().sum::<f64>() / vals.len() as f64 }
        })
        .collect()
}

/// In-sample predictions of the laws fitted on all levels (weights re-estimated for these
/// regressors) and the laws' parameter count.
pub fn fitted(reg: &Regressors, theta: &[Theta], se: &[Theta]) -> (Vec<Theta>, usize) {
    let w = LawWeights::estimate(reg, theta, se);
    let all: Vec<usize> = (0..theta.len()).collect();
    let pred = (0..theta.len()).map(|l| predict(reg, theta, se, &w, &all, l)).collect();
    (pred, chi2(reg, theta, se, &w).1)
}

/// −2 log-likelihood (up to a constant) of the levels' θ around predictions, each component
/// with its own scatter between levels τ_j² estimated from these residuals, and the humidity
/// read error of each level as a random effect shared by the four: a level read σ_h off sits
/// where every parameter's law says it would at the true humidity, so its residuals move
/// together along `grad` (∂θ/∂RH of the calibration at the level). v = SE² + τ_j² alone
/// would count such coherent scatter as independent evidence four times over, and a
/// remap (an offset, a lag) would be rewarded for fitting what is only the sensor's noise.
/// σ_h² is profiled (0 included), τ_j² by moments given it. Unlike a χ² at fixed weights, it
/// lets a model that explains the scatter (temperature, hydration) show it.
pub fn nll(pred: &[Theta], theta: &[Theta], se: &[Theta], grad: &[Theta]) -> f64 {
    nll_per_level(pred, theta, se, grad).iter().sum()
}

/// [`nll`] level by level (its terms at the profiled read variance): a level's Σ_l is its own,
/// so the likelihood is a sum over levels.
pub fn nll_per_level(pred: &[Theta], theta: &[Theta], se: &[Theta], grad: &[Theta]) -> Vec<f64> {
    let terms = Terms::of(pred, theta, se, grad);
    let at = |s2: f64| terms.nll_at(s2).iter().sum::<f64>();
    let (s2, best) = minimize_log(at, READ_VARIANCE_RANGE.0, READ_VARIANCE_RANGE.1);
    terms.nll_at(if at(0.0) <= best { 0.0 } else { s2 })
}

/// Where the per-level humidity read variance is profiled [%RH²]: 0.03–5 %RH standard
/// deviation, from a sensor's repeatability to the ±3.5 %RH an HTS221 is specified to.
const READ_VARIANCE_RANGE: (f64, f64) = (1e-3, 25.0);

/// What [`nll`] needs of the levels that does not depend on the read variance, computed once
/// for its profile over it.
struct Terms<'a> {
    grad: &'a [Theta],
    /// Per level and component: whether θ_j takes part, its misfit and its own variance.
    valid: Vec<[bool; 4]>,
    misfit: Vec<Theta>,
    own: Vec<Theta>,
    /// Per component: the levels that hold θ_j, their mean square misfit's sum, own variances'
    /// sum and read gradients² sum.
    sums: [(usize, f64, f64, f64); 4],
}

impl<'a> Terms<'a> {
    fn of(pred: &[Theta], theta: &[Theta], se: &[Theta], grad: &'a [Theta]) -> Self {
        let valid: Vec<[bool; 4]> =
            (0..theta.len()).map(|l| std::array::from_fn(|j| !se[l][j].is_nan() && pred[l][j].is_finite())).collect();
        let misfit: Vec<Theta> = (0..theta.len()).map(|l| std::array::from_fn(|j| theta[l][j] - pred[l][j])).collect();
        let own: Vec<Theta> = se.iter().map(|s| s.map(|v| v.min(1.0).powi(2))).collect();
        let sums = std::array::from_fn(|j| {
            // Mean square misfit, own variance and read gradient² over the levels that hold θ_j.
            let (mut n, mut ms, mut own_mean, mut g2) = (0usize, 0.0, 0.0, 0.0);
            for l in (0..theta.len()).filter(|&l| valid[l][j]) {
                n += 1;
                ms += misfit[l][j].powi(2);
                own_mean += own[l][j];
                g2 += grad[l][j].powi(2);
            }
            (n, ms, own_mean, g2)
        });
        Terms { grad, valid, misfit, own, sums }
    }

    /// [`nll`] at a read variance `s2` [%RH²], level by level.
    fn nll_at(&self, s2: f64) -> Vec<f64> {
        let mut tau2 = [0.0; 4];
        for (t, &(n, ms, own_mean, g2)) in tau2.iter_mut().zip(&self.sums) {
            if n > 0 {
                *t = ((ms - own_mean - s2 * g2) / n as f64).max(1e-8);
            }
        }
        let mut total = Vec::with_capacity(self.misfit.len());
        for l in 0..self.misfit.len() {
            // Σ = D + s2·g·gᵀ: Sherman–Morrison for the quadratic form and the determinant (one
            // logarithm of the product: this runs inside every profiled and nested fit).
            let (mut q, mut det, mut rg, mut gg) = (0.0, 1.0, 0.0, 0.0);
            for j in (0..4).filter(|&j| self.valid[l][j]) {
                let d = self.own[l][j] + tau2[j];
                let r = self.misfit[l][j];
                q += r * r / d;
                det *= d;
                rg += r * self.grad[l][j] / d;
                gg += self.grad[l][j].powi(2) / d;
            }
            total.push(q - s2 * rg * rg / (1.0 + s2 * gg) + (det * (1.0 + s2 * gg)).ln());
        }
        total
    }
}

/// ∂θ/∂RH of the calibration at each humidity [per %RH]: the direction a level's parameters
/// move in when its humidity is read wrong.
pub fn read_gradient(calib: &ipmc_core::Calibration, rh: &[f64]) -> Vec<Theta> {
    const STEP: f64 = 0.5;
    rh.iter()
        .map(|&h| {
            let (a, b) = (crate::fits::calibration_theta(calib, h + STEP), crate::fits::calibration_theta(calib, h - STEP));
            std::array::from_fn(|j| (a[j] - b[j]) / (2.0 * STEP))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_follows_a_step_exponentially() {
        let t: Vec<f64> = (0..=200).map(|i| i as f64).collect();
        let rh: Vec<f64> = t.iter().map(|&t| if t < 10.0 { 40.0 } else { 60.0 }).collect();
        let hist = RhHistory { t_s: t.clone(), rh_pct: rh };
        let lvl = |a: f64, b: f64| LevelData {
            session: 0,
            rh_pct: 60.0,
            temp_c: None,
            time_s: Some((a + b) / 2.0),
            time_span: Some((a, b)),
            revisit_of: None,
            freqs: vec![],
            tip: vec![],
            current: vec![],
            kappa_e: None,
        };
        let got = lagged_rh(&[lvl(60.0, 60.0)], &[hist], 50.0)[0];
        // the chamber steps right after the last reading at 40 %, at 9 s
        let want = 60.0 - 20.0 * (-(60.0 - 9.0) / 50.0f64).exp();
        assert!((got - want).abs() < 0.1, "{got} vs {want}");
    }

    /// Levels read off by their own error each sit where all four laws put that humidity: the
    /// likelihood that knows the four move together along the gradient explains them far
    /// better than one that takes each parameter's scatter as independent.
    #[test]
    fn a_levels_read_error_moves_its_parameters_together() {
        let n = 24;
        // Deterministic spread of read errors in ±2 %RH and a small independent scatter.
        let err: Vec<f64> = (0..n).map(|l| 2.0 * (((l * 7919) % 97) as f64 / 48.0 - 1.0)).collect();
        let grad: Vec<Theta> = (0..n).map(|l| [0.01, 0.004, -0.02, 0.11 + 0.001 * l as f64]).collect();
        let theta: Vec<Theta> =
            (0..n).map(|l| std::array::from_fn(|j| grad[l][j] * err[l] + 1e-3 * ((((l + 3 * j) * 31) % 11) as f64 / 5.0 - 1.0))).collect();
        let (pred, se) = (vec![[0.0; 4]; n], vec![[1e-3; 4]; n]);
        let coherent = nll(&pred, &theta, &se, &grad);
        let independent = nll(&pred, &theta, &se, &vec![[0.0; 4]; n]);
        assert!(coherent < independent - 50.0, "{coherent} vs {independent}");
    }

    #[test]
    fn laws_predict_a_quadratic_exactly() {
        let x: Vec<f64> = (0..8).map(|i| 40.0 + 5.0 * i as f64).collect();
        let theta: Vec<Theta> = x.iter().map(|&v| [1.0 + 0.01 * v, 2.0 - 1e-4 * v * v, 0.0, -30.0 + 0.05 * v]).collect();
        let se = vec![[0.01; 4]; x.len()];
        let reg = Regressors { x, temperature: None };
        let w = LawWeights::estimate(&reg, &theta, &se);
        let train: Vec<usize> = (0..8).filter(|&l| l != 3).collect();
        let p = predict(&reg, &theta, &se, &w, &train, 3);
        for j in 0..4 {
            assert!((p[j] - theta[3][j]).abs() < 1e-9);
        }
    }
}
