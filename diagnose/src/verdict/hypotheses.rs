//! The one rule a report states: from the probabilities, the verdict and the set.
//!
//! `none` stands for "nothing worth naming from this recording": the null (no effect at all)
//! and every candidate below its floor (an offset that moves no level by a percent,
//! interference no worse at its lines than beside them), each listed within it
//! ([`Grouped::within_none`]), with the effects the recording cannot carry added there by the
//! follow-up's plan. The probabilities a report shows are these groups, so that `none` at 99 %
//! never stands beside a candidate at 99 %; the verdict is then the most probable group when it
//! holds [`CONFIDENCE`] (a candidate only when it also passes every gate naming needs), else
//! `undecided` with the smallest set of groups holding it.

use crate::candidates::effect::NONE;
use crate::verdict::types::Probability;

/// A hypothesis is stated alone only when it holds this much of the probability; otherwise the
/// verdict is `undecided` and the smallest set holding it is reported.
pub const CONFIDENCE: f64 = 0.9;

/// The probabilities as a report states them: `none` as its group's total, each other
/// candidate on its own, most probable first; and what `none` holds.
#[derive(Clone, Debug)]
pub struct Grouped {
    pub probabilities: Vec<Probability>,
    /// The null first, then the candidates below their floor, with their probabilities
    /// (summing to `none`'s).
    pub within_none: Vec<Probability>,
}

/// Groups the hypotheses' probabilities (`raw`, `none` being the null) with the candidates
/// `below_floor` counted in `none`.
pub fn group(raw: &[Probability], below_floor: &dyn Fn(&str) -> bool) -> Grouped {
    let null = raw.iter().find(|p| p.name == NONE).map_or(0.0, |p| p.probability);
    let mut within_none = vec![Probability { name: NONE.into(), probability: null }];
    within_none.extend(raw.iter().filter(|p| p.name != NONE && below_floor(&p.name)).cloned());
    let total: f64 = within_none.iter().map(|p| p.probability).sum();
    let mut probabilities: Vec<Probability> = raw.iter().filter(|p| p.name != NONE && !below_floor(&p.name)).cloned().collect();
    probabilities.push(Probability { name: NONE.into(), probability: total });
    probabilities.sort_by(|a, b| b.probability.total_cmp(&a.probability));
    Grouped { probabilities, within_none }
}

/// What the rule concludes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Ruling {
    /// This candidate holds the confidence and passes every gate.
    Named(String),
    /// `none` holds the confidence.
    Nothing,
    Undecided,
}

/// The verdict and the set from the grouped probabilities (most probable first); `passes` says
/// whether a candidate passes every gate naming needs. A candidate that holds the confidence
/// without the evidence naming needs is not stated alone: `none` stays beside it.
pub fn rule(probabilities: &[Probability], passes: &dyn Fn(&str) -> bool) -> (Ruling, Vec<String>) {
    let Some(top) = probabilities.first() else { return (Ruling::Nothing, vec![NONE.into()]) };
    if top.probability >= CONFIDENCE {
        if top.name == NONE {
            return (Ruling::Nothing, vec![NONE.into()]);
        }
        if passes(&top.name) {
            return (Ruling::Named(top.name.clone()), vec![top.name.clone()]);
        }
        return (Ruling::Undecided, vec![top.name.clone(), NONE.into()]);
    }
    (Ruling::Undecided, credible_set(probabilities))
}

/// The smallest set of hypotheses (most probable first) holding [`CONFIDENCE`].
pub fn credible_set(probabilities: &[Probability]) -> Vec<String> {
    let mut held = 0.0;
    let mut out = Vec::new();
    for p in probabilities {
        if held >= CONFIDENCE {
            break;
        }
        held += p.probability;
        out.push(p.name.clone());
    }
    out
}

/// The set as report.json lists it: where `none` is in it, the candidates it holds follow it.
pub fn listed(set: &[String], within_none: &[Probability]) -> Vec<String> {
    let mut out = Vec::new();
    for n in set {
        out.push(n.clone());
        if n == NONE {
            out.extend(within_none.iter().filter(|p| p.name != NONE).map(|p| p.name.clone()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(name: &str, probability: f64) -> Probability {
        Probability { name: name.into(), probability }
    }

    /// A sensor offset below its floor holding 99 % is counted in `none`: the verdict is
    /// `none` at 99.5 %, and the offset is listed within it, not beside it.
    #[test]
    fn a_candidate_below_its_floor_stands_within_none() {
        let raw = [p("humidity_sensor_error", 0.99), p("none", 0.005), p("tip_mass", 0.005)];
        let g = group(&raw, &|n| n == "humidity_sensor_error");
        assert_eq!(g.probabilities[0].name, NONE);
        assert!((g.probabilities[0].probability - 0.995).abs() < 1e-12);
        assert_eq!(g.within_none.len(), 2);
        let (ruling, set) = rule(&g.probabilities, &|_| true);
        assert_eq!(ruling, Ruling::Nothing);
        assert_eq!(listed(&set, &g.within_none), ["none", "humidity_sensor_error"]);
    }

    /// Named only through every gate; two close candidates leave the verdict undecided.
    #[test]
    fn one_rule_names_or_leaves_undecided() {
        let named = [p("a", 0.95), p("none", 0.05)];
        assert_eq!(rule(&named, &|_| true).0, Ruling::Named("a".into()));
        assert_eq!(rule(&named, &|_| false), (Ruling::Undecided, vec!["a".to_string(), NONE.to_string()]));
        let tie = [p("a", 0.6), p("b", 0.38), p("none", 0.02)];
        assert_eq!(rule(&tie, &|_| true), (Ruling::Undecided, vec!["a".to_string(), "b".to_string()]));
    }
}
