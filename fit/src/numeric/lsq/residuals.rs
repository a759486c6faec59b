//! How the optimizer gets residuals: a dense residual function, or one evaluated block by block
//! where each parameter moves every block or one block only.

use super::block_qr::Reach;

/// The layout of a problem whose residuals come in consecutive blocks.
#[derive(Clone, Copy, Debug)]
pub struct Blocks<'a> {
    /// Residual count of each block, in the order the blocks are laid out in the residual vector.
    pub sizes: &'a [usize],
    /// For each parameter (in the order of `params`), which residuals it moves.
    pub reach: &'a [Reach],
}

/// How the optimizer gets residuals: all of them, or those one parameter moves.
pub(super) trait Residuals {
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
pub(super) struct Dense<F> {
    pub(super) n_residuals: usize,
    pub(super) f: F,
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

/// A residual function evaluated block by block ([`fit_blocks`](super::fit_blocks)).
pub(super) struct Blocked<'a, F> {
    /// Where each block starts in the residual vector, and the total at the end.
    pub(super) offsets: Vec<usize>,
    pub(super) reach: &'a [Reach],
    pub(super) f: F,
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
