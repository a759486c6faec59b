//! How far the levels stray from what is kept of them: the law alone against each parameter's
//! levels, and the whole model (law, departures, read errors) against each level held out.

use super::hyper::Spread;
use super::problem::Problem;
use crate::gaussian_process::{Posterior, leave_one_out_z2};
use crate::numeric::stats::chi2_tail;
use nalgebra::{DMatrix, DVector};

/// How far the smooth law alone (no departures) misses its levels: χ² against the levels'
/// errors and the reading's, its degrees of freedom and the chance of a χ² that large if the
/// law held.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LawTest {
    pub chi2: f64,
    pub dof: usize,
    pub p_value: f64,
}

/// The law alone (no departures) against the levels of parameter k: generalized least squares
/// with each level's own variance and the reading's along the slope.
pub(super) fn law_test(p: &Problem<'_>, k: usize, degree: usize, sd: Spread) -> Option<LawTest> {
    let rows: Vec<usize> = (0..p.obs.len()).filter(|&a| p.obs[a].0 == k).collect();
    let dof = rows.len().checked_sub(degree + 1).filter(|&d| d > 0)?;
    let col0 = p.col[k];
    let (mut xtx, mut xty) = (DMatrix::<f64>::zeros(degree + 1, degree + 1), DVector::<f64>::zeros(degree + 1));
    let var = |a: usize| {
        let i = p.obs[a].1;
        p.levels[i].cov[k][k] + p.input_cov(i, i, sd) * p.slopes[i][k].powi(2)
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

/// Each parameter's levels against what the rest of the model predicts there, the law's
/// coefficients refitted without it ([`leave_one_out_z2`]). The sum of the
/// squared z's has its levels' number as mean when the model the calibration keeps (law,
/// departures and read errors at their fitted sizes) explains the levels; a level it cannot
/// predict, a read error beyond σₑ or a law bent by one level, raises it. The law alone is not
/// the test: a strip with departures misses it by construction.
pub(super) fn kept_tests(post: &Posterior, h: &DMatrix<f64>, obs: &[(usize, usize)]) -> [Option<LawTest>; 4] {
    let z2 = leave_one_out_z2(post, h);
    core::array::from_fn(|k| {
        let rows: Vec<usize> = (0..obs.len()).filter(|&a| obs[a].0 == k).collect();
        let chi2 = rows.iter().map(|&a| z2[a]).sum::<f64>();
        (rows.len() >= 2 && chi2.is_finite()).then(|| LawTest { chi2, dof: rows.len(), p_value: chi2_tail(chi2, rows.len()) })
    })
}
