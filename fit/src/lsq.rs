//! Bounded, weighted nonlinear least squares: Levenberg–Marquardt (the `levenberg-marquardt`
//! crate, a port of MINPACK's trust-region LM) in transformed coordinates, several starts, and
//! standard errors from the Jacobian at the optimum.
//!
//! A problem is a list of named [`Param`]s and a residual function of the parameters in their
//! natural units. The residuals must already be divided by each point's σ (so that χ² = Σ r²).
//! Bounds are kept by optimizing an unconstrained coordinate u with θ = g(u) ([`Bound`]); the
//! covariance is propagated back to θ through g′ (delta method), so a badly determined positive
//! parameter shows up as a large relative standard error instead of a clipped estimate.
//!
//! A problem whose residuals come in blocks (one per humidity level, say) where most parameters
//! move one block only is fitted by [`fit_blocks`]: the same optimizer, but each forward
//! difference of a block's own parameter evaluates that block alone.

use crate::block_qr::{self, Reach};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{DMatrix, DVector, Dyn, Owned};

/// How a parameter is kept in its physical range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bound {
    /// Unbounded: u = θ.
    Free,
    /// Positive, usually spanning decades (moduli, damping, diffusivity): u = ln θ, so the
    /// optimizer takes relative steps and can never reach zero.
    Positive,
    /// Inside (lo, hi): θ = lo + (hi − lo)·logistic(u).
    Between(f64, f64),
}

impl Bound {
    fn to_u(self, theta: f64) -> f64 {
        match self {
            Bound::Free => theta,
            Bound::Positive => theta.ln(),
            Bound::Between(lo, hi) => {
                let t = ((theta - lo) / (hi - lo)).clamp(1e-12, 1.0 - 1e-12);
                (t / (1.0 - t)).ln()
            }
        }
    }
    fn to_theta(self, u: f64) -> f64 {
        match self {
            Bound::Free => u,
            Bound::Positive => u.exp(),
            Bound::Between(lo, hi) => lo + (hi - lo) / (1.0 + (-u).exp()),
        }
    }
    /// dθ/du at u.
    fn slope(self, u: f64) -> f64 {
        match self {
            Bound::Free => 1.0,
            Bound::Positive => u.exp(),
            Bound::Between(lo, hi) => {
                let e = (-u.abs()).exp();
                (hi - lo) * e / ((1.0 + e) * (1.0 + e))
            }
        }
    }
    /// Whether θ is strictly inside the range (a start must be).
    pub fn admits(self, theta: f64) -> bool {
        theta.is_finite()
            && match self {
                Bound::Free => true,
                Bound::Positive => theta > 0.0,
                Bound::Between(lo, hi) => lo < theta && theta < hi,
            }
    }
}

/// One fitted parameter.
#[derive(Clone, Debug)]
pub struct Param {
    pub name: String,
    pub bound: Bound,
}

impl Param {
    pub fn new(name: impl Into<String>, bound: Bound) -> Self {
        Param { name: name.into(), bound }
    }
}

/// The outcome of [`fit`]: estimates in natural units and their statistics.
#[derive(Clone, Debug)]
pub struct Fit {
    pub names: Vec<String>,
    pub estimates: Vec<f64>,
    /// Standard errors, √diag(covariance); infinite when the data do not determine the parameter
    /// (singular information matrix).
    pub std_errors: Vec<f64>,
    /// Covariance of the estimates, (JᵀJ)⁻¹ scaled by the reduced χ² (so it holds even when the
    /// σ given with the data were off by a common factor), in natural units.
    pub covariance: DMatrix<f64>,
    /// Correlation matrix of the estimates (scale-free, the same in u and θ).
    pub correlation: DMatrix<f64>,
    /// Σ r² at the optimum.
    pub chi2: f64,
    /// Residual count minus fitted parameter count.
    pub dof: usize,
    /// Weighted residuals at the optimum, in the order the residual function writes them.
    pub residuals: Vec<f64>,
    /// Model evaluations spent over all starts (the cost of the fit; for [`fit_blocks`], block
    /// evaluations are added up as their share of the residuals).
    pub evaluations: usize,
}

impl Fit {
    pub fn reduced_chi2(&self) -> f64 {
        self.chi2 / self.dof.max(1) as f64
    }
    pub fn index(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }
    pub fn value(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.estimates[i])
    }
    pub fn std_error(&self, name: &str) -> Option<f64> {
        self.index(name).map(|i| self.std_errors[i])
    }
    pub fn correlation_of(&self, a: &str, b: &str) -> Option<f64> {
        Some(self.correlation[(self.index(a)?, self.index(b)?)])
    }
}

/// Why a fit produced nothing.
#[derive(Clone, Debug, PartialEq)]
pub enum FitError {
    /// A start lies outside its parameter's bound or has the wrong length.
    BadStart { start: usize, reason: String },
    /// Fewer residuals than parameters.
    TooFewResiduals { residuals: usize, params: usize },
    /// No start reached a finite χ² (the model gave non-finite values everywhere tried).
    NoFiniteStart,
    /// A block problem's layout does not match its parameters ([`fit_blocks`]).
    BadBlocks(String),
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FitError::BadStart { start, reason } => write!(f, "start {start}: {reason}"),
            FitError::TooFewResiduals { residuals, params } => {
                write!(f, "{residuals} residuals cannot determine {params} parameters")
            }
            FitError::NoFiniteStart => write!(f, "the model is not finite at any start"),
            FitError::BadBlocks(reason) => write!(f, "block layout: {reason}"),
        }
    }
}

impl std::error::Error for FitError {}

/// When Levenberg–Marquardt stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Relative reduction of χ² below which it stops.
    pub ftol: f64,
    /// Relative step in the (transformed) parameters below which it stops.
    pub xtol: f64,
    /// It stops after `patience`·(parameters + 1) trial evaluations of the residuals (at least
    /// one per iteration) even if neither tolerance is met.
    pub patience: usize,
}

impl Tolerance {
    /// For a reported fit: the statistical uncertainty of any parameter worth reporting is far
    /// above 1e-8 relative, so iterating towards machine precision (the crate's default) buys
    /// nothing.
    pub const REPORT: Tolerance = Tolerance { ftol: 1e-10, xtol: 1e-8, patience: 100 };
    /// For a fit that only starts another one: it needs to land in the right basin, not on its
    /// floor.
    pub const START: Tolerance = Tolerance { ftol: 1e-6, xtol: 1e-4, patience: 100 };
}

/// Forward-difference step in u (relative step for `Positive` parameters).
const DIFF_STEP: f64 = 1e-7;
/// Singular values of J below this fraction of the largest are taken as zero: forward
/// differences leave errors of about `DIFF_STEP` in J, so smaller ones are noise, and a
/// direction a million times worse determined than the best one is undetermined for any use.
const SINGULAR_RATIO: f64 = 1e-6;

/// Minimizes Σ r(θ)² from each start and keeps the best optimum.
///
/// `residuals(θ, out)` writes `n_residuals` weighted residuals for parameters θ in natural units;
/// a non-finite residual marks θ as infeasible (the step is rejected).
pub fn fit<F>(params: &[Param], starts: &[Vec<f64>], n_residuals: usize, residuals: F) -> Result<Fit, FitError>
where
    F: Fn(&[f64], &mut [f64]),
{
    fit_with(Tolerance::REPORT, params, starts, n_residuals, residuals)
}

/// The best optimum over `starts` and its χ², without the statistics [`fit`] adds (for a fit
/// that only starts another one: the statistics cost a Jacobian and an SVD).
pub fn minimize<F>(
    tol: Tolerance,
    params: &[Param],
    starts: &[Vec<f64>],
    n_residuals: usize,
    residuals: F,
) -> Result<(Vec<f64>, f64), FitError>
where
    F: Fn(&[f64], &mut [f64]),
{
    let model = Dense { n_residuals, f: residuals };
    let (problem, chi2, _) = best_of_starts(tol, params, starts, &model)?;
    Ok((problem.theta(&problem.u), chi2))
}

/// [`fit`] with chosen stopping tolerances.
pub fn fit_with<F>(tol: Tolerance, params: &[Param], starts: &[Vec<f64>], n_residuals: usize, residuals: F) -> Result<Fit, FitError>
where
    F: Fn(&[f64], &mut [f64]),
{
    fit_model(tol, params, starts, &Dense { n_residuals, f: residuals })
}

/// The layout of a problem whose residuals come in consecutive blocks.
#[derive(Clone, Copy, Debug)]
pub struct Blocks<'a> {
    /// Residual count of each block, in the order the blocks are laid out in the residual vector.
    pub sizes: &'a [usize],
    /// For each parameter (in the order of `params`), which residuals it moves.
    pub reach: &'a [Reach],
}

/// [`fit`] for a problem whose residuals come in blocks, each parameter moving either every block
/// or one block only (a model's global parameters and each humidity level's own ones). The
/// result is the one [`fit`] gives on the concatenated residuals (the same steps in exact
/// arithmetic, so the two part at the stopping tolerance); only the cost differs: a
/// Jacobian takes one evaluation of every block per global parameter, plus one, and one
/// evaluation of its block per local parameter, instead of one of every block per parameter,
/// and each step is solved from a QR factor computed block by block ([`crate::block_qr`]).
///
/// `residuals(θ, b, out)` writes block `b`'s `sizes[b]` weighted residuals for parameters θ (all
/// of them, in natural units). It must not read a parameter that reaches another block only: that
/// parameter's derivatives outside its block are taken as exactly zero. A non-finite residual
/// marks θ as infeasible. [`Fit::residuals`] holds the blocks one after another.
pub fn fit_blocks<F>(tol: Tolerance, params: &[Param], starts: &[Vec<f64>], blocks: Blocks<'_>, residuals: F) -> Result<Fit, FitError>
where
    F: Fn(&[f64], usize, &mut [f64]),
{
    if blocks.reach.len() != params.len() {
        return Err(FitError::BadBlocks(format!("{} reaches for {} parameters", blocks.reach.len(), params.len())));
    }
    if let Some((p, b)) = params.iter().zip(blocks.reach).find_map(|(p, r)| match r {
        Reach::Block(b) if *b >= blocks.sizes.len() => Some((p, b)),
        _ => None,
    }) {
        return Err(FitError::BadBlocks(format!("{} reaches block {b} of {}", p.name, blocks.sizes.len())));
    }
    let mut offsets = Vec::with_capacity(blocks.sizes.len() + 1);
    offsets.push(0);
    for s in blocks.sizes {
        offsets.push(offsets.last().copied().unwrap_or(0) + s);
    }
    fit_model(tol, params, starts, &Blocked { offsets, reach: blocks.reach, f: residuals })
}

/// How the optimizer gets residuals: all of them, or those one parameter moves.
trait Residuals {
    fn len(&self) -> usize;
    /// Writes every residual at θ.
    fn all(&self, theta: &[f64], out: &mut [f64]);
    /// Writes, at θ, the residuals that parameter `j` moves and returns where they are in `out`
    /// (the others it may leave as they were: their derivative in `j` is zero).
    fn moved_by(&self, j: usize, theta: &[f64], out: &mut [f64]) -> core::ops::Range<usize>;
    /// Where each block starts (and the total at the end) and which block each parameter
    /// reaches, for a problem with that structure.
    fn layout(&self) -> Option<(&[usize], &[Reach])> {
        None
    }
}

/// A residual function with no known structure: every parameter moves every residual.
struct Dense<F> {
    n_residuals: usize,
    f: F,
}

impl<F: Fn(&[f64], &mut [f64])> Residuals for Dense<F> {
    fn len(&self) -> usize {
        self.n_residuals
    }
    fn all(&self, theta: &[f64], out: &mut [f64]) {
        (self.f)(theta, out)
    }
    fn moved_by(&self, _j: usize, theta: &[f64], out: &mut [f64]) -> core::ops::Range<usize> {
        (self.f)(theta, out);
        0..self.n_residuals
    }
}

/// A residual function evaluated block by block ([`fit_blocks`]).
struct Blocked<'a, F> {
    /// Where each block starts in the residual vector, and the total at the end.
    offsets: Vec<usize>,
    reach: &'a [Reach],
    f: F,
}

impl<F: Fn(&[f64], usize, &mut [f64])> Residuals for Blocked<'_, F> {
    fn len(&self) -> usize {
        self.offsets.last().copied().unwrap_or(0)
    }
    fn all(&self, theta: &[f64], out: &mut [f64]) {
        for (b, w) in self.offsets.windows(2).enumerate() {
            (self.f)(theta, b, &mut out[w[0]..w[1]]);
        }
    }
    fn moved_by(&self, j: usize, theta: &[f64], out: &mut [f64]) -> core::ops::Range<usize> {
        match self.reach[j] {
            Reach::Global => {
                self.all(theta, out);
                0..self.len()
            }
            Reach::Block(b) => {
                let rows = self.offsets[b]..self.offsets[b + 1];
                (self.f)(theta, b, &mut out[rows.clone()]);
                rows
            }
        }
    }
    fn layout(&self) -> Option<(&[usize], &[Reach])> {
        Some((&self.offsets, self.reach))
    }
}

/// The best optimum over `starts` with its statistics.
fn fit_model<R: Residuals>(tol: Tolerance, params: &[Param], starts: &[Vec<f64>], model: &R) -> Result<Fit, FitError> {
    let (problem, chi2, evaluations) = best_of_starts(tol, params, starts, model)?;
    let before = problem.evaluations();
    let mut fit = problem.statistics(chi2);
    fit.evaluations = evaluations + problem.evaluations() - before;
    Ok(fit)
}

/// Runs LM from every start; the best problem, its χ² and the evaluations spent on all starts.
fn best_of_starts<'a, R: Residuals>(
    tol: Tolerance,
    params: &'a [Param],
    starts: &[Vec<f64>],
    model: &'a R,
) -> Result<(Problem<'a, R>, f64, usize), FitError> {
    let n = params.len();
    let n_residuals = model.len();
    if n_residuals < n {
        return Err(FitError::TooFewResiduals { residuals: n_residuals, params: n });
    }
    for (k, s) in starts.iter().enumerate() {
        if s.len() != n {
            return Err(FitError::BadStart { start: k, reason: format!("{} values for {n} parameters", s.len()) });
        }
        if let Some((p, v)) = params.iter().zip(s).find(|(p, v)| !p.bound.admits(**v)) {
            return Err(FitError::BadStart { start: k, reason: format!("{} = {v} is outside {:?}", p.name, p.bound) });
        }
    }
    let lm = LevenbergMarquardt::new().with_ftol(tol.ftol).with_xtol(tol.xtol).with_gtol(tol.ftol).with_patience(tol.patience.max(1));
    let mut best: Option<(Problem<'a, R>, f64)> = None;
    let mut evaluations = 0;
    for start in starts {
        let u = DVector::from_iterator(n, params.iter().zip(start).map(|(p, &v)| p.bound.to_u(v)));
        let problem = Problem::new(params, u, model);
        if !problem.chi2().is_finite() {
            evaluations += problem.evaluations();
            continue;
        }
        let (problem, _report) = lm.minimize(problem);
        evaluations += problem.evaluations();
        let chi2 = problem.chi2();
        if chi2.is_finite() && best.as_ref().is_none_or(|(_, b)| chi2 < *b) {
            best = Some((problem, chi2));
        }
    }
    let (problem, chi2) = best.ok_or(FitError::NoFiniteStart)?;
    Ok((problem, chi2, evaluations))
}

/// The LM crate's view of a problem: coordinates u, residuals by the caller's function.
struct Problem<'a, R> {
    params: &'a [Param],
    u: DVector<f64>,
    model: &'a R,
    /// Residual values computed so far: a block evaluation costs its share of a full one.
    rows_evaluated: core::cell::Cell<usize>,
    /// The residuals at the last u they were computed at: LM asks for the residuals and then
    /// the Jacobian at the same point, and the Jacobian's differences start from them.
    at_u: core::cell::RefCell<Option<(DVector<f64>, Vec<f64>)>>,
}

impl<'a, R: Residuals> Problem<'a, R> {
    fn new(params: &'a [Param], u: DVector<f64>, model: &'a R) -> Self {
        Problem { params, u, model, rows_evaluated: core::cell::Cell::new(0), at_u: Default::default() }
    }

    /// Full model evaluations spent so far (block evaluations added up).
    fn evaluations(&self) -> usize {
        self.rows_evaluated.get().div_ceil(self.model.len().max(1))
    }

    fn count(&self, rows: usize) {
        self.rows_evaluated.set(self.rows_evaluated.get() + rows);
    }

    fn theta(&self, u: &DVector<f64>) -> Vec<f64> {
        self.params.iter().zip(u.iter()).map(|(p, &x)| p.bound.to_theta(x)).collect()
    }

    fn eval(&self, u: &DVector<f64>, out: &mut [f64]) -> bool {
        self.count(out.len());
        self.model.all(&self.theta(u), out);
        out.iter().all(|r| r.is_finite())
    }

    /// The residuals at the current u (computed once per u).
    fn eval_here(&self, out: &mut [f64]) -> bool {
        if let Some((u, r)) = self.at_u.borrow().as_ref()
            && *u == self.u
        {
            out.copy_from_slice(r);
            return out.iter().all(|r| r.is_finite());
        }
        let ok = self.eval(&self.u, out);
        *self.at_u.borrow_mut() = Some((self.u.clone(), out.to_vec()));
        ok
    }

    fn chi2(&self) -> f64 {
        let mut r = vec![0.0; self.model.len()];
        if self.eval_here(&mut r) { r.iter().map(|x| x * x).sum() } else { f64::INFINITY }
    }

    /// Forward differences in u: per parameter, one evaluation of the residuals it moves (the
    /// other rows of its column stay zero).
    fn jacobian_at(&self, r0: &[f64]) -> Option<DMatrix<f64>> {
        let (m, n) = (self.model.len(), self.u.len());
        let mut jac = DMatrix::zeros(m, n);
        let mut r = vec![0.0; m];
        for j in 0..n {
            let mut u = self.u.clone();
            let h = DIFF_STEP * self.u[j].abs().max(1.0);
            u[j] += h;
            let rows = self.model.moved_by(j, &self.theta(&u), &mut r);
            self.count(rows.len());
            if !r[rows.clone()].iter().all(|x| x.is_finite()) {
                return None;
            }
            for i in rows {
                jac[(i, j)] = (r[i] - r0[i]) / h;
            }
        }
        Some(jac)
    }

    fn statistics(&self, chi2: f64) -> Fit {
        let n = self.u.len();
        let m = self.model.len();
        let mut r0 = vec![0.0; m];
        self.eval_here(&mut r0);
        let dof = m - n;
        let s2 = if dof > 0 { chi2 / dof as f64 } else { f64::NAN };
        // (JᵀJ)⁻¹ through the SVD of J: singular directions get infinite variance instead of
        // the arbitrary huge numbers a plain inverse of a near-singular matrix gives.
        // R of a block problem has J's singular values and right vectors at a fraction of the cost.
        let jac = self.jacobian_at(&r0).map(|jac| match self.model.layout() {
            Some((offsets, reach)) => block_qr::factor(&jac, &r0, offsets, reach).r,
            None => jac,
        });
        let cov_u = match jac {
            Some(jac) => {
                let svd = jac.svd(false, true);
                let v_t = svd.v_t.expect("requested V");
                let smax = svd.singular_values.max();
                let mut cov = DMatrix::zeros(n, n);
                for k in 0..svd.singular_values.len() {
                    let sv = svd.singular_values[k];
                    let w = if sv > smax * SINGULAR_RATIO { 1.0 / (sv * sv) } else { f64::INFINITY };
                    for a in 0..n {
                        for b in 0..n {
                            let c = v_t[(k, a)] * v_t[(k, b)];
                            if c != 0.0 {
                                cov[(a, b)] += w * c;
                            }
                        }
                    }
                }
                cov * s2
            }
            None => DMatrix::from_element(n, n, f64::NAN),
        };
        let slopes: Vec<f64> = self.params.iter().zip(self.u.iter()).map(|(p, &x)| p.bound.slope(x)).collect();
        let covariance = DMatrix::from_fn(n, n, |a, b| cov_u[(a, b)] * slopes[a] * slopes[b]);
        let std_errors: Vec<f64> = (0..n).map(|k| covariance[(k, k)].sqrt()).collect();
        let correlation = DMatrix::from_fn(n, n, |a, b| if a == b { 1.0 } else { cov_u[(a, b)] / (cov_u[(a, a)] * cov_u[(b, b)]).sqrt() });
        Fit {
            names: self.params.iter().map(|p| p.name.clone()).collect(),
            estimates: self.theta(&self.u),
            std_errors,
            covariance,
            correlation,
            chi2,
            dof,
            residuals: r0,
            evaluations: 0,
        }
    }
}

impl<R: Residuals> LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_, R> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, u: &DVector<f64>) {
        self.u.copy_from(u);
    }

    fn params(&self) -> DVector<f64> {
        self.u.clone()
    }

    /// A block problem hands the optimizer its reduced form ([`block_qr::reduced_jacobian`]):
    /// the residuals' norm in the first of n + 1 rows.
    fn residuals(&self) -> Option<DVector<f64>> {
        let mut r = vec![0.0; self.model.len()];
        if !self.eval_here(&mut r) {
            return None;
        }
        Some(match self.model.layout() {
            Some(_) => {
                let mut reduced = DVector::zeros(self.u.len() + 1);
                reduced[0] = r.iter().map(|x| x * x).sum::<f64>().sqrt();
                reduced
            }
            None => DVector::from_vec(r),
        })
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        let mut r0 = vec![0.0; self.model.len()];
        if !self.eval_here(&mut r0) {
            return None;
        }
        let jac = self.jacobian_at(&r0)?;
        Some(match self.model.layout() {
            Some((offsets, reach)) => {
                let norm = r0.iter().map(|x| x * x).sum::<f64>().sqrt();
                block_qr::reduced_jacobian(&block_qr::factor(&jac, &r0, offsets, reach), norm)
            }
            None => jac,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y = a·e^(−k·x) with known Gaussian-free "noise" pattern: the estimates, their standard
    /// errors and χ² must match the linearized theory computed independently.
    #[test]
    fn exponential_decay_recovers_parameters_and_bounds_hold() {
        let (a, k) = (2.5, 0.7);
        let xs: Vec<f64> = (0..40).map(|i| i as f64 * 0.1).collect();
        let noise = |i: usize| 0.01 * ((i * 7919 % 101) as f64 / 50.0 - 1.0);
        let ys: Vec<f64> = xs.iter().enumerate().map(|(i, &x)| a * (-k * x).exp() + noise(i)).collect();
        let sigma = 0.01;
        let params = [Param::new("a", Bound::Positive), Param::new("k", Bound::Between(0.0, 5.0))];
        let f = fit(&params, &[vec![1.0, 2.0], vec![10.0, 0.1]], xs.len(), |t, out| {
            for (i, &x) in xs.iter().enumerate() {
                out[i] = (ys[i] - t[0] * (-t[1] * x).exp()) / sigma;
            }
        })
        .unwrap();
        assert!((f.estimates[0] - a).abs() < 0.02 && (f.estimates[1] - k).abs() < 0.02, "{:?}", f.estimates);
        assert_eq!(f.dof, 38);
        // Standard errors from the textbook formula at the optimum (analytic Jacobian).
        let (ea, ek) = (f.estimates[0], f.estimates[1]);
        let jac = DMatrix::from_fn(xs.len(), 2, |i, j| {
            let e = (-ek * xs[i]).exp();
            if j == 0 { e / sigma } else { -ea * xs[i] * e / sigma }
        });
        let cov = (jac.transpose() * &jac).try_inverse().unwrap() * f.reduced_chi2();
        for j in 0..2 {
            let want = cov[(j, j)].sqrt();
            assert!((f.std_errors[j] / want - 1.0).abs() < 1e-3, "se {j}: {} vs {want}", f.std_errors[j]);
        }
        let want_corr = cov[(0, 1)] / (cov[(0, 0)] * cov[(1, 1)]).sqrt();
        assert!((f.correlation_of("a", "k").unwrap() - want_corr).abs() < 1e-3);
    }

    #[test]
    fn an_undetermined_parameter_gets_an_infinite_error() {
        // Only a·b is observable.
        let params = [Param::new("a", Bound::Positive), Param::new("b", Bound::Positive)];
        let f = fit(&params, &[vec![1.0, 1.0]], 5, |t, out| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = (t[0] * t[1] - 6.0) * (1.0 + i as f64) + 0.01 * (i as f64 - 2.0);
            }
        })
        .unwrap();
        assert!((f.estimates[0] * f.estimates[1] - 6.0).abs() < 1e-2);
        assert!(f.std_errors.iter().all(|s| s.is_infinite()), "{:?}", f.std_errors);
    }

    /// Three blocks of different sizes, y = a_b·e^(−k_b·x) + c_b·x² + g·x per block, with one
    /// global slope g.
    fn block_residuals(t: &[f64], b: usize, out: &mut [f64]) {
        let (g, a, k, c) = (t[0], t[1 + 3 * b], t[2 + 3 * b], t[3 + 3 * b]);
        for (i, o) in out.iter_mut().enumerate() {
            let x = 0.3 * (i + 1) as f64 + b as f64;
            let y = (1.7 + 0.1 * b as f64) * (-0.4 * x).exp() + 0.05 * x * x + 0.2 * x + 0.002 * (((i * 37 + b) % 7) as f64 - 3.0);
            *o = (y - a * (-k * x).exp() - c * x * x - g * x) / 0.002;
        }
    }
    const BLOCK_SIZES: [usize; 3] = [7, 11, 5];

    fn block_problem() -> (Vec<Param>, Vec<Reach>) {
        let mut params = vec![Param::new("g", Bound::Positive)];
        let mut reach = vec![Reach::Global];
        for b in 0..BLOCK_SIZES.len() {
            params.push(Param::new(format!("a{b}"), Bound::Positive));
            params.push(Param::new(format!("k{b}"), Bound::Between(0.0, 3.0)));
            params.push(Param::new(format!("c{b}"), Bound::Free));
            reach.extend([Reach::Block(b); 3]);
        }
        (params, reach)
    }

    fn dense_residuals(t: &[f64], out: &mut [f64]) {
        let mut at = 0;
        for (b, &n) in BLOCK_SIZES.iter().enumerate() {
            block_residuals(t, b, &mut out[at..at + n]);
            at += n;
        }
    }

    /// The block Jacobian is the dense one: the same differences in each block's own rows,
    /// zeros elsewhere (which the dense one gets by differencing equal values).
    #[test]
    fn block_jacobian_equals_the_dense_one() {
        let (params, reach) = block_problem();
        let theta = [0.9, 1.2, 0.5, 0.03, 2.0, 0.3, 0.1, 1.5, 0.8, -0.02];
        let u = DVector::from_iterator(params.len(), params.iter().zip(&theta).map(|(p, &v)| p.bound.to_u(v)));
        let dense = Dense { n_residuals: BLOCK_SIZES.iter().sum(), f: dense_residuals };
        let blocked = Blocked { offsets: vec![0, 7, 18, 23], reach: &reach, f: block_residuals };
        fn jacobian<R: Residuals>(p: &Problem<'_, R>) -> DMatrix<f64> {
            let mut r0 = vec![0.0; p.model.len()];
            assert!(p.eval_here(&mut r0));
            p.jacobian_at(&r0).unwrap()
        }
        let jd = jacobian(&Problem::new(&params, u.clone(), &dense));
        let blocked_problem = Problem::new(&params, u, &blocked);
        let jb = jacobian(&blocked_problem);
        // The global column and each block's three: every entry the structure allows is non-zero.
        assert_eq!(jd.iter().filter(|v| **v != 0.0).count(), 23 + 3 * 23);
        assert_eq!(jb, jd);
        // One full evaluation for r0 and one per global parameter, a block's worth per local one.
        assert_eq!(blocked_problem.rows_evaluated.get(), 23 * 2 + 3 * 23);
    }

    #[test]
    fn a_block_fit_lands_where_the_dense_fit_does() {
        let (params, reach) = block_problem();
        let start = vec![1.0, 1.0, 0.5, 0.0, 1.0, 0.5, 0.0, 1.0, 0.5, 0.0];
        let dense = fit(&params, std::slice::from_ref(&start), BLOCK_SIZES.iter().sum(), dense_residuals).unwrap();
        let blocks = Blocks { sizes: &BLOCK_SIZES, reach: &reach };
        let blocked = fit_blocks(Tolerance::REPORT, &params, &[start], blocks, block_residuals).unwrap();
        assert!((dense.estimates[0] - 0.2).abs() < 0.05, "the dense fit itself went astray: {:?}", dense.estimates);
        // The same steps in exact arithmetic, solved from the block factor: they part at the
        // stopping tolerance, far inside the standard errors.
        for ((b, d), se) in blocked.estimates.iter().zip(&dense.estimates).zip(&dense.std_errors) {
            assert!((b - d).abs() < 1e-4 * se, "{b} vs {d} (σ {se})");
        }
        assert!((blocked.chi2 / dense.chi2 - 1.0).abs() < 1e-9, "{} vs {}", blocked.chi2, dense.chi2);
        for (b, d) in blocked.std_errors.iter().zip(&dense.std_errors) {
            assert!((b / d - 1.0).abs() < 1e-6, "{b} vs {d}");
        }
        assert!(blocked.evaluations < dense.evaluations, "{} vs {}", blocked.evaluations, dense.evaluations);
    }

    #[test]
    fn a_block_layout_that_does_not_match_is_refused() {
        let (params, mut reach) = block_problem();
        reach[4] = Reach::Block(3);
        let blocks = Blocks { sizes: &BLOCK_SIZES, reach: &reach };
        let e = fit_blocks(Tolerance::REPORT, &params, &[vec![1.0; 10]], blocks, block_residuals).unwrap_err();
        assert!(matches!(e, FitError::BadBlocks(_)), "{e:?}");
    }

    #[test]
    fn starts_outside_bounds_are_refused() {
        let params = [Param::new("a", Bound::Positive)];
        let e = fit(&params, &[vec![-1.0]], 3, |_, _| {}).unwrap_err();
        assert!(matches!(e, FitError::BadStart { start: 0, .. }), "{e:?}");
    }
}
