//! The diagnosis: compare with the calibration, refit per level, estimate the noise, test every
//! candidate by a joint fit, held-out levels and an information criterion, and decide.
//!
//! **Held out.** Each level in turn is left out, and the score is its χ² per residual (1 = at
//! the noise), each candidate against its own null:
//! - a model candidate's global parameters are fitted on the other levels (their base
//!   parameters held where the joint fit put them) and the held-out level's own four base
//!   parameters are refitted with them, as the plain model's are: the level's drift from the
//!   calibration is not the candidate's business, and judging the candidate by humidity laws
//!   would bury a small effect under the scatter of the parameters between levels;
//! - mains interference: the level refitted without its line points, which are scored by the
//!   interference power the other levels show;
//! - hydration lag and humidity sensor error: the level's base parameters from the calibration
//!   at the remapped humidity (τ, or offset and gain, from the other levels) plus the other
//!   levels' mean drift from it, against the calibration at the humidity as read plus that
//!   drift;
//! - temperature: the level's base parameters predicted by humidity (and temperature) laws
//!   fitted on the other levels, against the humidity laws alone.
//!
//! With no effect named, the numbers and figures are the per-level refit's.
//!
//! **Information criterion.** BIC differences ΔBIC = Δχ² − Δk·ln N on the data (model and mains
//! candidates) or on the per-level parameters (candidates acting through humidity).
//!
//! **Decision.** A candidate must beat "no extension" by ΔBIC ≥ [`MIN_DELTA_BIC`] and lower the
//! held-out χ² with a paired significance over levels z ≥ [`MIN_HELDOUT_Z`] (a weak gate: the
//! held-out differences between levels are heavy-tailed, a few levels carry an effect that
//! grows with humidity or temperature, so the strong gate is the information criterion); among
//! those the largest ΔBIC wins, the held-out z breaking near-ties (ΔBIC within 2, where the
//! runner-up is named as indistinguishable). A humidity remap must move some level by
//! [`MIN_RH_SHIFT_PCT`], mains lines must stand out from their neighbours ([`MIN_LINE_Z`]).
//! With none passing, the verdict is "none" if the
//! per-level refit leaves no structured residual (neighbour correlation, [`fits::structure_z`]),
//! "unexplained" if it does. A winner that removes less than half of a structured residual's
//! neighbour correlation is still named (it passed both gates), with the remainder reported.

use super::candidates::{Candidate, HumidityMap, Kind, LIBRARY};
use super::data::Dataset;
use super::fits::{self, BaseFits, LevelSigmas, Mask, Noise, Theta};
use super::laws::{self, LawWeights, Regressors};
use super::locate::{self, Located};
use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_core::extension::Extension;
use ipmc_core::humidity_path::HumidityPath;
use ipmc_fit::lsq::{self, Bound, Param, Tolerance};

/// Very strong evidence on Kass & Raftery's scale (ΔBIC > 10 ⇔ Bayes factor > 150).
pub const MIN_DELTA_BIC: f64 = 10.0;
/// Two candidates are told apart only when one beats the other by the evidence a candidate
/// needs to be named at all ([`MIN_DELTA_BIC`], "very strong" on Kass & Raftery's scale):
/// every passing candidate whose ΔBIC is within this of the best is reported as
/// indistinguishable from it. A confident wrong name is worse than an honest pair.
pub const INDISTINGUISHABLE_BIC: f64 = MIN_DELTA_BIC;
/// Paired improvement of the held-out χ² over levels, in standard errors.
pub const MIN_HELDOUT_Z: f64 = 0.5;
/// How much worse than their neighbours in frequency the values at the mains lines must fit
/// for interference to be named (z): a broadband misfit raises both alike.
pub const MIN_LINE_Z: f64 = 3.0;
/// Smallest humidity shift [%RH] a sensor error or hydration lag must cause at some level to
/// be named: a tenth of a percent is within one reading's scatter and of no use to anyone,
/// while the sensors this product reads (HTS221, HIH-4030) are specified to ±3.5 %RH.
pub const MIN_RH_SHIFT_PCT: f64 = 1.0;
/// z of the neighbour correlation of residuals ([`fits::structure_z`]) above which a residual
/// counts as structured.
pub const STRUCTURED_Z: f64 = 5.0;

/// One candidate's fitted parameter.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Estimate {
    pub name: String,
    pub unit: String,
    pub value: f64,
    pub std_error: f64,
}

/// A candidate's scores.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Score {
    pub name: String,
    pub family: String,
    /// Whether the data allow testing it (times for hydration, varying temperature…).
    pub applicable: bool,
    pub params: Vec<Estimate>,
    /// χ² improvement over no extension (data or per-level parameters, see `space`).
    pub delta_chi2: f64,
    pub extra_params: usize,
    pub delta_bic: f64,
    /// "data" or "level parameters".
    pub space: String,
    pub heldout: f64,
    pub heldout_per_level: Vec<f64>,
    /// The same held-out score of the candidate's null (no extension, the humidity as read).
    pub heldout_null: f64,
    pub heldout_null_per_level: Vec<f64>,
    pub heldout_z: f64,
    pub passes: bool,
    pub note: String,
    /// Every gate but the information criterion passed (held-out, floors): `passes` is this and
    /// ΔBIC ≥ [`MIN_DELTA_BIC`] once ΔBIC is corrected for overdispersion.
    #[serde(skip)]
    other_gates: bool,
}

/// A candidate the data cannot separate from the verdict, with the evidence.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Alternative {
    pub name: String,
    pub delta_bic: f64,
    /// The verdict's ΔBIC minus this one's (< [`INDISTINGUISHABLE_BIC`]).
    pub delta_bic_gap: f64,
    pub heldout: f64,
    pub heldout_z: f64,
    /// Paired z over levels of the verdict's held-out χ² against this one's (positive: the
    /// verdict predicts held-out levels better), where both share a null.
    pub heldout_z_vs_verdict: Option<f64>,
    /// What measurement would separate the two.
    pub separate_by: String,
}

/// Per-level view for the report and its figures.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LevelSummary {
    pub rh_pct: f64,
    pub time_s: Option<f64>,
    pub temp_c: Option<f64>,
    pub revisit_of: Option<usize>,
    pub simulation_chi2_per_residual: f64,
    pub refit_chi2_per_residual: f64,
    pub heldout_before: f64,
    pub heldout_after: f64,
}

/// The model that scored one level held out (see the module's doc for each kind of candidate).
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
}

impl HeldOutModel {
    /// The inflated variance's share of −2 ln L (m ln factor for m inflated residuals): without
    /// it, inflating σ would lower the score for free.
    pub fn normalization(&self) -> f64 {
        self.inflated.as_ref().map_or(0.0, |(mask, factor)| mask.count() as f64 * factor.ln())
    }
}

/// The models a level's figures draw.
#[derive(Clone, Debug)]
pub struct LevelModels {
    /// The calibration at the level's humidity (the "simulation").
    pub simulation: ipmc_core::Params<f64>,
    /// The base model refitted at the level (in sample).
    pub refit: ipmc_core::Params<f64>,
    /// The held-out null the level's `heldout_before` scores.
    pub before: HeldOutModel,
    /// The winner held out, the level's `heldout_after` (None when the verdict names no effect).
    pub after: Option<HeldOutModel>,
}

pub struct Diagnosis {
    pub verdict: String,
    /// Passing candidates within [`INDISTINGUISHABLE_BIC`] of the verdict.
    pub indistinguishable: Vec<Alternative>,
    /// Overdispersion ĉ of the data's χ² (see [`overdispersion`]) that data-space ΔBIC are divided by.
    pub overdispersion: f64,
    pub family: String,
    pub explanation: String,
    pub params: Vec<Estimate>,
    pub heldout_before: f64,
    pub heldout_after: f64,
    pub located: Located,
    pub candidates: Vec<Score>,
    pub levels: Vec<LevelSummary>,
    pub noise: Noise,
    /// Per level, in the order of the dataset's levels.
    pub models: Vec<LevelModels>,
    /// What the held-out models before and after are (after: None when no effect is named).
    pub heldout_before_is: String,
    pub heldout_after_is: Option<String>,
    /// When the verdict is a part of the humidity path (hydration lag, sensor error): the whole
    /// path fitted at once (see [`fit_humidity_path`]), relative to the humidity the levels are
    /// at (the readings through the calibration's own path).
    pub humidity_path: Option<HumidityPath>,
}

/// A candidate's held-out models per level and its null's, and what each is.
struct HeldOut {
    null: Vec<HeldOutModel>,
    null_is: String,
    candidate: Vec<HeldOutModel>,
    candidate_is: String,
}

fn per_level_scores(models: &[HeldOutModel]) -> Vec<f64> {
    models.iter().map(|m| m.chi2_per_residual).collect()
}

const REFIT_NULL_IS: &str = "the base model refitted at the level";
const ANCHORED_NULL_IS: &str = "the calibration at the humidity as read plus the mean drift from it of the other levels";

/// Per-level outcome of a candidate, what held-out scoring needs.
struct Fitted {
    theta: Vec<Theta>,
    se: Vec<Theta>,
    ext: Vec<Extension<f64>>,
    masks: Vec<Mask>,
    regressors: Regressors,
}

struct Ctx<'a> {
    calib: &'a Calibration,
    data: &'a Dataset,
    sig: Vec<LevelSigmas>,
    all: Vec<Mask>,
    base: BaseFits,
    read: Regressors,
    weights: LawWeights,
}

impl Ctx<'_> {
    /// The held-out model of each level given per-level fits and their extension.
    fn heldout(&self, f: &Fitted, laws_for: &dyn Fn(&[usize], usize) -> Theta) -> Vec<HeldOutModel> {
        let n = self.data.levels.len();
        (0..n)
            .map(|l| {
                let train: Vec<usize> = (0..n).filter(|&k| k != l).collect();
                // Never the level's own fit: where no law can be fitted, the calibration.
                let cal = fits::calibration_theta(self.calib, self.data.levels[l].rh_pct);
                let mut th = laws_for(&train, l);
                for j in 0..4 {
                    if !th[j].is_finite() {
                        th[j] = cal[j];
                    }
                }
                self.scored(l, fits::level_params(self.calib, &self.data.levels[l], &th), f.ext[l])
            })
            .collect()
    }

    /// Level `l`'s held-out model scored on all its values.
    fn scored(&self, l: usize, params: ipmc_core::Params<f64>, extension: Extension<f64>) -> HeldOutModel {
        let chi2 = fits::chi2(&self.data.levels[l], &self.sig[l], &self.all[l], &params, &extension);
        HeldOutModel { params, extension, inflated: None, chi2_per_residual: chi2 / self.all[l].count() as f64 }
    }

    fn law_heldout(&self, f: &Fitted) -> Vec<HeldOutModel> {
        let w = LawWeights::estimate(&f.regressors, &f.theta, &f.se);
        self.heldout(f, &|train, at| laws::predict(&f.regressors, &f.theta, &f.se, &w, train, at))
    }

    fn plain(&self) -> Fitted {
        let n = self.data.levels.len();
        Fitted {
            theta: self.base.theta.clone(),
            se: self.base.se.clone(),
            ext: vec![Extension::default(); n],
            masks: self.all.clone(),
            regressors: self.read.clone(),
        }
    }

    /// The plain model's per-level refit, as held-out score: the null of model candidates.
    fn refit_null(&self) -> Vec<HeldOutModel> {
        (0..self.data.levels.len())
            .map(|l| HeldOutModel {
                params: fits::level_params(self.calib, &self.data.levels[l], &self.base.theta[l]),
                extension: Extension::default(),
                inflated: None,
                chi2_per_residual: self.base.chi2[l] / self.all[l].count() as f64,
            })
            .collect()
    }

    /// Held-out score of a model candidate (see the module's doc): per level, its parameters
    /// `phi` refitted on the other levels, then the level's base parameters with them.
    fn refit_heldout(&self, cand: &Candidate, ext: ExtFn, phi: &[f64], f: &Fitted) -> Vec<HeldOutModel> {
        let levels = &self.data.levels;
        let n = levels.len();
        let params: Vec<Param> = cand.params.iter().map(|s| Param::new(s.name, s.bound)).collect();
        let start = vec![cand.params.iter().zip(phi).map(|(s, &v)| fits::inside_tight(s.bound, v)).collect::<Vec<f64>>()];
        let p_joint: Vec<ipmc_core::Params<f64>> = (0..n).map(|l| fits::level_params(self.calib, &levels[l], &f.theta[l])).collect();
        (0..n)
            .map(|held| {
                let train: Vec<usize> = (0..n).filter(|&l| l != held).collect();
                let counts: Vec<usize> = train.iter().map(|&l| self.all[l].count()).collect();
                let phi_train = lsq::minimize(Tolerance::REPORT, &params, &start, counts.iter().sum(), |v, out| {
                    let mut at = 0;
                    for (&l, &c) in train.iter().zip(&counts) {
                        fits::write_residuals(
                            &levels[l],
                            &self.sig[l],
                            &self.all[l],
                            &p_joint[l],
                            &ext(v, &p_joint[l]),
                            &mut out[at..at + c],
                        );
                        at += c;
                    }
                })
                .map_or_else(|_| phi.to_vec(), |(v, _)| v);
                let x = ext(&phi_train, &p_joint[held]);
                let (params, chi2) = match fits::fit_level(self.calib, &levels[held], &self.sig[held], &self.all[held], &x, &f.theta[held])
                {
                    Ok((theta, fit)) => (fits::level_params(self.calib, &levels[held], &theta), fit.chi2),
                    Err(_) => (p_joint[held], fits::chi2(&levels[held], &self.sig[held], &self.all[held], &p_joint[held], &x)),
                };
                HeldOutModel { params, extension: x, inflated: None, chi2_per_residual: chi2 / self.all[held].count() as f64 }
            })
            .collect()
    }

    /// Held-out score of the mains candidate: per level, its refit without the line points plus
    /// those points scored with the predictive variance σ²(1 + P) per component, P being the
    /// interference power [σ²] the other levels show at their lines.
    fn mains_heldout(&self, f: &Fitted) -> Vec<HeldOutModel> {
        let levels = &self.data.levels;
        let n = levels.len();
        let lines: Vec<(f64, Mask)> = (0..n)
            .map(|l| {
                let mut lines = self.all[l].clone();
                for (on, keep) in lines.current.iter_mut().zip(&f.masks[l].current) {
                    *on = *on && !keep;
                }
                lines.tip.iter_mut().for_each(|b| *b = false);
                let p = fits::level_params(self.calib, &levels[l], &f.theta[l]);
                (fits::chi2(&levels[l], &self.sig[l], &lines, &p, &f.ext[l]), lines)
            })
            .collect();
        (0..n)
            .map(|held| {
                let (r2, m): (f64, usize) =
                    (0..n).filter(|&l| l != held).fold((0.0, 0), |(a, b), l| (a + lines[l].0, b + lines[l].1.count()));
                let power = if m > 0 { (r2 / m as f64 - 1.0).max(0.0) } else { 0.0 };
                let p = fits::level_params(self.calib, &levels[held], &f.theta[held]);
                let kept = fits::chi2(&levels[held], &self.sig[held], &f.masks[held], &p, &f.ext[held]);
                let (r2, held_lines) = &lines[held];
                let mut model = HeldOutModel {
                    params: p,
                    extension: f.ext[held],
                    inflated: Some((held_lines.clone(), 1.0 + power)),
                    chi2_per_residual: 0.0,
                };
                model.chi2_per_residual = (kept + r2 / (1.0 + power) + model.normalization()) / self.all[held].count() as f64;
                model
            })
            .collect()
    }
}

type ExtFn = fn(&[f64], &ipmc_core::Params<f64>) -> Extension<f64>;

fn total_residuals(masks: &[Mask]) -> usize {
    masks.iter().map(|m| m.count()).sum()
}

/// Paired z of the held-out improvement over levels.
fn paired_z(before: &[f64], after: &[f64], weights: &[f64]) -> f64 {
    let d: Vec<f64> = before.iter().zip(after).zip(weights).map(|((b, a), w)| (b - a) * w).collect();
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    if var <= 0.0 {
        return if mean > 0.0 { f64::INFINITY } else { 0.0 };
    }
    mean / (var / n).sqrt()
}

fn weighted_mean(v: &[f64], w: &[f64]) -> f64 {
    v.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / w.iter().sum::<f64>()
}

/// Runs the whole diagnosis. `progress` is told each step's name.
pub fn diagnose(calib: &Calibration, data: &Dataset, progress: &dyn Fn(&str)) -> Result<Diagnosis> {
    let levels = &data.levels;
    anyhow::ensure!(levels.len() >= 3, "a diagnosis needs at least three humidity levels, the recordings have {}", levels.len());
    for l in levels {
        anyhow::ensure!(l.freqs.len() >= 5, "the level at {:.1} %RH has only {} frequencies (at least 5 needed)", l.rh_pct, l.freqs.len());
    }
    progress("per-level refit and noise");
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
    let ctx = Ctx { calib, data, sig, all, base, read, weights };

    let n_levels = levels.len();
    let counts: Vec<f64> = ctx.all.iter().map(|m| m.count() as f64).collect();
    let n_data = total_residuals(&ctx.all) as f64;
    let simulation: Vec<f64> = (0..n_levels)
        .map(|l| fits::chi2(&levels[l], &ctx.sig[l], &ctx.all[l], &fits::level_params(calib, &levels[l], &cal_theta[l]), &none) / counts[l])
        .collect();
    let plain = ctx.plain();
    let plain_heldout = ctx.law_heldout(&plain);
    let chi2_0: f64 = ctx.base.chi2.iter().sum();
    let (law_pred_0, law_k_0) = laws::fitted(&ctx.read, &ctx.base.theta, &ctx.base.se);
    let law_chi2_0 = laws::nll(&law_pred_0, &ctx.base.theta, &ctx.base.se);
    let n_theta = ctx.base.se.iter().flatten().filter(|s| !s.is_nan()).count() as f64;

    let trace = std::env::var_os("IPMC_TRACE").is_some();
    if trace {
        eprintln!("base fits and noise done");
    }
    progress("locating the mismatch");
    let located = locate::locate(ctx.calib, data, &ctx.sig, &ctx.base, &cal_theta, &simulation)?;

    let mut scores = Vec::new();
    let mut fitted_of: Vec<Option<Fitted>> = Vec::new();
    let mut heldout_of: Vec<Option<HeldOut>> = Vec::new();
    for cand in LIBRARY {
        progress(cand.name);
        let t0 = std::time::Instant::now();
        let (score, fitted, heldout) =
            score_candidate(&ctx, cand, &plain_heldout, &counts, n_data, chi2_0, (law_chi2_0, law_k_0), n_theta)?;
        if std::env::var_os("IPMC_TRACE").is_some() {
            eprintln!(
                "{}: {:.2} s dBIC {:.1} heldout {:.3} null {:.3} z {:.1} {:?}",
                cand.name,
                t0.elapsed().as_secs_f64(),
                score.delta_bic,
                score.heldout,
                score.heldout_null,
                score.heldout_z,
                score.params.iter().map(|p| p.value).collect::<Vec<_>>()
            );
        }
        scores.push(score);
        fitted_of.push(fitted);
        heldout_of.push(heldout);
    }

    // Overdispersion: ΔBIC on the data as quasi-likelihood differences.
    let c_hat = overdispersion(&scores, chi2_0, n_data - 4.0 * n_levels as f64);
    for sc in scores.iter_mut().filter(|sc| sc.applicable && sc.space == "data") {
        sc.delta_bic = sc.delta_chi2 / c_hat - sc.extra_params as f64 * n_data.ln();
        sc.passes = sc.other_gates && sc.delta_bic >= MIN_DELTA_BIC;
    }
    // Decide.
    let structure_before = fits::structure_z(calib, levels, &ctx.sig, &ctx.all, &ctx.base.theta, &vec![none; n_levels]);
    let structured = structure_before > STRUCTURED_Z;
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| {
        let (sa, sb) = (&scores[a], &scores[b]);
        sb.passes.cmp(&sa.passes).then(sb.delta_bic.total_cmp(&sa.delta_bic))
    });
    let winner = order.first().copied().filter(|&i| scores[i].passes);
    let tied: Vec<usize> =
        winner.map_or_else(Vec::new, |w| order[1..].iter().copied().filter(|&i| indistinguishable(&scores[w], &scores[i])).collect());
    let alternatives: Vec<Alternative> = match winner {
        Some(w) => tied
            .iter()
            .map(|&i| {
                let (a, b) = (&scores[w], &scores[i]);
                let shared_null = a.space == b.space && a.heldout_null_per_level == b.heldout_null_per_level;
                Alternative {
                    name: b.name.clone(),
                    delta_bic: b.delta_bic,
                    delta_bic_gap: a.delta_bic - b.delta_bic,
                    heldout: b.heldout,
                    heldout_z: b.heldout_z,
                    heldout_z_vs_verdict: shared_null.then(|| paired_z(&b.heldout_per_level, &a.heldout_per_level, &counts)),
                    separate_by: separating_measurement(&a.name, &b.name),
                }
            })
            .collect(),
        None => vec![],
    };
    let refit_before = weighted_mean(&per_level_scores(&ctx.refit_null()), &counts);
    let (verdict, family, explanation, params, before_after) = match winner {
        Some(i) => {
            let s = &scores[i];
            let f = fitted_of[i].as_ref().expect("a passing candidate was fitted");
            let after = fits::structure_z(calib, levels, &ctx.sig, &f.masks, &f.theta, &f.ext);
            // The share of the neighbour correlation the winner removes.
            // Candidates acting through humidity explain the levels' parameters, not the shape
            // within a level: the structure test is for candidates fitted to the data.
            let explained = if structured && s.space == "data" { 1.0 - after.max(0.0) / structure_before } else { 1.0 };
            // A candidate that passes both gates explains part of the mismatch even when a
            // structured residual remains (a second effect, or a law the candidate approximates):
            // "unexplained" is for a residual no candidate explains, so the winner is named and
            // the remainder reported with it.
            let remainder = if structured && after > STRUCTURED_Z && explained < 0.5 {
                format!(
                    "; a structured residual remains ({}): {} explains {:.0} % of its neighbour correlation",
                    located.summary,
                    s.name,
                    100.0 * explained.max(0.0)
                )
            } else {
                String::new()
            };
            (
                s.name.clone(),
                s.family.clone(),
                format!(
                    "{} (ΔBIC {:.1}, held-out χ²/residual {:.3} → {:.3}, z = {:.1}){}{}",
                    s.name,
                    s.delta_bic,
                    s.heldout_null,
                    s.heldout,
                    s.heldout_z,
                    if alternatives.is_empty() {
                        String::new()
                    } else {
                        format!(
                            "; the data cannot tell it from {} (ΔBIC within {INDISTINGUISHABLE_BIC})",
                            alternatives.iter().map(|a| format!("{} (ΔBIC {:.1})", a.name, a.delta_bic)).collect::<Vec<_>>().join(", ")
                        )
                    },
                    remainder
                ),
                s.params.clone(),
                (s.heldout_null, s.heldout),
            )
        }
        None if structured => (
            "unexplained".to_string(),
            String::new(),
            format!("a structured residual ({}) that no candidate explains", located.summary),
            vec![],
            (refit_before, refit_before),
        ),
        None => ("none".to_string(), String::new(), "no missing physics above the noise".to_string(), vec![], (refit_before, refit_before)),
    };
    // The held-out models the numbers score: the winner's and its null's, or the per-level refit
    // when no effect is named (the model candidates' null: the humidity laws' would report the
    // scatter of the parameters between levels, tens of σ, beside "no missing physics").
    let named = winner.filter(|&i| verdict == scores[i].name).and_then(|i| heldout_of[i].take());
    let (before_models, before_is, after_models, after_is) = match named {
        Some(h) => (h.null, h.null_is, Some(h.candidate), Some(h.candidate_is)),
        None => (ctx.refit_null(), REFIT_NULL_IS.to_string(), None, None),
    };
    let before_per_level = per_level_scores(&before_models);
    let after_per_level = after_models.as_deref().map_or_else(|| before_per_level.clone(), per_level_scores);
    let summaries = (0..n_levels)
        .map(|l| LevelSummary {
            rh_pct: levels[l].rh_pct,
            time_s: levels[l].time_s,
            temp_c: levels[l].temp_c,
            revisit_of: levels[l].revisit_of,
            simulation_chi2_per_residual: simulation[l],
            refit_chi2_per_residual: ctx.base.chi2[l] / counts[l],
            heldout_before: before_per_level[l],
            heldout_after: after_per_level[l],
        })
        .collect();
    let mut after_models = after_models.map(Vec::into_iter);
    let models = before_models
        .into_iter()
        .enumerate()
        .map(|(l, before)| LevelModels {
            simulation: fits::level_params(calib, &levels[l], &cal_theta[l]),
            refit: fits::level_params(calib, &levels[l], &ctx.base.theta[l]),
            before,
            after: after_models.as_mut().and_then(Iterator::next),
        })
        .collect();
    let mut ranked = scores;
    // Held-out scores of different candidates have different nulls: rank by the evidence.
    ranked.sort_by(|a, b| b.passes.cmp(&a.passes).then(b.applicable.cmp(&a.applicable)).then(b.delta_bic.total_cmp(&a.delta_bic)));
    let humidity_path = matches!(verdict.as_str(), "hydration_lag" | "humidity_sensor_error").then(|| fit_humidity_path(&ctx, c_hat));
    Ok(Diagnosis {
        indistinguishable: if winner.is_some() { alternatives } else { vec![] },
        overdispersion: c_hat,
        verdict,
        family,
        explanation,
        params,
        heldout_before: before_after.0,
        heldout_after: before_after.1,
        located,
        candidates: ranked,
        levels: summaries,
        noise,
        models,
        heldout_before_is: before_is,
        heldout_after_is: after_is,
        humidity_path,
    })
}

/// The one ambiguity rule: `b` passes every gate but the information criterion's (it lowers the
/// held-out error; a floor does not stop it) and its ΔBIC is within [`INDISTINGUISHABLE_BIC`]
/// of the verdict `a`'s: the evidence between them is less than what naming needs, so `b` is
/// reported beside `a` even when `b` alone would not be named (a verdict barely past the
/// threshold is not separated from a runner-up just under it). ΔBIC of candidates acting on
/// the data and of those acting through the humidity are on different data (the values, the
/// levels' parameters): they are compared all the same, each being the evidence against the
/// same null.
fn indistinguishable(a: &Score, b: &Score) -> bool {
    b.applicable && b.other_gates && a.delta_bic - b.delta_bic < INDISTINGUISHABLE_BIC
}

/// Overdispersion ĉ ≥ 1 of the data's χ²: the best-fitting model's χ² per degree of freedom
/// (no extension, or a candidate acting on the data). Residuals scattered more than the noise
/// estimated from neighbouring points (level-to-level calibration errors, a law slightly off)
/// inflate every Δχ² by that factor, and a BIC that ignores it names a candidate for fitting
/// the excess. Dividing Δχ² by ĉ is quasi-likelihood (Burnham & Anderson, Model Selection and
/// Multimodel Inference, 2002, §2.5: QAIC; the same for BIC); ĉ is the most general model's, and
/// a single extension is the most general fitted here.
pub fn overdispersion(scores: &[Score], chi2_0: f64, dof_0: f64) -> f64 {
    let mut best = chi2_0 / dof_0.max(1.0);
    for s in scores.iter().filter(|s| s.applicable && s.space == "data" && s.other_gates) {
        let dof = (dof_0 - s.extra_params as f64).max(1.0);
        best = best.min((chi2_0 - s.delta_chi2) / dof);
    }
    best.max(1.0)
}

/// The measurement that would separate two candidates the data cannot tell apart.
pub fn separating_measurement(a: &str, b: &str) -> String {
    let pair = |x: &str, y: &str| (a == x && b == y) || (a == y && b == x);
    let has = |x: &str| a == x || b == x;
    let s = if pair("current_timing", "amplifier_bandwidth") {
        "sweep to ≥ 1 kHz (a pole rolls the current's gain off and its phase bends away from a line in f, a delay's does not), or measure the amplifier's response with a test current"
    } else if pair("electrode_resistance", "amplifier_bandwidth") || pair("electrode_resistance", "current_timing") {
        "record levels far apart in humidity (the electrodes' RC follows the strip's capacitance, which grows with humidity; an amplifier or a delay does not), measure the electrodes' surface resistance (four-point probe), or the amplifier with a test current"
    } else if pair("viscoelastic_relaxation", "air_loading") {
        "record in vacuum or at reduced pressure (air loading goes, the polymer's law stays), or sweep to 400 Hz to see the second mode"
    } else if has("tip_mass")
        && (has("air_loading") || has("viscoelastic_relaxation") || has("clamp_compliance") || has("hysteretic_damping"))
    {
        "sweep through the second mode (≈ 6.3 f₁, ≥ 250 Hz: a tip mass lowers it far more than the first), or weigh what is at the tip"
    } else if has("clamp_compliance") {
        "sweep through the second mode, or measure the root's rotation (a clamp's compliance shows as root slope)"
    } else if has("temperature") {
        "record the temperature per point, or hold it constant (±0.5 K) over the session"
    } else if pair("hydration_lag", "humidity_sensor_error") {
        "revisit levels in both sweep directions with longer settling (a lag's error changes sign with direction, an offset does not), or check the sensor at a reference humidity (a saturated salt)"
    } else if has("tip_timing") {
        "measure the tip sensor's delay against a reference (a step or an accelerometer at the tip)"
    } else if has("mains_interference") {
        "record with the shaker off (mains lines stay), or shift the excitation lines off 50/60 Hz and their harmonics"
    } else if has("capacitive_feedthrough") {
        "record with the strip disconnected (feedthrough stays) or shield the current input"
    } else {
        "more humidity levels, a wider band, or a second session in the other sweep direction"
    };
    s.to_string()
}

fn not_applicable(cand: &Candidate, note: &str, before: f64) -> Score {
    Score {
        name: cand.name.into(),
        family: cand.family.into(),
        applicable: false,
        params: vec![],
        delta_chi2: 0.0,
        extra_params: 0,
        delta_bic: 0.0,
        space: String::new(),
        heldout: before,
        heldout_per_level: vec![],
        heldout_null: before,
        heldout_null_per_level: vec![],
        heldout_z: 0.0,
        passes: false,
        note: note.into(),
        other_gates: false,
    }
}

#[allow(clippy::too_many_arguments)]
fn score_candidate(
    ctx: &Ctx,
    cand: &Candidate,
    before: &[HeldOutModel],
    counts: &[f64],
    n_data: f64,
    chi2_0: f64,
    law0: (f64, usize),
    n_theta: f64,
) -> Result<(Score, Option<Fitted>, Option<HeldOut>)> {
    let levels = &ctx.data.levels;
    let n = levels.len();
    let heldout_before = weighted_mean(&per_level_scores(before), counts);
    let estimates = |values: &[f64], ses: &[f64]| -> Vec<Estimate> {
        cand.params
            .iter()
            .zip(values.iter().zip(ses))
            .map(|(s, (v, e))| Estimate { name: s.name.into(), unit: s.unit.into(), value: *v, std_error: *e })
            .collect()
    };
    // Why a candidate that fits cannot be named (a humidity remap too small to matter, lines no
    // worse than their neighbours): kept in the note.
    let mut floor: Option<String> = None;
    let (fitted, delta_chi2, extra, space, params, mut note, held) = match cand.kind {
        Kind::Model(ext) => {
            let start: Vec<f64> = cand.params.iter().map(|s| s.start).collect();
            let j = fits::fit_joint(ctx.calib, levels, &ctx.sig, &ctx.all, cand.params, ext, &ctx.base.theta, &start)?;
            let exts: Vec<Extension<f64>> = (0..n).map(|l| ext(&j.phi, &fits::level_params(ctx.calib, &levels[l], &j.theta[l]))).collect();
            let chi2: f64 = j.chi2.iter().sum();
            let f = Fitted { theta: j.theta, se: j.se, ext: exts, masks: ctx.all.clone(), regressors: ctx.read.clone() };
            let held = HeldOut {
                null: ctx.refit_null(),
                null_is: REFIT_NULL_IS.into(),
                candidate: ctx.refit_heldout(cand, ext, &j.phi, &f),
                candidate_is: format!("the level's base parameters refitted with {}'s parameters fitted on the other levels", cand.name),
            };
            (f, chi2_0 - chi2, cand.params.len(), "data", estimates(&j.phi, &j.phi_se), String::new(), held)
        }
        Kind::Mains => {
            // (Δχ², fit, values at lines, line, power, z of the lines against their neighbours)
            let mut best: Option<(f64, Fitted, usize, f64, f64, f64)> = None;
            for line in [50.0, 60.0] {
                let masks: Vec<Mask> = levels
                    .iter()
                    .zip(&ctx.all)
                    .map(|(l, m)| {
                        let mut m = m.clone();
                        for (on, &f) in m.current.iter_mut().zip(&l.freqs) {
                            let k = (f / line).round();
                            if (1.0..=4.0).contains(&k) && (f - k * line).abs() <= (0.01 * f).max(0.5) {
                                *on = false;
                            }
                        }
                        m
                    })
                    .collect();
                let excluded = (total_residuals(&ctx.all) - total_residuals(&masks)) / 2;
                if excluded == 0 {
                    continue;
                }
                let b = fits::fit_levels(ctx.calib, levels, &ctx.sig, &masks, &Extension::default(), &ctx.base.theta)?;
                let chi2: f64 = b.chi2.iter().sum();
                // χ² per current value under the fit without the lines; each line value against
                // its neighbours in frequency that are not lines themselves: with no
                // interference it is the worst of k + 1 values with probability 1/(k + 1), a
                // sign test that a smooth misfit (which raises neighbours alike) cannot pass,
                // however heavy its tails.
                let mut at_lines = Vec::new();
                let (mut worst, mut expected, mut variance) = (0.0, 0.0, 0.0);
                for l in 0..n {
                    let p = fits::level_params(ctx.calib, &levels[l], &b.theta[l]);
                    let (_, cur) = fits::log_ratios(&levels[l], &p, &Extension::default());
                    let chi2_at = |i: usize| {
                        cur[i].map(|z| (z.re / ctx.sig[l].current[i].ln_gain).powi(2) + (z.im / ctx.sig[l].current[i].phase).powi(2))
                    };
                    for i in 0..cur.len() {
                        if !(ctx.all[l].current[i] && !masks[l].current[i]) {
                            continue;
                        }
                        let Some(here) = chi2_at(i) else { continue };
                        at_lines.push(here);
                        let beside: Vec<f64> = [i.wrapping_sub(1), i + 1]
                            .into_iter()
                            .filter(|&j| j < cur.len() && masks[l].current[j])
                            .filter_map(chi2_at)
                            .collect();
                        if !beside.is_empty() {
                            let p = 1.0 / (beside.len() + 1) as f64;
                            expected += p;
                            variance += p * (1.0 - p);
                            if beside.iter().all(|&b| here > b) {
                                worst += 1.0;
                            }
                        }
                    }
                }
                // The interference as a random-phase current at the lines: each of their
                // values scattered with variance σ²(1 + P) per component, P by maximum
                // likelihood; one parameter, where a free value per point would cost two each.
                let m = 2.0 * at_lines.len() as f64;
                let r2: f64 = at_lines.iter().sum();
                let power = (r2 / m - 1.0).max(0.0);
                let nll = chi2 + r2 / (1.0 + power) + m * (1.0 + power).ln();
                let specific = if variance > 0.0 { (worst - expected) / variance.sqrt() } else { 0.0 };
                let dchi2 = chi2_0 - nll;
                if best.as_ref().is_none_or(|(d, ..)| dchi2 > *d) {
                    let f = Fitted { theta: b.theta, se: b.se, ext: vec![Extension::default(); n], masks, regressors: ctx.read.clone() };
                    best = Some((dchi2, f, excluded, line, power, specific));
                }
            }
            let Some((dchi2, f, excluded, line, power, specific)) = best else {
                return Ok((not_applicable(cand, "no frequency near 50/60 Hz or their harmonics", heldout_before), None, None));
            };
            if specific < MIN_LINE_Z {
                floor = Some(format!("the values at the lines are no worse than their neighbours (z = {specific:.1})"));
            }
            let amplitude = power.sqrt();
            let held = HeldOut {
                null: ctx.refit_null(),
                null_is: REFIT_NULL_IS.into(),
                candidate: ctx.mains_heldout(&f),
                candidate_is: "the base model refitted at the level without its line points, those scored with σ² × (1 + the interference power of the other levels)".into(),
            };
            let params = vec![
                Estimate { name: "line_hz".into(), unit: "Hz".into(), value: line, std_error: 0.0 },
                Estimate {
                    name: "interference_rms".into(),
                    unit: "σ".into(),
                    value: amplitude,
                    std_error: amplitude / (2.0 * excluded as f64).sqrt(),
                },
            ];
            (f, dchi2, 1, "data", params, format!("{excluded} current values at lines, z = {specific:.1} against their neighbours"), held)
        }
        Kind::Humidity(map) => {
            let base = &ctx.base;
            match map {
                HumidityMap::HydrationLag => {
                    if !ctx.data.has_times() {
                        return Ok((not_applicable(cand, "the recordings have no time_s", heldout_before), None, None));
                    }
                    // The calibration's laws at the lagged humidity (with a drift per parameter),
                    // not free laws: free laws are blind to the humidity's scale, so a lag far
                    // longer than the session (the lagged humidity a scaled integral of the
                    // readings) would pass as a change of the laws' shape.
                    let everyone: Vec<usize> = (0..n).collect();
                    let (tau, nll_alt) = fit_lag(ctx, &everyone);
                    let score_tau = |tau: f64| anchored_nll(ctx, &laws::lagged_rh(levels, &ctx.data.histories, tau), &everyone);
                    // Uncertainty of τ from the χ² curvature in ln τ.
                    let h = 0.1f64;
                    let curv = (score_tau(tau * h.exp()) - 2.0 * nll_alt + score_tau(tau * (-h).exp())) / (h * h);
                    let se = if curv > 0.0 { tau * (2.0 / curv).sqrt() } else { f64::INFINITY };
                    let rh = laws::lagged_rh(levels, &ctx.data.histories, tau);
                    let r = score_remap(
                        ctx,
                        &rh,
                        1,
                        "at the lagged humidity",
                        "the calibration at the humidity lagged by the τ fitted on the other levels, plus their mean drift from it",
                        &|train| laws::lagged_rh(levels, &ctx.data.histories, fit_lag(ctx, train).0),
                        law0,
                        n_theta,
                    );
                    floor = r.floor;
                    (r.fitted, r.delta_chi2, 1, "level parameters", estimates(&[tau], &[se]), r.note, r.held)
                }
                HumidityMap::Temperature => {
                    if ctx.data.temperature_span() < 1.0 {
                        return Ok((not_applicable(cand, "temperature not recorded or constant within 1 K", heldout_before), None, None));
                    }
                    let everyone: Vec<usize> = (0..n).collect();
                    let (phi, se_phi) = fit_thermal(ctx, &everyone);
                    let pred = thermal(ctx, &phi, &everyone);
                    let nll_null = anchored_nll(ctx, &read_rh(ctx), &everyone);
                    let pick = |v: &[Theta]| everyone.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
                    let nll_alt = laws::nll(&pick(&pred), &pick(&base.theta), &pick(&base.se));
                    // As for the humidity remaps: when free humidity laws beat the calibration
                    // with temperature (by BIC), the levels do not follow the calibration's
                    // laws at any temperature, and their drift is not the temperature's.
                    let bic_alt = nll_alt + 6.0 * n_theta.ln();
                    let bic_laws = law0.0 + law0.1 as f64 * n_theta.ln();
                    let delta = if bic_alt <= bic_laws { nll_null - nll_alt } else { 0.0 };
                    let f = Fitted { theta: pred, ..ctx.plain() };
                    let (null, candidate): (Vec<HeldOutModel>, Vec<HeldOutModel>) = (0..n)
                        .map(|held| {
                            let train: Vec<usize> = (0..n).filter(|&k| k != held).collect();
                            let score = |th: &Theta| ctx.scored(held, fits::level_params(ctx.calib, &levels[held], th), f.ext[held]);
                            let (phi_train, _) = fit_thermal(ctx, &train);
                            (score(&anchored(ctx, &read_rh(ctx), &train)[held]), score(&thermal(ctx, &phi_train, &train)[held]))
                        })
                        .unzip();
                    let held = HeldOut {
                        null,
                        null_is: ANCHORED_NULL_IS.into(),
                        candidate,
                        candidate_is: "the calibration at the humidity as read with the level's temperature acting on d (Arrhenius) and Y, the activation energy and modulus slope fitted on the other levels, plus their mean drift from it".into(),
                    };
                    let note = format!(
                        "calibration + drift as read: −2lnL {nll_null:.1}; with temperature {nll_alt:.1}; free laws {:.1} ({} parameters)",
                        law0.0, law0.1
                    );
                    (f, delta, 2, "level parameters", estimates(&phi, &se_phi), note, held)
                }
                HumidityMap::SensorError => {
                    let everyone: Vec<usize> = (0..n).collect();
                    let (o, g, _, se_og) = fit_sensor(ctx, &everyone);
                    let rh: Vec<f64> = levels.iter().map(|l| laws::mapped_rh(l.rh_pct, o, g)).collect();
                    let r = score_remap(
                        ctx,
                        &rh,
                        2,
                        "with the humidity mapped",
                        "the calibration at the humidity mapped by the offset and gain fitted on the other levels, plus their mean drift from it",
                        &|train| {
                            let (o, g, ..) = fit_sensor(ctx, train);
                            levels.iter().map(|l| laws::mapped_rh(l.rh_pct, o, g)).collect()
                        },
                        law0,
                        n_theta,
                    );
                    floor = r.floor;
                    (r.fitted, r.delta_chi2, 2, "level parameters", estimates(&[o, g], &se_og), r.note, r.held)
                }
            }
        }
    };
    let n_ic = if space == "data" { n_data } else { n_theta };
    let delta_bic = delta_chi2 - extra as f64 * n_ic.ln();
    let (null_per_level, per_level) = (per_level_scores(&held.null), per_level_scores(&held.candidate));
    let heldout = weighted_mean(&per_level, counts);
    let heldout_null = weighted_mean(&null_per_level, counts);
    let z = paired_z(&null_per_level, &per_level, counts);
    let other_gates = z >= MIN_HELDOUT_Z && heldout < heldout_null && floor.is_none();
    let passes = delta_bic >= MIN_DELTA_BIC && other_gates;
    if let Some(why) = floor {
        note = if note.is_empty() { why } else { format!("{note}; {why}") };
    }
    Ok((
        Score {
            name: cand.name.into(),
            family: cand.family.into(),
            applicable: true,
            params,
            delta_chi2,
            extra_params: extra,
            delta_bic,
            space: space.into(),
            heldout,
            heldout_per_level: per_level,
            heldout_null,
            heldout_null_per_level: null_per_level,
            heldout_z: z,
            passes,
            note,
            other_gates,
        },
        Some(fitted),
        Some(held),
    ))
}

/// The levels' θ under temperature: the calibration at the humidity read, with the level's
/// absolute temperature T (its mean `temp_c`) acting on the ionic transport by Arrhenius,
/// ln d += −(E_a/R)(1/T − 1/T_c), and on the modulus, ln Y += −α(T − T_c) (T_c the
/// calibration's temperature; K's own 1/T is in every level's parameters already, see
/// [`fits::level_params`]), plus the mean drift over `train`. `phi` = [E_a in kJ/mol, α in 1/K].
fn thermal(ctx: &Ctx, phi: &[f64], train: &[usize]) -> Vec<Theta> {
    with_drift(ctx, thermal_raw(ctx, phi), train)
}

/// E_a [kJ/mol] and α [1/K] of [`thermal`] fitted to the levels `train` (with a free drift per
/// parameter), and their standard errors.
fn fit_thermal(ctx: &Ctx, train: &[usize]) -> (Vec<f64>, Vec<f64>) {
    let base = &ctx.base;
    let params = vec![
        Param::new("ea_kj_per_mol", Bound::Between(0.0, 80.0)),
        Param::new("alpha_y_per_k", Bound::Between(-0.05, 0.05)),
        Param::new("dY", Bound::Free),
        Param::new("dCs", Bound::Free),
        Param::new("dCa", Bound::Free),
        Param::new("dd", Bound::Free),
    ];
    let resid = |v: &[f64], out: &mut [f64]| {
        let raw = thermal_raw(ctx, v);
        let mut k = 0;
        for &l in train {
            for j in 0..4 {
                let w = ctx.weights.weight(&base.se[l], j);
                out[k] = if w > 0.0 { (base.theta[l][j] - raw[l][j] - v[2 + j]) * w.sqrt() } else { 0.0 };
                k += 1;
            }
        }
    };
    let starts = vec![vec![15.0, 0.003, 0.0, 0.0, 0.0, 0.0]];
    match lsq::fit(&params, &starts, 4 * train.len(), resid) {
        Ok(f) => (f.estimates[..2].to_vec(), f.std_errors[..2].to_vec()),
        Err(_) => (vec![0.0, 0.0], vec![f64::NAN, f64::NAN]),
    }
}

/// [`thermal`] without the drift.
fn thermal_raw(ctx: &Ctx, phi: &[f64]) -> Vec<Theta> {
    let t_c = ctx.calib.t_k;
    ctx.data
        .levels
        .iter()
        .map(|l| {
            let mut c = fits::calibration_theta(ctx.calib, l.rh_pct);
            if let Some(t) = l.temp_c {
                let t = t + 273.15;
                c[0] -= phi[1] * (t - t_c);
                c[3] -= phi[0] * 1e3 / ctx.calib.r_gas * (1.0 / t - 1.0 / t_c);
            }
            c
        })
        .collect()
}

/// Fits RH_true = mapped(RH_read; o, g) and a constant drift δ_j of each ln θ_j to the levels
/// `train`: returns o, g, δ and the standard errors of o and g.
fn fit_sensor(ctx: &Ctx, train: &[usize]) -> (f64, f64, Theta, Vec<f64>) {
    let read: Vec<f64> = ctx.data.levels.iter().map(|l| l.rh_pct).collect();
    fit_sensor_at(ctx, train, &read)
}

/// [`fit_sensor`] for levels at humidities `read` (the readings, or the readings behind a lag),
/// with the fit's −2 ln L.
fn fit_sensor_at(ctx: &Ctx, train: &[usize], read: &[f64]) -> (f64, f64, Theta, Vec<f64>) {
    let (o, g, drift, se, _) = fit_sensor_nll(ctx, train, read);
    (o, g, drift, se)
}

fn fit_sensor_nll(ctx: &Ctx, train: &[usize], read: &[f64]) -> (f64, f64, Theta, Vec<f64>, f64) {
    fit_sensor_with(ctx, train, read, true, true)
}

/// The sensor's offset and gain (or the offset alone, the gain 1: `free_gain` false) that map
/// the levels `train` at humidities `read` onto the calibration, with a free drift per parameter
/// (`drift`) or none, and the fit's −2 ln L.
fn fit_sensor_with(ctx: &Ctx, train: &[usize], read: &[f64], drift: bool, free_gain: bool) -> (f64, f64, Theta, Vec<f64>, f64) {
    let base = &ctx.base;
    let mut params = vec![Param::new("rh_offset_pct", Bound::Between(-25.0, 25.0))];
    if free_gain {
        params.push(Param::new("rh_gain", Bound::Between(0.6, 1.4)));
    }
    let first_drift = params.len();
    if drift {
        params.extend(["dY", "dCs", "dCa", "dd"].map(|n| Param::new(n, Bound::Free)));
    }
    let gain_of = |v: &[f64]| if free_gain { v[1] } else { 1.0 };
    let resid = |v: &[f64], out: &mut [f64]| {
        let mut k = 0;
        for &l in train {
            let pred = fits::calibration_theta(ctx.calib, laws::mapped_rh(read[l], v[0], gain_of(v)));
            for j in 0..4 {
                let w = ctx.weights.weight(&base.se[l], j);
                let d = if drift { v[first_drift + j] } else { 0.0 };
                out[k] = if w > 0.0 { (base.theta[l][j] - pred[j] - d) * w.sqrt() } else { 0.0 };
                k += 1;
            }
        }
    };
    let starts: Vec<Vec<f64>> = [-8.0, 0.0, 8.0]
        .iter()
        .map(|&o| {
            let mut v = vec![o];
            if free_gain {
                v.push(1.0);
            }
            v.resize(params.len(), 0.0);
            v
        })
        .collect();
    match lsq::fit(&params, &starts, 4 * train.len(), resid) {
        Ok(f) => {
            let (o, g) = (f.estimates[0], gain_of(&f.estimates));
            let mapped: Vec<f64> = read.iter().map(|&r| laws::mapped_rh(r, o, g)).collect();
            let (drifts, nll) = if drift {
                let d = &f.estimates[first_drift..];
                ([d[0], d[1], d[2], d[3]], anchored_nll(ctx, &mapped, train))
            } else {
                let pick = |v: &[Theta]| train.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
                let pred: Vec<Theta> = mapped.iter().map(|&h| fits::calibration_theta(ctx.calib, h)).collect();
                ([0.0; 4], laws::nll(&pick(&pred), &pick(&base.theta), &pick(&base.se)))
            };
            let se_gain = if free_gain { f.std_errors[1] } else { 0.0 };
            (o, g, drifts, vec![f.std_errors[0], se_gain], nll)
        }
        Err(_) => (0.0, 1.0, [0.0; 4], vec![f64::NAN; 2], f64::INFINITY),
    }
}

/// The whole humidity path at once, once a part of it is named: the sensor's offset and gain
/// and the strip's hydration lag (when the recordings have times), fitted together. Each alone
/// absorbs some of the other (a lag fitted beside an uncorrected offset comes out short; an
/// offset and gain beside a short lag take its hysteresis for a span error), and what goes
/// into a calibration is the path, not the one part the verdict names.
/// The path is fitted without a drift of the parameters: a drift trades off against the
/// sensor's offset, and what is written into the calibration must be the humidity, not a
/// mixture of humidity and calibration error.
const PATH_FIT_DRIFT: bool = false;
/// Rounds of refitting the levels at the strip's humidity the path gives (see
/// [`fit_humidity_path`]); measured, the third changes the path by < 0.05 %RH.
const PATH_ROUNDS: usize = 3;

fn fit_humidity_path(ctx: &Ctx, c_hat: f64) -> HumidityPath {
    let mut path = fit_path_once(ctx, c_hat);
    // Each level's own fit holds κe, h and m at the humidity the level is placed at, the reading:
    // with the reading off, its Y, Cs, Ca and d come out pulled toward the reading, and the
    // path fitted on them short of the truth. So the levels are refitted where the path puts
    // them, and the path on those fits.
    for _ in 0..PATH_ROUNDS {
        let strip = path_rh(ctx, &path);
        let mut moved = ctx.data.levels.clone();
        for (l, rh) in moved.iter_mut().zip(&strip) {
            l.rh_pct = *rh;
        }
        let Ok(base) = fits::fit_levels(ctx.calib, &moved, &ctx.sig, &ctx.all, &Extension::default(), &ctx.base.theta) else { break };
        // The law scatter is re-estimated where the path puts the levels: measured at the
        // reading, it holds the very hysteresis and offset the path removes, and weighs the
        // parameters that show them most as if they were noise.
        let at_strip = Regressors { x: strip, temperature: None };
        let weights = LawWeights::estimate(&at_strip, &base.theta, &base.se);
        let refitted =
            Ctx { calib: ctx.calib, data: ctx.data, sig: ctx.sig.clone(), all: ctx.all.clone(), base, read: ctx.read.clone(), weights };
        path = fit_path_once(&refitted, c_hat);
    }
    path
}

/// Each level's humidity under `path`: its readings behind the lag, then corrected.
fn path_rh(ctx: &Ctx, path: &HumidityPath) -> Vec<f64> {
    let behind = if path.has_lag() {
        laws::lagged_rh(&ctx.data.levels, &ctx.data.histories, path.tau_wet_s)
    } else {
        ctx.data.levels.iter().map(|l| l.rh_pct).collect()
    };
    behind.iter().map(|&r| path.correct(r)).collect()
}

/// `c_hat` is the data's overdispersion: the levels' standard errors are that much too small
/// in variance, so their likelihood gains are divided by it before BIC prices a parameter.
fn fit_path_once(ctx: &Ctx, c_hat: f64) -> HumidityPath {
    let everyone: Vec<usize> = (0..ctx.data.levels.len()).collect();
    // BIC's price of one more parameter of the path, on the levels' four parameters each.
    let penalty = c_hat * (4.0 * everyone.len() as f64).ln();
    let read: Vec<f64> = ctx.data.levels.iter().map(|l| l.rh_pct).collect();
    // The sensor's gain only where the data ask for it: a gain the levels cannot pin down
    // trades off against the offset and the lag and moves the humidity at the range's ends.
    let sensor = |read: &[f64]| {
        let free = fit_sensor_with(ctx, &everyone, read, PATH_FIT_DRIFT, true);
        let unit = fit_sensor_with(ctx, &everyone, read, PATH_FIT_DRIFT, false);
        if unit.4 - free.4 > penalty { free } else { unit }
    };
    if !ctx.data.has_times() {
        let (o, g, ..) = sensor(&read);
        return laws::sensor_correction(o, g);
    }
    let lagged = |tau: f64| laws::lagged_rh(&ctx.data.levels, &ctx.data.histories, tau);
    let (tau, nll_lag) = minimize_log(|tau| sensor(&lagged(tau)).4, 1.0, 1e5);
    let none = sensor(&read);
    // Likewise a lag that does not beat none by its parameter's price is none.
    let (tau, (o, g, ..)) = if none.4 - nll_lag > penalty { (tau, sensor(&lagged(tau))) } else { (0.0, none) };
    HumidityPath { tau_wet_s: tau, tau_dry_s: tau, ..laws::sensor_correction(o, g) }
}

/// The humidity each level was read at.
fn read_rh(ctx: &Ctx) -> Vec<f64> {
    ctx.data.levels.iter().map(|l| l.rh_pct).collect()
}

/// The calibration at humidities `rh` plus a constant drift per parameter, the drift the
/// weighted mean over the levels `train` of θ − calibration: the per-level θ a humidity remap
/// predicts (the null when `rh` is the humidity read).
fn anchored(ctx: &Ctx, rh: &[f64], train: &[usize]) -> Vec<Theta> {
    with_drift(ctx, rh.iter().map(|&h| fits::calibration_theta(ctx.calib, h)).collect(), train)
}

/// `cal` plus the weighted mean over the levels `train` of θ − `cal` per parameter.
fn with_drift(ctx: &Ctx, cal: Vec<Theta>, train: &[usize]) -> Vec<Theta> {
    let mut delta = [0.0; 4];
    for (j, d) in delta.iter_mut().enumerate() {
        let (mut sw, mut s) = (0.0, 0.0);
        for &l in train {
            let w = ctx.weights.weight(&ctx.base.se[l], j);
            s += w * (ctx.base.theta[l][j] - cal[l][j]);
            sw += w;
        }
        *d = if sw > 0.0 { s / sw } else { 0.0 };
    }
    cal.iter().map(|c| [c[0] + delta[0], c[1] + delta[1], c[2] + delta[2], c[3] + delta[3]]).collect()
}

/// −2 ln L of the levels `train`'s θ under [`anchored`] at humidities `rh`.
fn anchored_nll(ctx: &Ctx, rh: &[f64], train: &[usize]) -> f64 {
    let pred = anchored(ctx, rh, train);
    let pick = |v: &[Theta]| train.iter().map(|&l| v[l]).collect::<Vec<Theta>>();
    laws::nll(&pick(&pred), &pick(&ctx.base.theta), &pick(&ctx.base.se))
}

/// The hydration lag τ [s] that best maps the levels `train` onto the calibration, and its −2 ln L.
fn fit_lag(ctx: &Ctx, train: &[usize]) -> (f64, f64) {
    minimize_log(|tau| anchored_nll(ctx, &laws::lagged_rh(&ctx.data.levels, &ctx.data.histories, tau), train), 1.0, 1e5)
}

/// A humidity error or lag that moves no level by [`MIN_RH_SHIFT_PCT`] is not reported.
fn shift_floor(rh: &[f64], read: &[f64]) -> Option<String> {
    let largest = rh.iter().zip(read).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    (largest < MIN_RH_SHIFT_PCT).then(|| format!("moves no level by {MIN_RH_SHIFT_PCT} %RH (largest {largest:.2} %RH)"))
}

/// What a humidity remap scores, against the calibration as read with its drift.
struct RemapScore {
    fitted: Fitted,
    /// −2 ln L gained over the null; 0 when the remap does worse than free humidity laws (by
    /// BIC): then the levels' parameters follow the calibration's laws at no humidity, and their
    /// drift is not a humidity error.
    delta_chi2: f64,
    note: String,
    floor: Option<String>,
    held: HeldOut,
}

/// Scores the remap that puts the levels at humidities `rh` with `k` parameters of its own
/// (plus the four drifts); `remap_of` refits it on training levels for the held-out scores.
#[allow(clippy::too_many_arguments)]
fn score_remap(
    ctx: &Ctx,
    rh: &[f64],
    k: usize,
    mapped: &str,
    candidate_is: &str,
    remap_of: &dyn Fn(&[usize]) -> Vec<f64>,
    law0: (f64, usize),
    n_theta: f64,
) -> RemapScore {
    let everyone: Vec<usize> = (0..ctx.data.levels.len()).collect();
    let nll_null = anchored_nll(ctx, &read_rh(ctx), &everyone);
    let nll_alt = anchored_nll(ctx, rh, &everyone);
    let bic_alt = nll_alt + (k + 4) as f64 * n_theta.ln();
    let bic_laws = law0.0 + law0.1 as f64 * n_theta.ln();
    let fitted = Fitted { theta: anchored(ctx, rh, &everyone), ..ctx.plain() };
    let (null, candidate) = heldout_anchored(ctx, &fitted, remap_of);
    RemapScore {
        delta_chi2: if bic_alt <= bic_laws { nll_null - nll_alt } else { 0.0 },
        note: format!(
            "calibration + drift as read: −2lnL {nll_null:.1}; {mapped} {nll_alt:.1}; free laws {:.1} ({} parameters)",
            law0.0, law0.1
        ),
        floor: shift_floor(rh, &read_rh(ctx)),
        held: HeldOut { null, null_is: ANCHORED_NULL_IS.into(), candidate, candidate_is: candidate_is.into() },
        fitted,
    }
}

/// Held-out models of a humidity remap and of its null, per level: the remap (`remap_of` the
/// training levels gives every level's humidity) and the drift from the other levels, against
/// the calibration as read with the drift from the other levels.
fn heldout_anchored(ctx: &Ctx, f: &Fitted, remap_of: &dyn Fn(&[usize]) -> Vec<f64>) -> (Vec<HeldOutModel>, Vec<HeldOutModel>) {
    let levels = &ctx.data.levels;
    let n = levels.len();
    let score = |held: usize, th: &Theta| ctx.scored(held, fits::level_params(ctx.calib, &levels[held], th), f.ext[held]);
    (0..n)
        .map(|held| {
            let train: Vec<usize> = (0..n).filter(|&l| l != held).collect();
            let null = score(held, &anchored(ctx, &read_rh(ctx), &train)[held]);
            (null, score(held, &anchored(ctx, &remap_of(&train), &train)[held]))
        })
        .unzip()
}

/// Minimizes a function of a positive scalar on [lo, hi] over ln x: a grid, then golden-section
/// refinement around the best grid point.
fn minimize_log(f: impl Fn(f64) -> f64, lo: f64, hi: f64) -> (f64, f64) {
    let (a, b) = (lo.ln(), hi.ln());
    let n = 24;
    let grid: Vec<(f64, f64)> = (0..=n).map(|i| a + (b - a) * i as f64 / n as f64).map(|u| (u, f(u.exp()))).collect();
    let best = (0..grid.len()).min_by(|&i, &j| grid[i].1.total_cmp(&grid[j].1)).unwrap_or(0);
    let (mut x0, mut x1) = (grid[best.saturating_sub(1)].0, grid[(best + 1).min(n)].0);
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..30 {
        let (c, d) = (x1 - g * (x1 - x0), x0 + g * (x1 - x0));
        if f(c.exp()) < f(d.exp()) {
            x1 = d;
        } else {
            x0 = c;
        }
    }
    let u = (x0 + x1) / 2.0;
    let v = f(u.exp());
    if v <= grid[best].1 { (u.exp(), v) } else { (grid[best].0.exp(), grid[best].1) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(name: &str, delta_chi2: f64, delta_bic: f64, other_gates: bool) -> Score {
        Score {
            name: name.into(),
            family: String::new(),
            applicable: true,
            params: vec![],
            delta_chi2,
            extra_params: 1,
            delta_bic,
            space: "data".into(),
            heldout: 1.0,
            heldout_per_level: vec![],
            heldout_null: 1.0,
            heldout_null_per_level: vec![],
            heldout_z: 1.0,
            passes: other_gates && delta_bic >= MIN_DELTA_BIC,
            note: String::new(),
            other_gates,
        }
    }

    /// One rule: a candidate that passes the held-out gates and is within INDISTINGUISHABLE_BIC
    /// of the verdict is reported beside it, even below the naming threshold; one beyond it, or
    /// failing the held-out gates, is not.
    #[test]
    fn indistinguishable_is_one_rule() {
        let best = score("a", 0.0, 11.0, true);
        assert!(indistinguishable(&best, &score("b", 0.0, 11.0 - INDISTINGUISHABLE_BIC + 0.1, true)));
        assert!(!indistinguishable(&best, &score("c", 0.0, 11.0 - INDISTINGUISHABLE_BIC - 0.1, true)));
        assert!(!indistinguishable(&best, &score("d", 0.0, 10.5, false)));
        for (a, b) in
            [("current_timing", "amplifier_bandwidth"), ("viscoelastic_relaxation", "air_loading"), ("temperature", "hydration_lag")]
        {
            assert_eq!(separating_measurement(a, b), separating_measurement(b, a));
        }
        assert!(separating_measurement("current_timing", "amplifier_bandwidth").contains("1 kHz"));
    }

    /// ĉ is the best-fitting model's χ²/dof, never below 1.
    #[test]
    fn overdispersion_is_the_best_fit_per_dof() {
        let scores = [score("a", 100.0, 0.0, true), score("b", 300.0, 0.0, true), score("c", 390.0, 0.0, false)];
        let c = overdispersion(&scores, 500.0, 101.0);
        assert!((c - 200.0 / 100.0).abs() < 1e-12, "{c}");
        assert_eq!(overdispersion(&scores, 50.0, 101.0), 1.0);
    }
}
