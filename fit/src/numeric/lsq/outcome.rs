//! What a fit gives back (estimates and their statistics, or why there are none) and when
//! Levenberg–Marquardt stops.

use nalgebra::DMatrix;

/// The outcome of [`fit`](super::fit): estimates in natural units and their statistics.
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
    /// Model evaluations spent over all starts (the cost of the fit; for
    /// [`fit_blocks`](super::fit_blocks), block evaluations are added up as their share of the
    /// residuals).
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
    /// A block problem's layout does not match its parameters ([`fit_blocks`](super::fit_blocks)).
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
