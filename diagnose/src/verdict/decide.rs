//! The decision: which candidate, if any, the evidence names, and which others the data cannot
//! separate from it.
//!
//! Every hypothesis the evidence supports gets a probability ([`posterior`]): "none" (no
//! extension) and each candidate that lowers the held-out χ² with a paired significance over
//! levels z ≥ [`crate::candidates::score::MIN_HELDOUT_Z`] (a weak gate: the held-out differences between levels are
//! heavy-tailed, a few levels carry an effect that grows with humidity or temperature, so the
//! strong evidence is the information criterion). A hypothesis is stated alone only when it
//! holds [`CONFIDENCE`] of the probability (a candidate also needs ΔBIC ≥ [`MIN_DELTA_BIC`] and
//! to pass its kind's floor: a humidity remap must move some level by
//! [`crate::humidity::remap::MIN_RH_SHIFT_PCT`], mains lines must stand out from their neighbours). A floor
//! says the candidate would not be worth naming, not that the data do not favour it: removed
//! from the probabilities, its evidence would pass to whichever hypothesis it resembles, so it
//! keeps its probability and blocks only its own naming; otherwise the verdict is
//! `undecided`, with the smallest set holding it and the measurement that would separate its two
//! most probable members. "None" stated alone is "unexplained" when the per-level refit leaves a
//! structured residual (neighbour correlation, [`fits::structure_z`]). A winner that removes less
//! than half of a structured residual's neighbour correlation is still named, with the
//! remainder reported.

use crate::candidates::Candidate;
use crate::candidates::effect::NONE;
use crate::candidates::score::{Estimate, MIN_DELTA_BIC, Score, Space};
use crate::candidates::separation::{Separation, separating, separating_measurement};
use crate::evidence::context::{Baseline, Ctx, Fitted};
use crate::evidence::held_out::{per_level_scores, weighted_mean};
use crate::evidence::level_bootstrap::{Evidence, averaged_posterior};
use crate::fits;
use crate::verdict::hypotheses::{self, Ruling};
use crate::verdict::types::{Alternative, Probability, Verdict};
use ipmc_core::model::extension::Extension;

pub use crate::verdict::hypotheses::{CONFIDENCE, credible_set};
/// Prior probability that a strip brought to diagnosis has no missing physics at all; the rest
/// is shared equally by the library's effects (no effect is known to be commoner than another;
/// an effect fitted in several forms splits its share between them). With 14 effects a
/// candidate's prior odds against none are 1:14, so on its own it reaches [`CONFIDENCE`] at
/// ΔBIC = 2 ln(9·14) ≈ 9.7: the same evidence [`MIN_DELTA_BIC`] asks for, from the other side.
pub const PRIOR_NONE: f64 = 0.5;
/// The scale of the evidence in the probabilities: ln p ∝ ΔBIC / (2·EVIDENCE_SCALE). ΔBIC is
/// already a quasi-likelihood (divided by the overdispersion) and the probabilities are averaged
/// over the levels' bootstrap ([`crate::evidence::level_bootstrap`]), which is where the candidates'
/// approximate models and correlated residuals are paid for. Checked on the project's own
/// `prove` (docs/diagnosis.md): the log score of the truth over 204 cases is −0.547 at 0.5,
/// −0.559 at 1 and −0.574 at 1.5, flat enough that BIC's own scale is kept, and stated ≥ 90 %
/// is right 98 % (fr) and 95 % (ts) of the time at 1.
pub const EVIDENCE_SCALE: f64 = 1.0;

/// z of the neighbour correlation of residuals ([`fits::structure_z`]) above which a residual
/// counts as structured.
pub const STRUCTURED_Z: f64 = 5.0;

/// What the evidence names.
pub(crate) struct Decision {
    pub verdict: Verdict,
    /// The winning candidate's index (None when no effect is named).
    pub winner: Option<usize>,
    pub alternatives: Vec<Alternative>,
    /// ĉ the data-space ΔBIC were divided by.
    pub overdispersion: f64,
    pub family: String,
    /// The winner's form (see [`crate::candidates::Candidate::form`]).
    pub form: String,
    pub explanation: String,
    pub params: Vec<Estimate>,
    /// Held-out χ² per residual before and after.
    pub heldout: (f64, f64),
    /// The probabilities as stated: `none` as its group's total ([`hypotheses::group`]).
    pub probabilities: Vec<Probability>,
    /// What `none` holds: the null and the candidates below their floor.
    pub within_none: Vec<Probability>,
    pub set: Vec<String>,
    pub separation: Option<Separation>,
    /// The factor the evidence between candidates was divided by ([`crate::verdict::misfit`]).
    pub tempering: f64,
}

/// The probability of each hypothesis: `none` (ΔBIC 0) and every applicable candidate that
/// passes the held-out gates, floor or not (a candidate that does not predict held-out levels
/// better is not supported, whatever its ΔBIC), from the prior ([`PRIOR_NONE`], the rest shared
/// by `n_effects`, an effect's share split between its forms) and the evidence
/// exp(ΔBIC / 2·[`EVIDENCE_SCALE`]) (BIC's approximation of the marginal likelihood, Kass &
/// Raftery 1995; on the data ΔBIC is divided by the overdispersion `c_hat`), averaged over the
/// levels' bootstrap ([`crate::evidence::level_bootstrap`]: how much of a lead the `n_levels` levels
/// share), the split among the candidates above their floor fitted to the data tempered by `between`
/// ([`crate::verdict::misfit`]); the null and the candidates below their floor keep BIC's point
/// odds. Most probable first.
pub fn posterior(scores: &[Score], n_effects: usize, n_levels: usize, c_hat: f64, between: f64) -> Vec<Probability> {
    let ln_prior_effect = ((1.0 - PRIOR_NONE) / n_effects.max(1) as f64).ln();
    let supported: Vec<&Score> = scores.iter().filter(|s| supported(s)).collect();
    let per_level: Vec<Vec<f64>> = supported
        .iter()
        .map(|s| {
            let scale = if s.space == Space::Data { c_hat } else { 1.0 };
            s.delta_chi2_per_level.iter().map(|d| d / scale).collect()
        })
        .collect();
    // The null first, then the candidates below their floor (counted with it), then the rest.
    let order: Vec<usize> = (0..supported.len())
        .filter(|&i| supported[i].below_floor)
        .chain((0..supported.len()).filter(|&i| !supported[i].below_floor))
        .collect();
    let group = 1 + supported.iter().filter(|s| s.below_floor).count();
    let mut hypotheses = vec![Evidence { ln_prior: PRIOR_NONE.ln(), delta_bic: 0.0, per_level: &[], on_data: true }];
    hypotheses.extend(order.iter().map(|&i| Evidence {
        ln_prior: ln_prior_effect - (forms(scores, &supported[i].name) as f64).ln(),
        delta_bic: supported[i].delta_bic,
        per_level: &per_level[i],
        on_data: supported[i].space == Space::Data,
    }));
    let p = averaged_posterior(&hypotheses, group, n_levels, EVIDENCE_SCALE, between);
    let names = std::iter::once(NONE.to_string()).chain(order.iter().map(|&i| supported[i].name.clone()));
    let mut out: Vec<Probability> = names.zip(p).map(|(name, probability)| Probability { name, probability }).collect();
    out.sort_by(|a, b| b.probability.total_cmp(&a.probability));
    out
}

/// A candidate the probabilities weigh: applicable, through its gates, with a finite ΔBIC.
fn supported(s: &Score) -> bool {
    s.applicable && s.other_gates && s.delta_bic.is_finite()
}

/// The candidate whose residuals temper the evidence between candidates on the data: the best
/// supported one fitted to the data (`fitted` says which were fitted), its residuals as its fit
/// left them, the instrument's channels where it moved them ([`Fitted::levels`]): the plain
/// model's channels take part of a concealed effect (a shared delay, part of a pole's lag), and
/// the residuals of the levels as those channels leave them would show, at every candidate, the
/// misfit the candidate's own fit removed. A candidate acting on the
/// levels' parameters (a humidity remap, a temperature dependence) is not fitted within a
/// level: its residuals there carry the levels' scatter, which its own likelihood weighs
/// already, not the misfit of a shape.
fn tempering_source(scores: &[Score], fitted: &[bool]) -> Option<usize> {
    (0..scores.len())
        .filter(|&i| supported(&scores[i]) && fitted[i] && scores[i].space == Space::Data)
        .max_by(|&a, &b| scores[a].delta_bic.total_cmp(&scores[b].delta_bic))
}

/// How many forms of the effect `name` were scored.
fn forms(scores: &[Score], name: &str) -> usize {
    scores.iter().filter(|s| s.name == name).count()
}

/// Where an effect was fitted in several forms (`crate::candidates::Candidate::form`), only the
/// form with the larger ΔBIC stays a hypothesis: the effect's prior is split between its forms
/// ([`posterior`]), and dropping the other's evidence keeps the effect's probability a lower
/// bound (the exact sum gains at most ln 2 where the two forms fit alike).
fn keep_better_forms(scores: &mut [Score]) {
    for i in 0..scores.len() {
        let beaten = scores.iter().enumerate().any(|(j, o)| {
            j != i
                && o.name == scores[i].name
                && supported(o)
                && (o.delta_bic > scores[i].delta_bic || (o.delta_bic == scores[i].delta_bic && j < i))
        });
        if beaten && supported(&scores[i]) {
            let s = &mut scores[i];
            s.other_gates = false;
            s.passes = false;
            s.note = if s.note.is_empty() {
                "another form of this effect fits better".into()
            } else {
                format!("{}; another form of this effect fits better", s.note)
            };
        }
    }
}

/// Corrects the data-space ΔBIC of `scores` (in the order of `candidates`) for overdispersion,
/// then decides. `fitted` holds each tested candidate's fits, `located` the summary of where
/// the mismatch lives.
pub(crate) fn decide(
    ctx: &Ctx,
    candidates: &[Candidate],
    scores: &mut [Score],
    fitted: &[Option<Fitted>],
    base: &Baseline,
    located: &str,
) -> Decision {
    let n_levels = ctx.n_levels();
    // Overdispersion: ΔBIC on the data as quasi-likelihood differences.
    let c_hat = overdispersion(scores, base.chi2_0, base.n_data - 4.0 * n_levels as f64);
    for sc in scores.iter_mut().filter(|sc| sc.applicable && sc.space == Space::Data) {
        sc.delta_bic = sc.delta_chi2 / c_hat - sc.extra_params as f64 * base.n_data.ln();
        sc.passes = sc.other_gates && !sc.below_floor && sc.delta_bic >= MIN_DELTA_BIC;
    }
    keep_better_forms(scores);
    let structure_before =
        fits::structure_z(ctx.calib, &ctx.data.levels, &ctx.sig, &ctx.all, &ctx.base.theta, &vec![Extension::default(); n_levels]);
    let structured = structure_before > STRUCTURED_Z;
    let best = tempering_source(scores, &fitted.iter().map(Option::is_some).collect::<Vec<_>>());
    let tempering = best.and_then(|i| fitted[i].as_ref()).map_or(1.0, |f| {
        crate::verdict::misfit::between_candidates(fits::residual_correlation(
            ctx.calib,
            &f.levels(ctx.data),
            &ctx.sig,
            &f.masks,
            &f.theta,
            &f.ext,
        ))
    });
    let raw = posterior(scores, crate::Effect::ALL.len(), n_levels, c_hat, tempering);
    let below = |name: &str| scores.iter().any(|s| s.name == name && supported(s) && s.below_floor);
    let grouped = hypotheses::group(&raw, &below);
    let passes = |name: &str| scores.iter().any(|s| s.name == name && s.passes);
    let (ruling, stated) = hypotheses::rule(&grouped.probabilities, &passes);
    let set = hypotheses::listed(&stated, &grouped.within_none);
    let probabilities = grouped.probabilities;
    let within_none = grouped.within_none;
    let top = &probabilities[0];
    let probability_of =
        |name: &str| probabilities.iter().chain(within_none.iter().skip(1)).find(|p| p.name == name).map_or(0.0, |p| p.probability);
    let named = match &ruling {
        Ruling::Named(name) => scores.iter().position(|s| &s.name == name && s.passes),
        _ => None,
    };
    let separation = (set.len() >= 2).then(|| separating(&set[0], &set[1]));
    if ruling == Ruling::Undecided {
        let refit = weighted_mean(&per_level_scores(&ctx.refit_null()), &base.counts);
        let lean: Vec<String> = set.iter().map(|n| format!("{n} ({:.0} %)", 100.0 * probability_of(n))).collect();
        let measure = separation
            .as_ref()
            .map_or(String::new(), |m| format!("; {} ({}) would separate {} from {}", m.record, m.band, m.between[0], m.between[1]));
        let alternatives = set
            .iter()
            .filter_map(|n| scores.iter().find(|s| &s.name == n && supported(s)))
            .map(|b| Alternative {
                name: b.name.clone(),
                delta_bic: b.delta_bic,
                delta_bic_gap: scores.iter().find(|s| s.name == top.name && supported(s)).map_or(0.0, |t| t.delta_bic) - b.delta_bic,
                heldout: b.heldout,
                heldout_z: b.heldout_z,
                heldout_z_vs_verdict: None,
                separate_by: separating_measurement(&top.name, &b.name),
                probability: probability_of(&b.name),
            })
            .collect();
        return Decision {
            verdict: Verdict::Undecided,
            winner: None,
            alternatives,
            overdispersion: c_hat,
            family: String::new(),
            form: String::new(),
            explanation: format!(
                "no hypothesis holds {:.0} % of the probability alone; the data lean to {}{measure}",
                100.0 * CONFIDENCE,
                lean.join(", ")
            ),
            params: vec![],
            heldout: (refit, refit),
            probabilities,
            within_none,
            set,
            separation,
            tempering,
        };
    }
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| {
        let (sa, sb) = (&scores[a], &scores[b]);
        sb.passes.cmp(&sa.passes).then(sb.delta_bic.total_cmp(&sa.delta_bic))
    });
    let Some(w) = named else {
        let refit = weighted_mean(&per_level_scores(&ctx.refit_null()), &base.counts);
        let (verdict, mut explanation) = if structured {
            (Verdict::Unexplained, format!("a structured residual ({located}) that no candidate explains"))
        } else {
            (Verdict::None, "no missing physics above the noise".to_string())
        };
        // "No extension" is the verdict with ΔBIC 0: the ambiguity rule against it lists every
        // candidate the data favour over it (ΔBIC > 0, held-out gates passed) without the
        // evidence naming needs.
        let alternatives: Vec<Alternative> = order
            .iter()
            .map(|&i| &scores[i])
            .filter(|b| set.contains(&b.name) && supported(b))
            .map(|b| Alternative {
                name: b.name.clone(),
                delta_bic: b.delta_bic,
                delta_bic_gap: -b.delta_bic,
                heldout: b.heldout,
                heldout_z: b.heldout_z,
                heldout_z_vs_verdict: None,
                separate_by: separating_measurement(verdict.as_str(), &b.name),
                probability: probability_of(&b.name),
            })
            .collect();
        if !alternatives.is_empty() {
            explanation += &format!(
                "; the data lean to {} without the evidence to name it",
                alternatives
                    .iter()
                    .map(|a| {
                        let below = scores.iter().any(|s| s.name == a.name && s.below_floor);
                        format!("{} (ΔBIC {:.1}{})", a.name, a.delta_bic, if below { ", below its floor" } else { "" })
                    })
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        return Decision {
            verdict,
            winner: None,
            alternatives,
            overdispersion: c_hat,
            family: String::new(),
            form: String::new(),
            explanation,
            params: vec![],
            heldout: (refit, refit),
            probabilities,
            within_none,
            set,
            separation,
            tempering,
        };
    };
    let s = &scores[w];
    let alternatives: Vec<Alternative> = order[1..]
        .iter()
        .map(|&i| &scores[i])
        .filter(|b| set.contains(&b.name) && supported(b) && b.name != s.name)
        .map(|b| {
            let shared_null = s.space == b.space && s.heldout_null_per_level == b.heldout_null_per_level;
            Alternative {
                name: b.name.clone(),
                delta_bic: b.delta_bic,
                delta_bic_gap: s.delta_bic - b.delta_bic,
                heldout: b.heldout,
                heldout_z: b.heldout_z,
                heldout_z_vs_verdict: shared_null
                    .then(|| crate::evidence::held_out::paired_z(&b.heldout_per_level, &s.heldout_per_level, &base.counts)),
                separate_by: separating_measurement(&s.name, &b.name),
                probability: probability_of(&b.name),
            }
        })
        .collect();
    let f = fitted[w].as_ref().expect("a passing candidate was fitted");
    let after = fits::structure_z(ctx.calib, &f.levels(ctx.data), &ctx.sig, &f.masks, &f.theta, &f.ext);
    // The share of the neighbour correlation the winner removes. Candidates acting through
    // humidity explain the levels' parameters, not the shape within a level: the structure
    // test is for candidates fitted to the data.
    let explained = if structured && s.space == Space::Data { 1.0 - after.max(0.0) / structure_before } else { 1.0 };
    // A candidate that passes both gates explains part of the mismatch even when a structured
    // residual remains (a second effect, or a law the candidate approximates): "unexplained" is
    // for a residual no candidate explains, so the winner is named and the remainder reported
    // with it.
    let remainder = if structured && after > STRUCTURED_Z && explained < 0.5 {
        format!(
            "; a structured residual remains ({located}): {} explains {:.0} % of its neighbour correlation",
            s.name,
            100.0 * explained.max(0.0)
        )
    } else {
        String::new()
    };
    Decision {
        verdict: Verdict::Named(candidates[w].effect),
        winner: Some(w),
        overdispersion: c_hat,
        family: s.family.clone(),
        form: s.form.clone(),
        explanation: format!(
            "{} (ΔBIC {:.1}, held-out χ²/residual {:.3} → {:.3}, z = {:.1}){remainder}",
            s.name, s.delta_bic, s.heldout_null, s.heldout, s.heldout_z
        ),
        params: s.params.clone(),
        heldout: (s.heldout_null, s.heldout),
        alternatives,
        probabilities,
        within_none,
        set,
        separation,
        tempering,
    }
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
    // Not a candidate below its floor: a mains fit whose lines are no worse than their
    // neighbours has absorbed a broad misfit at them, and its χ² would understate the scatter
    // every other candidate is scored against.
    for s in scores.iter().filter(|s| s.applicable && s.space == Space::Data && s.other_gates && !s.below_floor) {
        let dof = (dof_0 - s.extra_params as f64).max(1.0);
        best = best.min((chi2_0 - s.delta_chi2) / dof);
    }
    best.max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(name: &str, delta_chi2: f64, delta_bic: f64, other_gates: bool) -> Score {
        Score {
            name: name.into(),
            family: String::new(),
            form: String::new(),
            applicable: true,
            params: vec![],
            delta_chi2,
            delta_chi2_per_level: vec![],
            extra_params: 1,
            delta_bic,
            space: Space::Data,
            heldout: 1.0,
            heldout_per_level: vec![],
            heldout_null: 1.0,
            heldout_null_per_level: vec![],
            heldout_z: 1.0,
            heldout_between_lines: false,
            passes: other_gates && delta_bic >= MIN_DELTA_BIC,
            note: String::new(),
            other_gates,
            below_floor: false,
        }
    }

    fn gated(name: &str, delta_bic: f64) -> Score {
        score(name, 0.0, delta_bic, true)
    }

    /// Probabilities sum to one; a candidate failing the held-out gates gets none.
    #[test]
    fn probabilities_cover_the_supported_hypotheses() {
        let scores = [gated("a", 30.0), gated("b", 20.0), score("c", 0.0, 50.0, false)];
        let p = posterior(&scores, 14, 1, 1.0, 1.0);
        assert_eq!(p.len(), 3);
        assert!((p.iter().map(|p| p.probability).sum::<f64>() - 1.0).abs() < 1e-12);
        assert_eq!(p[0].name, "a");
        assert!(p.iter().all(|p| p.name != "c"));
    }

    /// The smallest set holding CONFIDENCE: one hypothesis far ahead stands alone; two a few
    /// ΔBIC apart stand together; nothing supported leaves `none` alone.
    #[test]
    fn the_set_is_the_smallest_holding_the_confidence() {
        assert_eq!(credible_set(&posterior(&[gated("a", 40.0), gated("b", 10.0)], 14, 1, 1.0, 1.0)), ["a"]);
        assert_eq!(credible_set(&posterior(&[gated("a", 40.0), gated("b", 38.0)], 14, 1, 1.0, 1.0)), ["a", "b"]);
        assert_eq!(credible_set(&posterior(&[gated("a", -3.0)], 14, 1, 1.0, 1.0)), [NONE]);
        // The prior's odds against one candidate (1:14) are met at ΔBIC ≈ 9.7 on its own.
        let alone = |d: f64| posterior(&[gated("a", d)], 14, 1, 1.0, 1.0)[0].clone();
        assert!(alone(9.0).probability < CONFIDENCE || alone(9.0).name == NONE);
        assert!(alone(10.5).name == "a" && alone(10.5).probability >= CONFIDENCE);
    }

    /// The residuals that temper are the best data-space candidate's, not a better candidate's
    /// acting on the levels' parameters, nor an unfitted or unsupported one's.
    #[test]
    fn the_tempering_comes_from_the_best_fit_to_the_data() {
        let mut levels = gated("temperature", 12.0);
        levels.space = Space::LevelParameters;
        let scores = [gated("tip_timing", -2.0), levels, gated("amplifier_bandwidth", 3.0), score("tip_mass", 0.0, 9.0, false)];
        assert_eq!(tempering_source(&scores, &[true; 4]), Some(2));
        assert_eq!(tempering_source(&scores, &[true, true, false, true]), Some(0));
        assert_eq!(tempering_source(&scores[1..2], &[true]), None);
    }

    /// ĉ is the best-fitting model's χ²/dof, never below 1.
    #[test]
    fn overdispersion_is_the_best_fit_per_dof() {
        let scores = [score("a", 100.0, 0.0, true), score("b", 300.0, 0.0, true), score("c", 390.0, 0.0, false)];
        let c = overdispersion(&scores, 500.0, 101.0);
        assert!((c - 200.0 / 100.0).abs() < 1e-12, "{c}");
        assert_eq!(overdispersion(&scores, 50.0, 101.0), 1.0);
    }

    /// Below its floor a candidate keeps its probability but is not named: the traced up sweep,
    /// where a lag (ΔBIC 27.87) and an offset just under its floor (27.72) tie, is undecided
    /// between the lag and `none` holding the offset, rather than the lag at 99.99 % against
    /// `none`; alone and far ahead, a candidate below its floor still holds the probability,
    /// within `none`, and is not named.
    #[test]
    fn a_floor_blocks_naming_not_the_probability() {
        let mut offset = gated("humidity_sensor_error", 27.72);
        offset.below_floor = true;
        offset.passes = false;
        let stated = |scores: &[Score]| {
            let raw = posterior(scores, 14, 1, 1.0, 1.0);
            let below = |n: &str| scores.iter().any(|s| s.name == n && s.below_floor);
            let g = hypotheses::group(&raw, &below);
            let passes = |n: &str| scores.iter().any(|s| s.name == n && s.passes);
            let (ruling, set) = hypotheses::rule(&g.probabilities, &passes);
            (raw, ruling, hypotheses::listed(&set, &g.within_none))
        };
        let of = |p: &[Probability], n: &str| p.iter().find(|p| p.name == n).map_or(0.0, |p| p.probability);
        let tie = [gated("hydration_lag", 27.87), offset.clone()];
        let (raw, ruling, set) = stated(&tie);
        assert!(of(&raw, "humidity_sensor_error") > 0.4, "{raw:?}");
        assert!(of(&raw, "hydration_lag") < CONFIDENCE, "{raw:?}");
        assert_eq!(ruling, Ruling::Undecided);
        assert!(set.contains(&"humidity_sensor_error".to_string()) && set.contains(&"hydration_lag".to_string()), "{set:?}");
        let alone = [gated("hydration_lag", 2.0), {
            let mut o = offset;
            o.delta_bic = 40.0;
            o
        }];
        let (raw, ruling, set) = stated(&alone);
        assert_eq!(raw[0].name, "humidity_sensor_error");
        assert!(raw[0].probability >= CONFIDENCE);
        assert_eq!(ruling, Ruling::Nothing);
        assert_eq!(set, [NONE.to_string(), "humidity_sensor_error".to_string()]);
        let passing = [gated("hydration_lag", 2.0), gated("humidity_sensor_error", 40.0)];
        assert_eq!(stated(&passing).1, Ruling::Named("humidity_sensor_error".into()));
    }
}
