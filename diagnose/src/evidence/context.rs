//! What every candidate's scorer starts from: the calibration and data, the noise's σ, the
//! per-level base fits of the plain model and the humidity laws' weights, and the plain model's
//! figures every candidate is scored against.

use crate::evidence::laws::{LawWeights, Regressors};
use crate::fits::{self, BaseFits, LevelSigmas, Mask, Theta};
use crate::input::data::Dataset;
use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_core::model::extension::Extension;

pub(crate) struct Ctx<'a> {
    pub calib: &'a Calibration,
    pub data: &'a Dataset,
    pub sig: Vec<LevelSigmas>,
    /// Every measured value of each level.
    pub all: Vec<Mask>,
    /// The plain model refitted at every level with the noise's σ.
    pub base: BaseFits,
    /// The humidity as read, the regressor of the plain laws.
    pub read: Regressors,
    pub weights: LawWeights,
    /// ∂θ/∂RH of the calibration at each level's reading ([`crate::evidence::laws::read_gradient`]).
    pub read_gradient: Vec<Theta>,
    /// The instrument's channels as the plain model left them, for a model candidate's joint
    /// fit to move under their prior (None: every tolerance zero).
    pub channel_prior: Option<fits::ChannelPrior>,
    /// Where a model candidate's joint fit starts the channels.
    pub channel_start: fits::ChannelStart,
}

/// Per-level outcome of a candidate, what held-out scoring needs.
pub(crate) struct Fitted {
    pub theta: Vec<Theta>,
    pub se: Vec<Theta>,
    pub ext: Vec<Extension<f64>>,
    pub masks: Vec<Mask>,
    pub regressors: Regressors,
    /// The instrument's channels as the fit moved them from where the plain model put them
    /// (a model candidate's joint fit; none for the others).
    pub channels: fits::Channels,
}

impl Fitted {
    /// The levels of `data` as this fit's channels leave them: what its residuals are of.
    pub fn levels(&self, data: &Dataset) -> Vec<ipmc_fit::level::LevelData> {
        data.levels.iter().map(|l| self.channels.corrected(l)).collect()
    }
}

/// What every candidate is scored against: the plain model's fits and the counts the
/// information criterion needs.
pub(crate) struct Baseline {
    /// Residuals per level (the weights of per-level means).
    pub counts: Vec<f64>,
    /// Residuals in all.
    pub n_data: f64,
    /// χ² of the per-level refit of the plain model.
    pub chi2_0: f64,
    /// −2 ln L of free humidity laws through the levels' parameters, and their parameter count.
    pub law0: (f64, usize),
    /// Number of level parameters the fits determined.
    pub n_theta: f64,
    /// Held-out score of the plain humidity laws: a candidate that cannot be tested keeps it.
    pub heldout_before: f64,
}

impl<'a> Ctx<'a> {
    /// The per-level refit and noise of the plain model: a first fit with σ = 1, the noise from
    /// its neighbouring-point scatter, the fit again with that noise. Also returns the
    /// calibration's θ at each level, where the first fit started.
    pub fn new(calib: &'a Calibration, data: &'a Dataset) -> Result<(Self, fits::Noise, Vec<Theta>)> {
        let levels = &data.levels;
        let none = Extension::default();
        let all: Vec<Mask> = levels.iter().map(Mask::all).collect();
        let cal_theta: Vec<Theta> = levels.iter().map(|l| fits::calibration_theta(calib, l.rh_pct)).collect();
        let unit: Vec<LevelSigmas> = levels.iter().map(fits::unit_sigmas).collect();
        let first = fits::fit_levels(calib, levels, &unit, &all, &none, &cal_theta)?;
        let noise = fits::estimate_noise(calib, levels, &first.theta);
        let sig: Vec<LevelSigmas> = levels.iter().map(|l| fits::sigmas(l, &noise)).collect();
        let base = fits::fit_levels(calib, levels, &sig, &all, &none, &first.theta)?;
        let read = Regressors { x: levels.iter().map(|l| l.rh_pct).collect(), temperature: None };
        let weights = LawWeights::estimate(&read, &base.theta, &base.se);
        let read_gradient = crate::evidence::laws::read_gradient(calib, &read.x);
        Ok((
            Ctx {
                calib,
                data,
                sig,
                all,
                base,
                read,
                weights,
                read_gradient,
                channel_prior: None,
                channel_start: fits::ChannelStart::Plain,
            },
            noise,
            cal_theta,
        ))
    }

    /// The plain model's per-level fits as a candidate's outcome.
    pub fn plain(&self) -> Fitted {
        let n = self.data.levels.len();
        Fitted {
            theta: self.base.theta.clone(),
            se: self.base.se.clone(),
            ext: vec![Extension::default(); n],
            masks: self.all.clone(),
            regressors: self.read.clone(),
            channels: fits::Channels::default(),
        }
    }

    /// The humidity each level was read at.
    pub fn read_rh(&self) -> Vec<f64> {
        self.data.levels.iter().map(|l| l.rh_pct).collect()
    }

    pub fn n_levels(&self) -> usize {
        self.data.levels.len()
    }
}

pub(crate) fn total_residuals(masks: &[Mask]) -> usize {
    masks.iter().map(|m| m.count()).sum()
}
