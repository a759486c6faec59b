//! What the strip's own levels say, kept: smooth humidity laws plus the strip's departures from
//! them, where the levels show departures beyond their errors (the calibration's `[departures]`
//! table), and what remains unknown after both (its `[uncertainty]`).
//!
//! The statistics. Per level i, the fit gives θᵢ = ln(Y, Cs, Ca, d) with its covariance Σᵢ
//! (standard errors and correlations, the Cs–Ca one strong when the recording holds one bending
//! mode). The level was read at humidity rᵢ; the strip was at xᵢ = rᵢ − eᵢ, the bench sensor's
//! error eᵢ ~ N(0, σₑ²) a random effect of the level (a down sweep revisits a setpoint with
//! another one). Each parameter k follows
//!
//!   θₖ(x) = ln baseₖ(x) + pₖ(x) + gₖ(x),
//!
//! the base calibration's law shape times a smooth correction pₖ (a polynomial in RH, the
//! "law") and the strip's own departure gₖ, a zero-mean Gaussian process over humidity with
//! Matérn-3/2 covariance Aₖ²(1 + √3|Δ|/ℓₖ)e^(−√3|Δ|/ℓₖ) (departures that are continuous but not
//! smooth; the four processes independent). Linearized in the read error,
//! θᵢ = θ(rᵢ) − sᵢeᵢ + εᵢ with sᵢ = ∂θ/∂x the law's slope, so each level's four values carry the
//! noise Σᵢ + σₑ²·sᵢsᵢᵀ: the read error moves all four along their laws together, which is how
//! the levels tell it from the strip's departures (d, steep at high humidity, says most).
//!
//! Aₖ, ℓₖ (and σₑ when the reading's uncertainty is not given) maximize the restricted (REML)
//! marginal likelihood of all levels' values, the polynomial coefficients integrated out; then
//! the law is the generalized-least-squares polynomial and the departure the posterior mean of
//! gₖ. Where the data show no departure beyond their errors, Aₖ → 0 and the law alone remains;
//! where a level is well determined and its neighbours disagree with the law, gₖ follows it
//! within a length ℓₖ. The posterior variance of θₖ (departure and law coefficients both) is
//! what is left unknown: its rms over the calibrated range becomes `[uncertainty]`. No constant
//! here is set from any recording: the hyperparameters are the data's.

use crate::identify::LevelFit;
use crate::stats::{chi2_tail, nelder_mead};
use ipmc_core::departures::{DEPARTING, MAX_DEPARTURE_POINTS, MAX_LN_DEPARTURE};
use ipmc_core::{Calibration, ParamName};
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// Degree of the smooth correction pₖ of each law (quadratic, as the paper's laws).
pub const CORRECTION_DEGREE: usize = 2;
/// Bounds of the hyperparameters: a departure's amplitude (in ln), its length [%RH] and the
/// bench reading's standard error [%RH]. The bounds only keep the search finite: the lengths
/// span from a tenth of the closest setpoints to beyond any humidity range.
const AMPLITUDE: (f64, f64) = (1e-5, 2.0);
const LENGTH_PCT: (f64, f64) = (0.2, 300.0);
const RH_SD_PCT: (f64, f64) = (1e-3, 5.0);
/// RH step [%] of the laws' slopes.
const SLOPE_STEP_PCT: f64 = 0.05;

/// One level as the model takes it: ln of Y, Cs, Ca and d (order of [`DEPARTING`]; `None`
/// where the level did not determine the parameter) and their covariance.
#[derive(Clone, Debug)]
pub struct LevelTheta {
    pub rh_pct: f64,
    pub ln: [Option<f64>; 4],
    pub cov: [[f64; 4]; 4],
}

impl LevelTheta {
    /// The level's estimates in ln, their covariance from the fit's (relative: cov/(pₐp_b)).
    pub fn of(fit: &LevelFit) -> LevelTheta {
        let idx: [Option<usize>; 4] = DEPARTING.map(|p| fit.fit.index(p.as_str()));
        let mut ln = [None; 4];
        let mut cov = [[0.0; 4]; 4];
        for a in 0..4 {
            let Some(i) = idx[a] else { continue };
            let (v, se) = (fit.fit.estimates[i], fit.fit.std_errors[i]);
            if !(v > 0.0 && se.is_finite() && se > 0.0) {
                continue;
            }
            ln[a] = Some(v.ln());
            for b in 0..4 {
                if let Some(j) = idx[b] {
                    cov[a][b] = fit.fit.covariance[(i, j)] / (v * fit.fit.estimates[j]);
                }
            }
        }
        LevelTheta { rh_pct: fit.rh_pct, ln, cov }
    }
}

/// The hyperparameters: per parameter of [`DEPARTING`] the departure's amplitude (0: none) and
/// length, and the bench reading's standard error.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Hyper {
    pub amplitude: [f64; 4],
    pub length_pct: [f64; 4],
    pub rh_sd_pct: f64,
    /// Whether `rh_sd_pct` was estimated (true) or given.
    pub rh_sd_estimated: bool,
}

/// How far the smooth law alone (no departures) misses its levels: χ² against the levels'
/// errors and the reading's, its degrees of freedom and the chance of a χ² that large if the
/// law held.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LawTest {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
}

/// Why no model could be made.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelError {
    /// The base law is not positive at a level's humidity (its ln is the model's offset).
    BaseNotPositive { param: ParamName, rh_pct: f64 },
    /// The levels' covariance is not positive definite even without departures.
    Singular,
}

impl core::fmt::Display for ModelError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            ModelError::BaseNotPositive { param, rh_pct } => {
                write!(f, "the base calibration's law of {} is not positive at {rh_pct:.1} %RH", param.as_str())
            }
            ModelError::Singular => write!(f, "the levels' errors are singular: no law can be fitted"),
        }
    }
}

impl std::error::Error for ModelError {}

fn matern32(d: f64, amplitude: f64, length: f64) -> f64 {
    let a = 3f64.sqrt() * d.abs() / length;
    amplitude * amplitude * (1.0 + a) * (-a).exp()
}

/// The fitted model: laws, departures and what remains.
#[derive(Clone, Debug)]
pub struct StripModel {
    base: Calibration,
    pub hyper: Hyper,
    /// Per parameter: the correction's degree (None: no level determined it), whether it has a
    /// departure process.
    pub degree: [Option<usize>; 4],
    pub has_departures: [bool; 4],
    pub law_tests: [Option<LawTest>; 4],
    /// Levels per parameter.
    pub levels: [usize; 4],
    center: f64,
    half: f64,
    /// Observations: (parameter, reading) in the order of the vectors below.
    obs: Vec<(usize, f64)>,
    /// Column of each parameter's first correction coefficient.
    col: [usize; 4],
    beta: DVector<f64>,
    alpha: DVector<f64>,
    chol: Cholesky<f64, Dyn>,
    h: DMatrix<f64>,
    /// (HᵀC⁻¹H)⁻¹
    hch_inv: DMatrix<f64>,
}

/// The problem at fixed slopes.
struct Problem<'a> {
    levels: &'a [LevelTheta],
    /// (parameter, level)
    obs: Vec<(usize, usize)>,
    y: DVector<f64>,
    h: DMatrix<f64>,
    slopes: Vec<[f64; 4]>,
    gp: [bool; 4],
    col: [usize; 4],
}

impl Problem<'_> {
    fn covariance(&self, amplitude: &[f64; 4], length: &[f64; 4], rh_sd: f64) -> DMatrix<f64> {
        let n = self.obs.len();
        DMatrix::from_fn(n, n, |a, b| {
            let ((ka, ia), (kb, ib)) = (self.obs[a], self.obs[b]);
            let mut c = 0.0;
            if ka == kb && self.gp[ka] {
                c += matern32(self.levels[ia].rh_pct - self.levels[ib].rh_pct, amplitude[ka], length[ka]);
            }
            if ia == ib {
                c += self.levels[ia].cov[ka][kb] + rh_sd * rh_sd * self.slopes[ia][ka] * self.slopes[ia][kb];
            }
            c
        })
    }

    /// −(restricted log likelihood) up to a constant, and the pieces of the posterior.
    fn reml(&self, c: DMatrix<f64>) -> Option<(f64, Cholesky<f64, Dyn>, DVector<f64>, DMatrix<f64>)> {
        let chol = c.cholesky()?;
        let l = chol.l();
        let logdet: f64 = 2.0 * l.diagonal().iter().map(|d| d.ln()).sum::<f64>();
        let z = l.solve_lower_triangular(&self.h)?;
        let w = l.solve_lower_triangular(&self.y)?;
        let hch = z.transpose() * &z;
        let hch_chol = hch.clone().cholesky()?;
        let logdet_h: f64 = 2.0 * hch_chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
        let beta = hch_chol.solve(&(z.transpose() * &w));
        let r = &w - &z * &beta;
        let v = 0.5 * (logdet + logdet_h + r.dot(&r));
        v.is_finite().then(|| (v, chol, beta, hch_chol.inverse()))
    }
}

/// The polynomial basis of a parameter's correction at `x`.
fn basis(x: f64, center: f64, half: f64, degree: usize) -> impl Iterator<Item = f64> {
    (0..=degree).map(move |j| ((x - center) / half).powi(j as i32))
}

fn ln_base(base: &Calibration, k: usize, rh: f64) -> f64 {
    let law = base.law(DEPARTING[k]).expect("departing parameters have laws");
    let v: f64 = law.eval(rh);
    v.ln()
}

impl StripModel {
    /// Fits the model to `levels` on the shape of `base`'s laws. `rh_sd_pct`: the bench
    /// reading's standard error when known; estimated from the levels otherwise.
    pub fn fit(base: &Calibration, levels: &[LevelTheta], rh_sd_pct: Option<f64>) -> Result<StripModel, ModelError> {
        let obs: Vec<(usize, usize)> = (0..4).flat_map(|k| (0..levels.len()).filter(move |&i| levels[i].ln[k].is_some()).map(move |i| (k, i))).collect();
        let count: [usize; 4] = core::array::from_fn(|k| obs.iter().filter(|o| o.0 == k).count());
        // A correction of degree q needs q + 1 levels; a departure process some to spare.
        let degree: [Option<usize>; 4] = count.map(|n| (n > 0).then(|| CORRECTION_DEGREE.min(n - 1)));
        let gp: [bool; 4] = core::array::from_fn(|k| degree[k].is_some_and(|q| count[k] >= q + 3));
        let (lo, hi) = levels.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), l| (a.min(l.rh_pct), b.max(l.rh_pct)));
        let center = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(1.0);
        let mut col = [0usize; 4];
        let mut ncol = 0;
        for k in 0..4 {
            col[k] = ncol;
            ncol += degree[k].map_or(0, |q| q + 1);
        }
        let mut y = DVector::zeros(obs.len());
        let mut h = DMatrix::zeros(obs.len(), ncol);
        for (a, &(k, i)) in obs.iter().enumerate() {
            let r = levels[i].rh_pct;
            let offset = ln_base(base, k, r);
            if !offset.is_finite() {
                return Err(ModelError::BaseNotPositive { param: DEPARTING[k], rh_pct: r });
            }
            y[a] = levels[i].ln[k].expect("observed") - offset;
            for (j, v) in basis(r, center, half, degree[k].expect("observed")).enumerate() {
                h[(a, col[k] + j)] = v;
            }
        }
        let mut problem = Problem { levels, obs: obs.clone(), y, h, slopes: vec![[0.0; 4]; levels.len()], gp, col };
        let slope_of = |beta: &DVector<f64>, k: usize, x: f64| -> f64 {
            let at = |x: f64| {
                ln_base(base, k, x) + degree[k].map_or(0.0, |q| basis(x, center, half, q).enumerate().map(|(j, b)| b * beta[col[k] + j]).sum())
            };
            (at(x + SLOPE_STEP_PCT) - at(x - SLOPE_STEP_PCT)) / (2.0 * SLOPE_STEP_PCT)
        };
        // The hyperparameters as the search sees them: ln of each free one.
        let estimate_sd = rh_sd_pct.is_none();
        let unpack = |u: &[f64]| -> ([f64; 4], [f64; 4], f64) {
            let mut amplitude = [0.0; 4];
            let mut length = [1.0; 4];
            let mut m = 0;
            for k in 0..4 {
                if gp[k] {
                    amplitude[k] = u[m].exp().clamp(AMPLITUDE.0, AMPLITUDE.1);
                    length[k] = u[m + 1].exp().clamp(LENGTH_PCT.0, LENGTH_PCT.1);
                    m += 2;
                }
            }
            let sd = if estimate_sd { u[m].exp().clamp(RH_SD_PCT.0, RH_SD_PCT.1) } else { rh_sd_pct.unwrap_or(0.0) };
            (amplitude, length, sd)
        };
        let n_gp = gp.iter().filter(|&&g| g).count();
        let start = |length: f64| -> Vec<f64> {
            let mut u: Vec<f64> = (0..n_gp).flat_map(|_| [0.03f64.ln(), length.ln()]).collect();
            if estimate_sd {
                u.push(0.5f64.ln());
            }
            u
        };
        let mut best: Option<(Vec<f64>, f64)> = None;
        let mut beta = DVector::zeros(ncol);
        // Twice: the slopes of the law found the first time make the read error's noise the second.
        for pass in 0..2 {
            for (i, l) in levels.iter().enumerate() {
                problem.slopes[i] = core::array::from_fn(|k| slope_of(&beta, k, l.rh_pct));
            }
            let objective = |u: &[f64]| -> f64 {
                let (a, l, sd) = unpack(u);
                problem.reml(problem.covariance(&a, &l, sd)).map_or(f64::INFINITY, |r| r.0)
            };
            let starts: Vec<Vec<f64>> = match (&best, pass) {
                (Some((u, _)), 1) => vec![u.clone()],
                _ => [1.5, 4.0, 12.0].map(start).to_vec(),
            };
            best = None;
            if starts[0].is_empty() {
                best = Some((vec![], objective(&[])));
            } else {
                for s in starts {
                    let (u, v) = nelder_mead(&objective, &s, 0.7, 1e-7, 4000);
                    // Restarted once from its own optimum: a simplex can stall on a ridge.
                    let (u, v) = if v.is_finite() { nelder_mead(&objective, &u, 0.3, 1e-8, 2000) } else { (u, v) };
                    if best.as_ref().is_none_or(|b| v < b.1) {
                        best = Some((u, v));
                    }
                }
            }
            let (u, _) = best.as_ref().expect("at least one start");
            let (a, l, sd) = unpack(u);
            let (_, _, b, _) = problem.reml(problem.covariance(&a, &l, sd)).ok_or(ModelError::Singular)?;
            beta = b;
        }
        let (u, _) = best.expect("fitted");
        let (amplitude, length_pct, rh_sd) = unpack(&u);
        let c = problem.covariance(&amplitude, &length_pct, rh_sd);
        let (_, chol, beta, hch_inv) = problem.reml(c).ok_or(ModelError::Singular)?;
        let alpha = chol.solve(&(&problem.y - &problem.h * &beta));
        let law_tests = core::array::from_fn(|k| law_test(&problem, k, degree[k]?, rh_sd));
        let amplitude = core::array::from_fn(|k| if gp[k] { amplitude[k] } else { 0.0 });
        Ok(StripModel {
            base: *base,
            hyper: Hyper { amplitude, length_pct, rh_sd_pct: rh_sd, rh_sd_estimated: estimate_sd },
            degree,
            has_departures: gp,
            law_tests,
            levels: count,
            center,
            half,
            obs: obs.iter().map(|&(k, i)| (k, levels[i].rh_pct)).collect(),
            col,
            beta,
            alpha,
            chol,
            h: problem.h,
            hch_inv,
        })
    }

    /// The smooth law of parameter k (order of [`DEPARTING`]) at `x`, in ln.
    pub fn law_ln(&self, k: usize, x: f64) -> f64 {
        ln_base(&self.base, k, x) + self.degree[k].map_or(0.0, |q| basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * self.beta[self.col[k] + j]).sum())
    }

    /// The covariances of the departure of parameter k at `x` with every observation.
    fn k_star(&self, k: usize, x: f64) -> DVector<f64> {
        DVector::from_iterator(
            self.obs.len(),
            self.obs.iter().map(|&(kk, r)| if kk == k && self.has_departures[k] { matern32(x - r, self.hyper.amplitude[k], self.hyper.length_pct[k]) } else { 0.0 }),
        )
    }

    /// The strip's departure from the law of parameter k at `x`, in ln (the posterior mean).
    pub fn departure(&self, k: usize, x: f64) -> f64 {
        self.k_star(k, x).dot(&self.alpha)
    }

    /// The posterior standard deviation of ln θₖ at `x`: the departure's and the law's.
    pub fn posterior_sd(&self, k: usize, x: f64) -> f64 {
        let Some(q) = self.degree[k] else { return f64::NAN };
        let ks = self.k_star(k, x);
        let cinv_k = self.chol.solve(&ks);
        let prior = if self.has_departures[k] { self.hyper.amplitude[k].powi(2) } else { 0.0 };
        let mut hx = DVector::zeros(self.h.ncols());
        for (j, b) in basis(x, self.center, self.half, q).enumerate() {
            hx[self.col[k] + j] = b;
        }
        let r = hx - self.h.transpose() * &cinv_k;
        let var = prior - ks.dot(&cinv_k) + r.dot(&(&self.hch_inv * &r));
        var.max(0.0).sqrt()
    }
}

/// The law alone (no departures) against the levels of parameter k: generalized least squares
/// with each level's own variance and the reading's along the slope.
fn law_test(p: &Problem<'_>, k: usize, degree: usize, rh_sd: f64) -> Option<LawTest> {
    let rows: Vec<usize> = (0..p.obs.len()).filter(|&a| p.obs[a].0 == k).collect();
    let dof = rows.len().checked_sub(degree + 1).filter(|&d| d > 0)?;
    let col0 = p.col[k];
    let (mut xtx, mut xty) = (DMatrix::<f64>::zeros(degree + 1, degree + 1), DVector::<f64>::zeros(degree + 1));
    let var = |a: usize| {
        let i = p.obs[a].1;
        p.levels[i].cov[k][k] + (rh_sd * p.slopes[i][k]).powi(2)
    };
    for &a in &rows {
        let w = 1.0 / var(a);
        for r in 0..=degree {
            xty[r] += w * p.h[(a, col0 + r)] * p.y[a];
            for c in 0..=degree {
                xtx[(r, c)] += w * p.h[(a, col0 + r)] * p.h[(a, col0 + c)];
            }
        }
    }
    let b = xtx.cholesky()?.solve(&xty);
    let chi2: f64 = rows.iter().map(|&a| (p.y[a] - (0..=degree).map(|r| p.h[(a, col0 + r)] * b[r]).sum::<f64>()).powi(2) / var(a)).sum();
    Some(LawTest { chi2, dof, p_value: chi2_tail(chi2, dof) })
}

/// The departures table over `rh_range`: [`MAX_DEPARTURE_POINTS`] evenly spaced humidities,
/// each parameter's departure there plus `law_misfit(k, x)` (what the written law leaves of the
/// model's law), clamped to what a table may hold.
pub fn table(model: &StripModel, rh_range: (f64, f64), law_misfit: &dyn Fn(usize, f64) -> f64) -> (Vec<f64>, [Vec<f64>; 4]) {
    let n = MAX_DEPARTURE_POINTS;
    let grid: Vec<f64> = (0..n).map(|i| rh_range.0 + (rh_range.1 - rh_range.0) * i as f64 / (n - 1) as f64).collect();
    let ln = core::array::from_fn(|k| grid.iter().map(|&x| (model.departure(k, x) + law_misfit(k, x)).clamp(-MAX_LN_DEPARTURE, MAX_LN_DEPARTURE)).collect());
    (grid, ln)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Levels of a strip that follows the base laws times departures `dep(k, setpoint)`, read
    /// with errors `e`, each parameter's ln with standard error `se`.
    fn levels(setpoints: &[f64], e: &[f64], se: f64, dep: &dyn Fn(usize, f64) -> f64) -> Vec<LevelTheta> {
        let base = Calibration::default_preset();
        setpoints
            .iter()
            .zip(e)
            .enumerate()
            .map(|(i, (&x, &e))| {
                // A fixed pseudo-random noise of one SE's size.
                let noise = |k: usize| se * (((i * 7 + k * 13) % 11) as f64 / 5.0 - 1.0);
                LevelTheta {
                    rh_pct: x + e,
                    ln: core::array::from_fn(|k| Some(ln_base(&base, k, x) + dep(k, x) + noise(k))),
                    cov: core::array::from_fn(|a| core::array::from_fn(|b| if a == b { se * se } else { 0.0 })),
                }
            })
            .collect()
    }

    #[test]
    fn no_departures_no_table() {
        let sp: Vec<f64> = (0..12).map(|i| 36.0 + 4.0 * i as f64).collect();
        let lv = levels(&sp, &vec![0.0; 12], 0.01, &|_, _| 0.0);
        let m = StripModel::fit(&Calibration::default_preset(), &lv, Some(0.1)).unwrap();
        for k in 0..4 {
            for x in [40.0, 57.0, 75.0] {
                assert!(m.departure(k, x).abs() < 0.01, "{k} at {x}: {}", m.departure(k, x));
                assert!(m.law_ln(k, x) - ln_base(&Calibration::default_preset(), k, x) < 0.01);
            }
            let t = m.law_tests[k].unwrap();
            assert!(t.p_value > 0.01, "{k}: {t:?}");
        }
    }

    /// Departures far beyond the errors, the same at each setpoint's two visits: kept at the
    /// setpoints, the law test says the law alone does not hold.
    #[test]
    fn departures_beyond_the_errors_are_kept() {
        let sp: Vec<f64> = [38.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0, 75.0, 80.0].into_iter().chain([75.0, 70.0, 65.0, 60.0, 55.0, 50.0, 45.0, 40.0, 38.0]).collect();
        let dep = |k: usize, x: f64| if k == 0 { 0.05 * (x / 5.0).round().rem_euclid(3.0) - 0.05 } else { 0.0 };
        let e: Vec<f64> = (0..sp.len()).map(|i| 0.3 * ((i % 5) as f64 - 2.0) / 2.0).collect();
        let lv = levels(&sp, &e, 0.002, &dep);
        let m = StripModel::fit(&Calibration::default_preset(), &lv, None).unwrap();
        assert!(m.law_tests[0].unwrap().p_value < 1e-6, "{:?}", m.law_tests[0]);
        for &x in &[45.0, 55.0, 65.0, 75.0] {
            let got = m.law_ln(0, x) + m.departure(0, x) - ln_base(&Calibration::default_preset(), 0, x);
            assert!((got - dep(0, x)).abs() < 0.015, "Y at {x}: {got} vs {}", dep(0, x));
            assert!(m.posterior_sd(0, x) < 0.02, "{}", m.posterior_sd(0, x));
        }
        assert!(m.has_departures[0] && m.hyper.amplitude[0] > 0.02, "{:?}", m.hyper);
    }
}
