//! Held-out scoring: each level in turn predicted by a model whose tested part was fitted on
//! the other levels, scored by its χ² per residual, and the paired comparison of two such
//! scores over levels.

use crate::evidence::context::{Ctx, Fitted};
use crate::evidence::laws::{self, LawWeights};
use crate::fits::{self, Mask, Theta};
use ipmc_core::model::extension::Extension;

/// The model that scored one level held out (see [`crate::engine`] for each kind of candidate).
#[derive(Clone, Debug)]
pub struct HeldOutModel {
    pub params: ipmc_core::Params<f64>,
    pub extension: Extension<f64>,
    /// Values scored with their variance σ² multiplied by the factor: the mains candidate's line
    /// points, by 1 + the interference power of the other levels.
    pub inflated: Option<(Mask, f64)>,
    /// The level's held-out score: (Σ (residual/σ)² over all its values, σ inflated where
    /// `inflated` says, + [`HeldOutModel::normalization`]) / number of residuals.
    pub chi2_per_residual: f64,
    /// The instrument's channels as the candidate moved them beside its own fit, on top of
    /// those every candidate is scored with: the level this model scores is the recording with
    /// them taken out too (None: no move).
    pub channels: Option<crate::fits::Channels>,
}

impl HeldOutModel {
    /// The inflated variance's share of −2 ln L (m ln factor for m inflated residuals): without
    /// it, inflating σ would lower the score for free.
    pub fn normalization(&self) -> f64 {
        self.inflated.as_ref().map_or(0.0, |(mask, factor)| mask.count() as f64 * factor.ln())
    }
}

/// A candidate's held-out models per level and its null's, and what each is.
pub(crate) struct HeldOut {
    pub null: Vec<HeldOutModel>,
    pub null_is: String,
    pub candidate: Vec<HeldOutModel>,
    pub candidate_is: String,
}

pub(crate) const REFIT_NULL_IS: &str = "the base model refitted at the level";
pub(crate) const ANCHORED_NULL_IS: &str = "the calibration at the humidity as read plus the mean drift from it of the other levels";

pub(crate) fn per_level_scores(models: &[HeldOutModel]) -> Vec<f64> {
    models.iter().map(|m| m.chi2_per_residual).collect()
}

impl Ctx<'_> {
    /// Level `l`'s held-out model scored on all its values.
    pub fn scored(&self, l: usize, params: ipmc_core::Params<f64>, extension: Extension<f64>) -> HeldOutModel {
        let chi2 = fits::chi2(&self.data.levels[l], &self.sig[l], &self.all[l], &params, &extension);
        HeldOutModel { params, extension, inflated: None, chi2_per_residual: chi2 / self.all[l].count() as f64, channels: None }
    }

    /// The held-out model of each level with its base parameters from humidity laws fitted on
    /// the other levels' fits `f`.
    pub fn law_heldout(&self, f: &Fitted) -> Vec<HeldOutModel> {
        let w = LawWeights::estimate(&f.regressors, &f.theta, &f.se);
        let n = self.n_levels();
        (0..n)
            .map(|l| {
                let train: Vec<usize> = (0..n).filter(|&k| k != l).collect();
                // Never the level's own fit: where no law can be fitted, the calibration.
                let cal = fits::calibration_theta(self.calib, self.data.levels[l].rh_pct);
                let mut th: Theta = laws::predict(&f.regressors, &f.theta, &f.se, &w, &train, l);
                for j in 0..4 {
                    if !th[j].is_finite() {
                        th[j] = cal[j];
                    }
                }
                self.scored(l, fits::level_params(self.calib, &self.data.levels[l], &th), f.ext[l])
            })
            .collect()
    }

    /// The plain model's per-level refit, as held-out score: the null of model candidates.
    pub fn refit_null(&self) -> Vec<HeldOutModel> {
        (0..self.n_levels())
            .map(|l| HeldOutModel {
                params: fits::level_params(self.calib, &self.data.levels[l], &self.base.theta[l]),
                extension: Extension::default(),
                inflated: None,
                chi2_per_residual: self.base.chi2[l] / self.all[l].count() as f64,
                channels: None,
            })
            .collect()
    }
}

/// The relative precision of a held-out χ²: the fits that give one stop at a step gaining less
/// than this share of their χ² (the least squares' reporting tolerance, the tightest any of
/// them uses), so two fits of one model to one level agree only to about this much of it.
pub(crate) const CHI2_RESOLUTION: f64 = ipmc_fit::lsq::Tolerance::REPORT.ftol;

/// Paired z of the held-out improvement over levels: the mean of the levels' χ² differences
/// (`before` − `after`, per residual, times the level's `weights`) over its standard error. Each
/// difference is known only to the resolution of the two χ² it subtracts
/// ([`CHI2_RESOLUTION`] of each), and that uncertainty joins the levels' scatter: a candidate
/// whose fit came back to its null (an extension fitted to zero) differs from it by a few parts
/// in 10¹³ at every level, all of one sign, which is the fits' arithmetic, not an improvement
/// however consistent its sign.
pub(crate) fn paired_z(before: &[f64], after: &[f64], weights: &[f64]) -> f64 {
    let d: Vec<f64> = before.iter().zip(after).zip(weights).map(|((b, a), w)| (b - a) * w).collect();
    let resolution: f64 =
        before.iter().zip(after).zip(weights).map(|((b, a), w)| (CHI2_RESOLUTION * w * (b.abs() + a.abs())).powi(2)).sum();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    let se2 = var / n + resolution / (n * n);
    if se2 <= 0.0 {
        return if mean > 0.0 { f64::INFINITY } else { 0.0 };
    }
    mean / se2.sqrt()
}

pub(crate) fn weighted_mean(v: &[f64], w: &[f64]) -> f64 {
    v.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / w.iter().sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A consistent improvement the levels' scatter leaves significant keeps its z; differences
    /// at the fits' resolution, of one sign at every level, are no evidence.
    #[test]
    fn differences_at_the_fits_resolution_are_no_improvement() {
        let before = [0.40, 0.35, 0.38, 0.36, 0.41, 0.37];
        let counts = [600.0; 6];
        let improved: Vec<f64> = before.iter().enumerate().map(|(i, b)| b - 0.004 - 0.001 * (i % 2) as f64).collect();
        assert!(paired_z(&before, &improved, &counts) > 5.0);
        let returned: Vec<f64> = before.iter().enumerate().map(|(i, b)| b * (1.0 - 3e-13 * (1.0 + 0.1 * i as f64))).collect();
        let z = paired_z(&before, &returned, &counts);
        assert!(z.abs() < 0.1, "{z}");
        assert_eq!(paired_z(&before, &before, &counts), 0.0);
    }
}
