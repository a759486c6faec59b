//! A Levenberg–Marquardt step needs a Jacobian J and residuals r only through JᵀJ, Jᵀr and ‖r‖.
//! Where J's columns each reach one block of rows or every block ([`Reach`]: a humidity level's
//! own parameters, a model's global ones), those three come from a QR factor computed block by
//! block: O(m·(p + k)²) for blocks of p own and k global parameters, where a dense QR of J costs
//! O(m·n²) with n = k + Σp. A joint fit of 19 levels spent 65 % of its time in that dense QR.

use nalgebra::{DMatrix, DVector};

/// Which rows a column of J reaches: which residuals a parameter of a block problem moves
/// ([`super::fit_blocks`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reach {
    /// Every block's.
    Global,
    /// Only those of the block with this index.
    Block(usize),
}

/// R (n × n, triangular up to the order of its columns) and c with RᵀR = JᵀJ and Rᵀc = Jᵀr, and
/// ‖r‖² − ‖c‖², the part of r no change of the parameters can reach.
pub struct Factor {
    pub r: DMatrix<f64>,
    pub c: DVector<f64>,
    pub rest: f64,
}

/// The factor of `jac` (m × n) and `res` (m), with rows `offsets[b]..offsets[b + 1]` block b and
/// column j zero outside the block `reach[j]` names (taken as zero there, not read).
///
/// Each block's rows are triangularized over its own columns, then its globals' and the
/// residual's (one QR of m_b × (p_b + k + 1)); its first p_b rows are final rows of R. What each
/// block leaves in the global columns is stacked (at most k + 1 rows per block) and
/// triangularized once more; the last diagonal entry is the residual's norm outside J's columns.
pub fn factor(jac: &DMatrix<f64>, res: &[f64], offsets: &[usize], reach: &[Reach]) -> Factor {
    let n = reach.len();
    let globals: Vec<usize> = (0..n).filter(|&j| reach[j] == Reach::Global).collect();
    let k = globals.len();
    let mut r = DMatrix::zeros(n, n);
    let mut c = DVector::zeros(n);
    let mut row = 0;
    let mut left: Vec<DMatrix<f64>> = Vec::with_capacity(offsets.len());
    for (b, w) in offsets.windows(2).enumerate() {
        let own: Vec<usize> = (0..n).filter(|&j| reach[j] == Reach::Block(b)).collect();
        let cols: Vec<usize> = own.iter().chain(&globals).copied().collect();
        let rows = w[0]..w[1];
        let a =
            DMatrix::from_fn(
                rows.len(),
                cols.len() + 1,
                |i, j| if j < cols.len() { jac[(rows.start + i, cols[j])] } else { res[rows.start + i] },
            );
        let t = a.qr().r();
        for i in 0..own.len().min(t.nrows()) {
            for (j, &col) in cols.iter().enumerate() {
                r[(row, col)] = t[(i, j)];
            }
            c[row] = t[(i, cols.len())];
            row += 1;
        }
        if t.nrows() > own.len() {
            left.push(t.view((own.len(), own.len()), (t.nrows() - own.len(), k + 1)).into_owned());
        }
    }
    // Rows of blocks with fewer rows than own columns leave their last own columns without a
    // row: R keeps zero rows there, as a dense QR's would be (those directions are undetermined).
    let stacked_rows: usize = left.iter().map(|m| m.nrows()).sum();
    let mut stacked = DMatrix::zeros(stacked_rows.max(k + 1), k + 1);
    let mut at = 0;
    for m in &left {
        stacked.view_mut((at, 0), (m.nrows(), k + 1)).copy_from(m);
        at += m.nrows();
    }
    let t = stacked.qr().r();
    for i in 0..k.min(t.nrows()) {
        if row >= n {
            break;
        }
        for (j, &col) in globals.iter().enumerate() {
            r[(row, col)] = t[(i, j)];
        }
        c[row] = t[(i, k)];
        row += 1;
    }
    let rest = if t.nrows() > k { t[(k, k)].abs() } else { 0.0 };
    Factor { r, c, rest }
}

/// A least-squares problem of n + 1 rows whose LM step is J's: residuals (‖r‖, 0, …, 0) and a
/// Jacobian J̃ = [gᵀ; M] with g = Jᵀr/‖r‖ and MᵀM = Jᵀ(I − r rᵀ/‖r‖²)J, so J̃ᵀJ̃ = JᵀJ,
/// J̃ᵀr̃ = Jᵀr and ‖r̃‖ = ‖r‖. The residuals at a trial point are then its norm alone: the
/// optimizer keeps them for the next step, and no Jacobian is needed where a trial is refused.
pub fn reduced_jacobian(f: &Factor, norm: f64) -> DMatrix<f64> {
    let n = f.r.ncols();
    let mut a = DMatrix::zeros(n + 1, n);
    a.view_mut((0, 0), (n, n)).copy_from(&f.r);
    let mut u = DVector::zeros(n + 1);
    u.rows_mut(0, n).copy_from(&f.c);
    u[n] = f.rest;
    let mut out = DMatrix::zeros(n + 1, n);
    let u_norm = u.norm();
    if norm > 0.0 && u_norm > 0.0 {
        u /= u_norm;
        let g = f.r.transpose() * &f.c / norm;
        out.row_mut(0).copy_from(&g.transpose());
        let ut_a = u.transpose() * &a;
        a -= &u * ut_a;
    }
    let m = a.qr().r();
    out.view_mut((1, 0), (n, n)).copy_from(&m);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two blocks of 6 and 4 rows, two own columns each, one global column in the middle of the
    /// order: R, c and the rest reproduce JᵀJ, Jᵀr and ‖r‖², and the reduced problem keeps them.
    #[test]
    fn the_factor_keeps_what_a_step_needs() {
        let reach = [Reach::Block(0), Reach::Global, Reach::Block(0), Reach::Block(1), Reach::Block(1)];
        let offsets = [0, 6, 10];
        let value = |i: usize, j: usize| ((i * 31 + j * 17) % 23) as f64 / 7.0 - 1.3;
        let jac = DMatrix::from_fn(10, 5, |i, j| match reach[j] {
            Reach::Global => value(i, j),
            Reach::Block(b) if (offsets[b]..offsets[b + 1]).contains(&i) => value(i, j),
            Reach::Block(_) => 0.0,
        });
        let res: Vec<f64> = (0..10).map(|i| ((i * 13) % 11) as f64 / 3.0 - 1.5).collect();
        let rv = DMatrix::from_column_slice(10, 1, &res);
        let f = factor(&jac, &res, &offsets, &reach);
        let close = |a: &DMatrix<f64>, b: &DMatrix<f64>| (a - b).amax() < 1e-10 * b.amax().max(1.0);
        let jtj = jac.transpose() * &jac;
        let jtr = jac.transpose() * &rv;
        assert!(close(&(f.r.transpose() * &f.r), &jtj));
        let c = DMatrix::from_column_slice(5, 1, f.c.as_slice());
        assert!(close(&(f.r.transpose() * c), &jtr));
        assert!((f.c.norm_squared() + f.rest * f.rest - rv.norm_squared()).abs() < 1e-10 * rv.norm_squared());
        // A random r lies mostly outside five columns of ten rows.
        assert!(f.rest > 0.1 * rv.norm());
        let jr = reduced_jacobian(&f, rv.norm());
        assert!(close(&(jr.transpose() * &jr), &jtj));
        let mut r_reduced = DMatrix::zeros(6, 1);
        r_reduced[(0, 0)] = rv.norm();
        assert!(close(&(jr.transpose() * r_reduced), &jtr));
    }
}
