//! The model's data at given level humidities: each level's ln θₖ less the base law's ln there,
//! the correction's polynomial basis, and the observations' covariance and restricted likelihood
//! at given hyperparameters.
//!
//! A level's four values carry their fit's covariance plus the read error along the laws'
//! slopes, σₑ²·ssᵀ: the read error moves all four along their laws together, which is how the
//! levels tell it from the strip's departures (d, steep at high humidity, says most). Two levels'
//! departures covary as at their uncertain humidities ([`kernel`]), while each level's has the
//! full A²: a departure that would have to change within the read error to follow the levels is
//! no better than noise. The visits of one setpoint are one humidity: they share their mean
//! reading's error and differ only by how far the chamber left each (σₛ). Taken as two
//! humidities, two visits read apart that agree in value would claim the strip smooth over the
//! distance between the readings, and the departures' length would be set by the read errors
//! instead of by the setpoints.

use super::hyper::Spread;
use super::levels::LevelTheta;
use crate::gaussian_process::{Posterior, kernel, reml};
use crate::measure::chamber::Placement;
use ipmc_core::calibration::departures::DEPARTING;
use ipmc_core::{Calibration, ParamName};
use nalgebra::{DMatrix, DVector};

/// RH step [%] of the laws' slopes.
const SLOPE_STEP_PCT: f64 = 0.05;

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

/// The model's data at given level humidities.
#[derive(Clone)]
pub(super) struct Problem<'a> {
    pub(super) base: &'a Calibration,
    pub(super) levels: &'a [LevelTheta],
    /// (parameter, level)
    pub(super) obs: Vec<(usize, usize)>,
    pub(super) degree: [Option<usize>; 4],
    pub(super) col: [usize; 4],
    pub(super) ncol: usize,
    pub(super) center: f64,
    pub(super) half: f64,
    pub(super) gp: [bool; 4],
    /// Whether two levels' departures covary as at their uncertain humidities (else as at their
    /// readings).
    pub(super) uncertain_inputs: bool,
    /// Each level's humidity (its setpoint's readings' mean).
    pub(super) pos: Vec<f64>,
    /// Each level's setpoint (the index of its first visit) and how many visits it had.
    pub(super) site: Vec<usize>,
    pub(super) visits: Vec<usize>,
    /// Where the chamber's setpoints placed the levels, when the session states them.
    pub(super) placement: Option<Placement>,
    pub(super) y: DVector<f64>,
    pub(super) h: DMatrix<f64>,
    pub(super) slopes: Vec<[f64; 4]>,
}

impl<'a> Problem<'a> {
    /// The levels at humidities `pos` with variances `var`: the offsets (the base's law there)
    /// and the correction's basis.
    pub(super) fn place(&mut self, pos: Vec<f64>) -> Result<(), ModelError> {
        let mut y = DVector::zeros(self.obs.len());
        let mut h = DMatrix::zeros(self.obs.len(), self.ncol);
        for (a, &(k, i)) in self.obs.iter().enumerate() {
            let offset = ln_base(self.base, k, pos[i]);
            if !offset.is_finite() {
                return Err(ModelError::BaseNotPositive { param: DEPARTING[k], rh_pct: pos[i] });
            }
            y[a] = self.levels[i].ln[k].expect("observed") - offset;
            for (j, v) in basis(pos[i], self.center, self.half, self.degree[k].expect("observed")).enumerate() {
                h[(a, self.col[k] + j)] = v;
            }
        }
        (self.pos, self.y, self.h) = (pos, y, h);
        Ok(())
    }

    /// The law's ln at `x` with correction coefficients `beta`.
    pub(super) fn law_ln(&self, beta: &DVector<f64>, k: usize, x: f64) -> f64 {
        ln_base(self.base, k, x)
            + self.degree[k].map_or(0.0, |q| basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * beta[self.col[k] + j]).sum())
    }

    /// The laws' slopes at every level's humidity.
    pub(super) fn set_slopes(&mut self, beta: &DVector<f64>) {
        self.slopes = self
            .pos
            .iter()
            .map(|&x| {
                core::array::from_fn(|k| {
                    (self.law_ln(beta, k, x + SLOPE_STEP_PCT) - self.law_ln(beta, k, x - SLOPE_STEP_PCT)) / (2.0 * SLOPE_STEP_PCT)
                })
            })
            .collect();
    }

    /// The observations' covariance: departures (each level's value at its uncertain
    /// humidity), the levels' own errors, and the humidity's error along the laws.
    pub(super) fn covariance(&self, amplitude: &[f64; 4], length: &[f64; 4], sd: Spread) -> DMatrix<f64> {
        let n = self.obs.len();
        DMatrix::from_fn(n, n, |a, b| {
            let ((ka, ia), (kb, ib)) = (self.obs[a], self.obs[b]);
            let mut c = 0.0;
            if ka == kb && self.gp[ka] {
                // One level's departure is one value (its read error moves it along nothing);
                // two levels' are the departure at two humidities each known up to its error.
                let v = if ia == ib || !self.uncertain_inputs {
                    0.0
                } else {
                    self.input_cov(ia, ia, sd) + self.input_cov(ib, ib, sd) - 2.0 * self.input_cov(ia, ib, sd)
                };
                c += kernel(self.pos[ia] - self.pos[ib], amplitude[ka], length[ka], v);
            }
            if ia == ib {
                c += self.levels[ia].cov[ka][kb];
            }
            c + self.input_cov(ia, ib, sd) * self.slopes[ia][ka] * self.slopes[ib][kb]
        })
    }

    /// The covariance of two levels' true humidities about their positions: a lone level's is
    /// its reading's error; the visits of one setpoint share their mean reading's error and
    /// differ by how far the chamber left each.
    pub(super) fn input_cov(&self, ia: usize, ib: usize, sd: Spread) -> f64 {
        let n = self.visits[ia] as f64;
        if let Some(p) = &self.placement {
            let same = self.site[ia] == self.site[ib];
            let visit = if same && ia == ib && n > 1.0 { sd.setpoint * sd.setpoint } else { 0.0 };
            return p.input_cov(ia, ib, same, sd.read * sd.read / n) + visit;
        }
        if self.site[ia] != self.site[ib] {
            0.0
        } else if n == 1.0 {
            sd.read * sd.read
        } else {
            sd.read * sd.read / n + if ia == ib { sd.setpoint * sd.setpoint } else { 0.0 }
        }
    }

    /// −(restricted log likelihood) up to a constant, and the pieces of the posterior.
    pub(super) fn reml(&self, c: DMatrix<f64>) -> Option<(f64, Posterior)> {
        reml(c, &self.y, &self.h)
    }
}

/// The polynomial basis of a parameter's correction at `x`.
pub(super) fn basis(x: f64, center: f64, half: f64, degree: usize) -> impl Iterator<Item = f64> {
    (0..=degree).map(move |j| ((x - center) / half).powi(j as i32))
}

pub(super) fn ln_base(base: &Calibration, k: usize, rh: f64) -> f64 {
    let law = base.law(DEPARTING[k]).expect("departing parameters have laws");
    let v: f64 = law.eval(rh);
    v.ln()
}
