//! The restricted likelihood of observations with a given covariance and mean basis (the mean's
//! coefficients integrated out), the posterior it leaves, the posterior variance at a point, and
//! each observation's leave-one-out residual.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// What a posterior at fixed hyperparameters is made of: the covariance's Cholesky factor C,
/// the mean's generalized-least-squares coefficients β, α = C⁻¹(y − Hβ) and (HᵀC⁻¹H)⁻¹.
#[derive(Clone, Debug)]
pub struct Posterior {
    pub chol: Cholesky<f64, Dyn>,
    pub beta: DVector<f64>,
    pub alpha: DVector<f64>,
    pub hch_inv: DMatrix<f64>,
}

/// −(restricted log likelihood) of `y` with covariance `c` and mean basis `h` (coefficients
/// integrated out), and the posterior's pieces.
pub fn reml(c: DMatrix<f64>, y: &DVector<f64>, h: &DMatrix<f64>) -> Option<(f64, Posterior)> {
    let chol = c.cholesky()?;
    let l = chol.l();
    let logdet: f64 = 2.0 * l.diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let z = l.solve_lower_triangular(h)?;
    let w = l.solve_lower_triangular(y)?;
    let hch = z.transpose() * &z;
    let hch_chol = hch.cholesky()?;
    let logdet_h: f64 = 2.0 * hch_chol.l().diagonal().iter().map(|d| d.ln()).sum::<f64>();
    let beta = hch_chol.solve(&(z.transpose() * &w));
    let r = &w - &z * &beta;
    let v = 0.5 * (logdet + logdet_h + r.dot(&r));
    let alpha = chol.solve(&(y - h * &beta));
    v.is_finite().then(|| (v, Posterior { chol, beta, alpha, hch_inv: hch_chol.inverse() }))
}

/// The posterior variance at a point with process covariances `ks`, prior variance `prior`
/// and mean basis `hx` there (columns from `col` of the basis `h`): the process's and the mean
/// coefficients'.
pub fn posterior_var(
    chol: &Cholesky<f64, Dyn>,
    h: &DMatrix<f64>,
    hch_inv: &DMatrix<f64>,
    ks: &DVector<f64>,
    prior: f64,
    hx: impl Iterator<Item = f64>,
    col: usize,
) -> f64 {
    let cinv_k = chol.solve(ks);
    let mut full = DVector::zeros(h.ncols());
    for (j, b) in hx.enumerate() {
        full[col + j] = b;
    }
    let r = full - h.transpose() * &cinv_k;
    prior - ks.dot(&cinv_k) + r.dot(&(hch_inv * &r))
}

/// Each observation against what the others predict there, the mean's coefficients refitted
/// without it, as a squared z. In closed form for a linear model with known covariance C and
/// mean basis H: with P = C⁻¹ − C⁻¹H(HᵀC⁻¹H)⁻¹HᵀC⁻¹, the held-out residual is (Py)ᵢ/Pᵢᵢ with
/// variance 1/Pᵢᵢ, and Py is the posterior's α.
pub fn leave_one_out_z2(post: &Posterior, h: &DMatrix<f64>) -> Vec<f64> {
    let cinv = post.chol.inverse();
    let q = &cinv * h;
    (0..post.alpha.len())
        .map(|a| {
            let p_aa = cinv[(a, a)] - (q.row(a) * &post.hch_inv * q.row(a).transpose())[(0, 0)];
            post.alpha[a] * post.alpha[a] / p_aa
        })
        .collect()
}
