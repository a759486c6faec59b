//! The fits: Levenberg–Marquardt from every start, the best optimum kept, with its statistics
//! (dense or block by block).

use super::block_qr::Reach;
use super::bound::Param;
use super::outcome::{Fit, FitError, Tolerance};
use super::problem::Problem;
use super::residuals::{Blocked, Blocks, Dense, Residuals};
use levenberg_marquardt::LevenbergMarquardt;
use nalgebra::DVector;

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

/// [`fit`] for a problem whose residuals come in blocks, each parameter moving either every block
/// or one block only (a model's global parameters and each humidity level's own ones). The
/// result is the one [`fit`] gives on the concatenated residuals (the same steps in exact
/// arithmetic, so the two part at the stopping tolerance); only the cost differs: a
/// Jacobian takes one evaluation of every block per global parameter, plus one, and one
/// evaluation of its block per local parameter, instead of one of every block per parameter,
/// and each step is solved from a QR factor computed block by block ([`super::block_qr`]).
///
/// `residuals(θ, b, out)` writes block `b`'s `sizes[b]` weighted residuals for parameters θ (all
/// of them, in natural units). It must not read a parameter that reaches another block only: that
/// parameter's derivatives outside its block are taken as exactly zero. A non-finite residual
/// marks θ as infeasible. [`Fit::residuals`] holds the blocks one after another.
pub fn fit_blocks<F>(tol: Tolerance, params: &[Param], starts: &[Vec<f64>], blocks: Blocks<'_>, residuals: F) -> Result<Fit, FitError>
where
    F: Fn(&[f64], usize, &mut [f64]),
{
    fit_model(tol, params, starts, &blocked(params, blocks, residuals)?)
}

/// [`fit_blocks`]'s optimum and χ² without the statistics (for runs that restart from where the
/// last stopped: the statistics cost a Jacobian, a block factor and an SVD, and only the last
/// run's are wanted, from [`statistics_blocks`]).
pub fn minimize_blocks<F>(
    tol: Tolerance,
    params: &[Param],
    starts: &[Vec<f64>],
    blocks: Blocks<'_>,
    residuals: F,
) -> Result<(Vec<f64>, f64), FitError>
where
    F: Fn(&[f64], usize, &mut [f64]),
{
    let model = blocked(params, blocks, residuals)?;
    let (problem, chi2, _) = best_of_starts(tol, params, starts, &model)?;
    Ok((problem.theta(&problem.u), chi2))
}

/// The statistics [`fit_blocks`] gives at its optimum, at the point `at` (natural units), with
/// no optimization: standard errors, covariance, χ² and the residuals there.
pub fn statistics_blocks<F>(params: &[Param], at: &[f64], blocks: Blocks<'_>, residuals: F) -> Result<Fit, FitError>
where
    F: Fn(&[f64], usize, &mut [f64]),
{
    let model = blocked(params, blocks, residuals)?;
    if model.len() < params.len() {
        return Err(FitError::TooFewResiduals { residuals: model.len(), params: params.len() });
    }
    if at.len() != params.len() {
        return Err(FitError::BadStart { start: 0, reason: format!("{} values for {} parameters", at.len(), params.len()) });
    }
    let u = DVector::from_iterator(params.len(), params.iter().zip(at).map(|(p, &v)| p.bound.to_u(v)));
    let problem = Problem::new(params, u, &model);
    let chi2 = problem.chi2();
    if !chi2.is_finite() {
        return Err(FitError::NoFiniteStart);
    }
    let mut fit = problem.statistics(chi2);
    fit.evaluations = problem.evaluations();
    Ok(fit)
}

/// The block structure checked against the parameters: every block a parameter reaches exists.
fn blocked<'a, F>(params: &[Param], blocks: Blocks<'a>, residuals: F) -> Result<Blocked<'a, F>, FitError> {
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
    Ok(Blocked { offsets, reach: blocks.reach, f: residuals })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numeric::lsq::Bound;
    use nalgebra::DMatrix;

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
