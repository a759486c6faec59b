//! The evidence's uncertainty over levels: a Bayesian bootstrap (Rubin 1981) of each
//! candidate's Δχ² level by level, the probabilities averaged over its replicates.
//!
//! Why: ΔBIC adds Δχ² over thousands of residuals as if each were an independent datum, but
//! within a level the residuals are correlated along frequency and each level brings its own
//! calibration drift; the units that replicate are the levels. Two candidates that mimic each
//! other (a viscoelastic law and air loading, an RC line and a pole) both approximate the
//! concealed effect, and which approximates it better changes from level to level; the sum's
//! sign then rests on a few levels, and BIC's odds, e^{ΔΔBIC/2}, state as certain what another
//! set of levels would reverse. Weighting the levels by Dirichlet(1, …, 1) draws (the same
//! draw for every candidate: the comparison is paired) and averaging each draw's posterior
//! keeps a lead that every level shares and splits one that a few levels carry: the
//! regularization of Yao, Vehtari, Simpson & Gelman (2018, "pseudo-BMA+") for model sets that
//! do not hold the truth exactly. Candidates whose evidence does not decompose by level
//! (humidity remaps, mains) keep their ΔBIC in every replicate.

use ipmc_fit::random::SplitMix64;

/// Number of replicates: the Monte-Carlo error of a probability is ≤ 0.5/√N ≈ 0.008.
pub const REPLICATES: usize = 4000;

/// One hypothesis's evidence: the point ΔBIC and its Δχ² per level on the ΔBIC's scale
/// (divided by the overdispersion), empty when it does not decompose by level; `on_data` when
/// it is a likelihood of the measured values (the tempering between candidates is of their
/// residuals' correlation, [`crate::verdict::misfit`]), not of the levels' parameters.
pub struct Evidence<'a> {
    pub ln_prior: f64,
    pub delta_bic: f64,
    pub per_level: &'a [f64],
    pub on_data: bool,
}

/// The posterior probability of each hypothesis, `hypotheses[0]` being the null (no effect,
/// ΔBIC 0) that every other one nests and the next `group − 1` the candidates counted with it
/// (below their floor: nothing worth naming); `scale` divides every ΔBIC (the evidence's
/// temperature), and `between` ≥ 1 divides it again where the other candidates are weighed
/// against each other (the misfit they leave: [`crate::verdict::misfit`]), for the evidence
/// `on_data` only: `between` counts how many independent data a level's correlated residuals
/// carry, and a likelihood of the levels' parameters already counts a level as one datum per
/// parameter, with the scatter between levels in its variance. In the order given.
///
/// The null's group keeps BIC's own probabilities, from the point evidence: the null's Δχ²
/// against a candidate is ≥ 0 at every level by construction, so re-weighting the levels can only
/// spread a losing candidate's evidence upwards through the convex odds (Jensen) and would lend
/// every clean strip's candidates probability whatever its data; and tempering the group's
/// members against the others would pass their probability to whichever candidate they resemble.
/// What the levels' bootstrap judges is which of the other candidates explains what the group
/// leaves: the rest of the probability is split among them by their posterior averaged over
/// [`REPLICATES`] Bayesian-bootstrap weightings of the `n_levels` levels.
pub fn averaged_posterior(hypotheses: &[Evidence], group: usize, n_levels: usize, scale: f64, between: f64) -> Vec<f64> {
    let ln = |h: &Evidence, shift: f64, t: f64| h.ln_prior + (h.delta_bic + shift) / (2.0 * scale * if h.on_data { t } else { 1.0 });
    let mut point = vec![0.0; hypotheses.len()];
    accumulate(&mut point, hypotheses.iter().map(|h| ln(h, 0.0, 1.0)), 1.0);
    let group = group.clamp(1, hypotheses.len().max(1));
    if hypotheses.len() <= group {
        return point;
    }
    let rest = 1.0 - point[..group].iter().sum::<f64>();
    let others = &hypotheses[group..];
    let mut shares = vec![0.0; others.len()];
    let decomposes = |h: &Evidence| n_levels > 1 && h.per_level.len() == n_levels;
    let joined = |shares: &[f64]| point[..group].iter().copied().chain(shares.iter().map(|s| s * rest)).collect::<Vec<f64>>();
    if !others.iter().any(decomposes) {
        accumulate(&mut shares, others.iter().map(|h| ln(h, 0.0, between)), 1.0);
        return joined(&shares);
    }
    let mut rng = SplitMix64(0x1d_c0ff_ee27);
    let mut w = vec![0.0; n_levels];
    for _ in 0..REPLICATES {
        // Dirichlet(1, …, 1) × n_levels: exponential draws normalized to mean one.
        for wi in w.iter_mut() {
            *wi = -(1.0 - rng.uniform()).ln();
        }
        let total: f64 = w.iter().sum();
        w.iter_mut().for_each(|wi| *wi *= n_levels as f64 / total);
        let replicate = others.iter().map(|h| {
            let shift: f64 = if decomposes(h) { h.per_level.iter().zip(&w).map(|(d, wi)| d * (wi - 1.0)).sum() } else { 0.0 };
            ln(h, shift, between)
        });
        accumulate(&mut shares, replicate, 1.0 / REPLICATES as f64);
    }
    joined(&shares)
}

/// Adds `weight` × the normalized probabilities of the log-weights `ln` to `into`.
fn accumulate(into: &mut [f64], ln: impl Iterator<Item = f64>, weight: f64) {
    let ln: Vec<f64> = ln.collect();
    let top = ln.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let total: f64 = ln.iter().map(|v| (v - top).exp()).sum();
    for (m, v) in into.iter_mut().zip(&ln) {
        *m += weight * (v - top).exp() / total;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn h<'a>(delta_bic: f64, per_level: &'a [f64]) -> Evidence<'a> {
        Evidence { ln_prior: 0.0, delta_bic, per_level, on_data: true }
    }

    /// Among candidates, a lead every level shares stays certain and the same lead carried by
    /// one level of ten against the others is split; the null's probability is BIC's own
    /// however the candidates' evidence is spread over levels; without per-level evidence the
    /// result is BIC's own posterior.
    #[test]
    fn a_lead_few_levels_carry_is_split_between_candidates() {
        let shared = [3.0; 10];
        let flat = [1.0; 10];
        let null = || h(-100.0, &[]);
        let p = averaged_posterior(&[null(), h(30.0, &shared), h(10.0, &flat)], 1, 10, 1.0, 1.0);
        assert!(p[1] > 0.99, "{p:?}");
        // The same ΔBIC from one level while the nine others lean the other way.
        let mut one = [-1.0; 10];
        one[3] = 29.0;
        let p = averaged_posterior(&[null(), h(30.0, &one), h(10.0, &flat)], 1, 10, 1.0, 1.0);
        assert!(p[1] < 0.9 && p[1] > 0.3, "{p:?}");
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9, "{p:?}");
        let p = averaged_posterior(&[h(4.0, &[]), h(0.0, &[])], 1, 10, 1.0, 1.0);
        let bic = 1.0 / (1.0 + (-2.0f64).exp());
        assert!((p[0] - bic).abs() < 1e-12 && (p.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{p:?}");
    }

    /// A clean strip: the candidate's Δχ² sits in one level (noise) and its ΔBIC is negative.
    /// Re-weighting levels would lend it up to a tenth of the probability; the null keeps
    /// BIC's odds.
    #[test]
    fn the_null_keeps_its_point_odds() {
        let mut one = [0.1; 10];
        one[2] = 14.0;
        let delta_bic = one.iter().sum::<f64>() - 18.0;
        let p = averaged_posterior(&[h(0.0, &[]), h(delta_bic, &one)], 1, 10, 1.0, 1.0);
        let bic = 1.0 / (1.0 + (delta_bic / 2.0).exp());
        assert!((p[0] - bic).abs() < 1e-12, "{p:?} against {bic}");
    }

    /// Tempering between candidates splits a lead of two look-alikes that both leave a smooth
    /// misfit, and leaves the null's probability as it was, and its group's: a candidate below
    /// its floor keeps its point probability however the others are tempered.
    #[test]
    fn tempering_splits_candidates_not_the_null() {
        let hyps = || [h(0.0, &[]), h(400.0, &[]), h(384.0, &[])];
        let sharp = averaged_posterior(&hyps(), 1, 10, 1.0, 1.0);
        let tempered = averaged_posterior(&hyps(), 1, 10, 1.0, 9.0);
        assert!(sharp[1] > 0.999, "{sharp:?}");
        assert!(tempered[1] < 0.8 && tempered[2] > 0.2, "{tempered:?}");
        assert!((sharp[0] - tempered[0]).abs() < 1e-15);
        let clean = [h(0.0, &[]), h(-12.0, &[])];
        assert!((averaged_posterior(&clean, 1, 10, 1.0, 9.0)[0] - averaged_posterior(&clean, 1, 10, 1.0, 1.0)[0]).abs() < 1e-15);
        let floor = [h(0.0, &[]), h(4.0, &[]), h(-2.0, &[]), h(-8.0, &[])];
        let (sharp, tempered) = (averaged_posterior(&floor, 2, 10, 1.0, 1.0), averaged_posterior(&floor, 2, 10, 1.0, 9.0));
        assert!((sharp[0] + sharp[1] - tempered[0] - tempered[1]).abs() < 1e-15, "{sharp:?} {tempered:?}");
        assert!(tempered[3] > sharp[3], "{sharp:?} {tempered:?}");
    }

    /// The tempering is of the residuals' correlation within a level: a candidate scored on the
    /// levels' parameters keeps its evidence against one fitted to the data, which a smooth
    /// misfit tempers (its negative ΔBIC drawn toward none's, its lead split).
    #[test]
    fn only_the_evidence_on_the_data_is_tempered() {
        let levels = |d: f64| Evidence { ln_prior: 0.0, delta_bic: d, per_level: &[], on_data: false };
        let hyps = || [h(0.0, &[]), levels(12.0), h(-2.0, &[])];
        let (sharp, tempered) = (averaged_posterior(&hyps(), 1, 10, 1.0, 1.0), averaged_posterior(&hyps(), 1, 10, 1.0, 4.0));
        let odds = |p: &[f64]| (p[1] / p[2]).ln();
        assert!((odds(&tempered) - (12.0 - -2.0 / 4.0) / 2.0).abs() < 1e-9, "{tempered:?}");
        assert!(odds(&tempered) < odds(&sharp));
        let both = [levels(0.0), levels(12.0), levels(-2.0)];
        assert_eq!(averaged_posterior(&both, 1, 10, 1.0, 4.0), averaged_posterior(&both, 1, 10, 1.0, 1.0));
    }
}
