//! The LM crate's view of a problem: the parameters' unconstrained coordinates, residuals
//! evaluated once per point, forward-difference Jacobians, and the statistics at the optimum.

use super::block_qr;
use super::bound::Param;
use super::outcome::Fit;
use super::residuals::Residuals;
use levenberg_marquardt::LeastSquaresProblem;
use nalgebra::{DMatrix, DVector, Dyn, Owned};

/// Forward-difference step in u (relative step for `Positive` parameters).
const DIFF_STEP: f64 = 1e-7;
/// Singular values of J below this fraction of the largest are taken as zero: forward
/// differences leave errors of about `DIFF_STEP` in J, so smaller ones are noise, and a
/// direction a million times worse determined than the best one is undetermined for any use.
const SINGULAR_RATIO: f64 = 1e-6;

/// The LM crate's view of a problem: coordinates u, residuals by the caller's function.
pub(super) struct Problem<'a, R> {
    params: &'a [Param],
    pub(super) u: DVector<f64>,
    pub(super) model: &'a R,
    /// Residual values computed so far: a block evaluation costs its share of a full one.
    pub(super) rows_evaluated: core::cell::Cell<usize>,
    /// The residuals at the last u they were computed at: LM asks for the residuals and then
    /// the Jacobian at the same point, and the Jacobian's differences start from them.
    at_u: core::cell::RefCell<Option<(DVector<f64>, Vec<f64>)>>,
}

impl<'a, R: Residuals> Problem<'a, R> {
    pub(super) fn new(params: &'a [Param], u: DVector<f64>, model: &'a R) -> Self {
        Problem { params, u, model, rows_evaluated: core::cell::Cell::new(0), at_u: Default::default() }
    }

    /// Full model evaluations spent so far (block evaluations added up).
    pub(super) fn evaluations(&self) -> usize {
        self.rows_evaluated.get().div_ceil(self.model.len().max(1))
    }

    fn count(&self, rows: usize) {
        self.rows_evaluated.set(self.rows_evaluated.get() + rows);
    }

    pub(super) fn theta(&self, u: &DVector<f64>) -> Vec<f64> {
        self.params.iter().zip(u.iter()).map(|(p, &x)| p.bound.to_theta(x)).collect()
    }

    fn eval(&self, u: &DVector<f64>, out: &mut [f64]) -> bool {
        self.count(out.len());
        self.model.all(&self.theta(u), out);
        out.iter().all(|r| r.is_finite())
    }

    /// The residuals at the current u (computed once per u).
    pub(super) fn eval_here(&self, out: &mut [f64]) -> bool {
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

    pub(super) fn chi2(&self) -> f64 {
        let mut r = vec![0.0; self.model.len()];
        if self.eval_here(&mut r) { r.iter().map(|x| x * x).sum() } else { f64::INFINITY }
    }

    /// Forward differences in u: per parameter, one evaluation of the residuals it moves (the
    /// other rows of its column stay zero).
    pub(super) fn jacobian_at(&self, r0: &[f64]) -> Option<DMatrix<f64>> {
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

    pub(super) fn statistics(&self, chi2: f64) -> Fit {
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
