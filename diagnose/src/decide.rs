//! The decision: which candidate, if any, the evidence names, and which others the data cannot
//! separate from it.
//!
//! A candidate must beat "no extension" by ΔBIC ≥ [`MIN_DELTA_BIC`] and lower the held-out χ²
//! with a paired significance over levels z ≥ [`MIN_HELDOUT_Z`] (a weak gate: the held-out
//! differences between levels are heavy-tailed, a few levels carry an effect that grows with
//! humidity or temperature, so the strong gate is the information criterion), and pass its
//! kind's floor (a humidity remap must move some level by [`crate::remap::MIN_RH_SHIFT_PCT`],
//! mains lines must stand out from their neighbours). Among those
//! the largest ΔBIC wins; every other candidate passing the held-out gates within
//! [`INDISTINGUISHABLE_BIC`] of it is reported as indistinguishable. With none passing, the
//! verdict is "none" if the per-level refit leaves no structured residual (neighbour
//! correlation, [`fits::structure_z`]), "unexplained" if it does. A winner that removes less
//! than half of a structured residual's neighbour correlation is still named (it passed both
//! gates), with the remainder reported.

use crate::candidates::Candidate;
use crate::context::{Ctx, Fitted};
use crate::fits;
use crate::held_out::{per_level_scores, weighted_mean};
use crate::scorers::Baseline;
use crate::types::{Alternative, Estimate, Score, Space, Verdict};
use ipmc_core::extension::Extension;

/// Very strong evidence on Kass & Raftery's scale (ΔBIC > 10 ⇔ Bayes factor > 150).
pub const MIN_DELTA_BIC: f64 = 10.0;
/// Two candidates are told apart only when one beats the other by the evidence a candidate
/// needs to be named at all ([`MIN_DELTA_BIC`], "very strong" on Kass & Raftery's scale):
/// every passing candidate whose ΔBIC is within this of the best is reported as
/// indistinguishable from it. A confident wrong name is worse than an honest pair.
pub const INDISTINGUISHABLE_BIC: f64 = MIN_DELTA_BIC;
/// Paired improvement of the held-out χ² over levels, in standard errors.
pub const MIN_HELDOUT_Z: f64 = 0.5;
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
    pub explanation: String,
    pub params: Vec<Estimate>,
    /// Held-out χ² per residual before and after.
    pub heldout: (f64, f64),
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
        sc.passes = sc.other_gates && sc.delta_bic >= MIN_DELTA_BIC;
    }
    let structure_before =
        fits::structure_z(ctx.calib, &ctx.data.levels, &ctx.sig, &ctx.all, &ctx.base.theta, &vec![Extension::default(); n_levels]);
    let structured = structure_before > STRUCTURED_Z;
    let mut order: Vec<usize> = (0..scores.len()).collect();
    order.sort_by(|&a, &b| {
        let (sa, sb) = (&scores[a], &scores[b]);
        sb.passes.cmp(&sa.passes).then(sb.delta_bic.total_cmp(&sa.delta_bic))
    });
    let Some(w) = order.first().copied().filter(|&i| scores[i].passes) else {
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
            .filter(|b| leans_over_none(b))
            .map(|b| Alternative {
                name: b.name.clone(),
                delta_bic: b.delta_bic,
                delta_bic_gap: -b.delta_bic,
                heldout: b.heldout,
                heldout_z: b.heldout_z,
                heldout_z_vs_verdict: None,
                separate_by: separating_measurement(verdict.as_str(), &b.name),
            })
            .collect();
        if !alternatives.is_empty() {
            explanation += &format!(
                "; the data lean to {} without the evidence to name it",
                alternatives.iter().map(|a| format!("{} (ΔBIC {:.1})", a.name, a.delta_bic)).collect::<Vec<_>>().join(", ")
            );
        }
        return Decision {
            verdict,
            winner: None,
            alternatives,
            overdispersion: c_hat,
            family: String::new(),
            explanation,
            params: vec![],
            heldout: (refit, refit),
        };
    };
    let s = &scores[w];
    let alternatives: Vec<Alternative> = order[1..]
        .iter()
        .map(|&i| &scores[i])
        .filter(|b| indistinguishable(s, b))
        .map(|b| {
            let shared_null = s.space == b.space && s.heldout_null_per_level == b.heldout_null_per_level;
            Alternative {
                name: b.name.clone(),
                delta_bic: b.delta_bic,
                delta_bic_gap: s.delta_bic - b.delta_bic,
                heldout: b.heldout,
                heldout_z: b.heldout_z,
                heldout_z_vs_verdict: shared_null
                    .then(|| crate::held_out::paired_z(&b.heldout_per_level, &s.heldout_per_level, &base.counts)),
                separate_by: separating_measurement(&s.name, &b.name),
            }
        })
        .collect();
    let f = fitted[w].as_ref().expect("a passing candidate was fitted");
    let after = fits::structure_z(ctx.calib, &ctx.data.levels, &ctx.sig, &f.masks, &f.theta, &f.ext);
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
    let ties = if alternatives.is_empty() {
        String::new()
    } else {
        format!(
            "; the data cannot tell it from {} (ΔBIC within {INDISTINGUISHABLE_BIC})",
            alternatives.iter().map(|a| format!("{} (ΔBIC {:.1})", a.name, a.delta_bic)).collect::<Vec<_>>().join(", ")
        )
    };
    Decision {
        verdict: Verdict::Named(candidates[w].effect),
        winner: Some(w),
        overdispersion: c_hat,
        family: s.family.clone(),
        explanation: format!(
            "{} (ΔBIC {:.1}, held-out χ²/residual {:.3} → {:.3}, z = {:.1}){ties}{remainder}",
            s.name, s.delta_bic, s.heldout_null, s.heldout, s.heldout_z
        ),
        params: s.params.clone(),
        heldout: (s.heldout_null, s.heldout),
        alternatives,
    }
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

/// The ambiguity rule with "no extension" as the verdict (ΔBIC 0, held-out unchanged): `b`
/// passes every gate but the information criterion's and the data favour it over no extension
/// at all (ΔBIC > 0). With no candidate named, every such one is below the naming threshold.
fn leans_over_none(b: &Score) -> bool {
    b.applicable && b.other_gates && b.delta_bic > 0.0
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
    for s in scores.iter().filter(|s| s.applicable && s.space == Space::Data && s.other_gates) {
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
        "measure the amplifier with a test current through a known capacitor (its pole stays, the electrodes' line goes), or the electrodes' surface resistance (four-point probe); sweeping past 1/(2πτ) separates them too (an RC line's phase tends to −45°, a pole's to −90°)"
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

    /// With nothing named, the candidates the data favour over no extension that pass the
    /// held-out gates are reported; one the data do not favour, or failing those gates, is not.
    #[test]
    fn leaning_over_none() {
        assert!(leans_over_none(&score("a", 0.0, 6.9, true)));
        assert!(!leans_over_none(&score("b", 0.0, -0.1, true)));
        assert!(!leans_over_none(&score("c", 0.0, 6.9, false)));
        assert!(separating_measurement("none", "temperature").contains("temperature"));
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
