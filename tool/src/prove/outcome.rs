//! How a verdict stands against the truth, and the tables `ipmc prove` prints of many: the
//! outcome per class and the reliability of the stated probabilities; one case as a JSON record.

use anyhow::{Context, Result};

/// How a verdict stands against the truth: the rows of the outcome table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Class {
    /// The truth named (for a clean case: `none`).
    Named,
    /// `undecided`, the truth in the stated set.
    InSet,
    /// An effect present and `none`, `unexplained` or `undecided` without it in the set; or a
    /// clean case left undecided without `none` in the set.
    Missed,
    /// Another effect named alone.
    ConfidentWrong,
    /// A clean case given an effect's name.
    FalseAlarm,
}

impl Class {
    pub const ALL: [Class; 5] = [Class::Named, Class::InSet, Class::Missed, Class::ConfidentWrong, Class::FalseAlarm];

    pub fn of(truth: &str, verdict: &str, set: &[String]) -> Class {
        let named_effect = !matches!(verdict, "none" | "undecided" | "unexplained");
        if verdict == truth {
            Class::Named
        } else if verdict == "undecided" && set.iter().any(|n| n == truth) {
            Class::InSet
        } else if named_effect && truth == "none" {
            Class::FalseAlarm
        } else if named_effect {
            Class::ConfidentWrong
        } else {
            Class::Missed
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            Class::Named => "named",
            Class::InSet => "in set",
            Class::Missed => "none/missed",
            Class::ConfidentWrong => "confident wrong",
            Class::FalseAlarm => "false alarm",
        }
    }
}

/// The outcome table: per class, how many cases, and over all.
pub fn outcome_table(cases: &[(&str, Class)]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "\noutcomes ({} cases)", cases.len());
    let _ = writeln!(s, "{:<16} {:>6} {:>14} {:>12}", "outcome", "cases", "with effect", "clean");
    for c in Class::ALL {
        let n = |clean: bool| cases.iter().filter(|(t, k)| *k == c && (*t == "none") == clean).count();
        let _ = writeln!(s, "{:<16} {:>6} {:>14} {:>12}", c.label(), n(false) + n(true), n(false), n(true));
    }
    s
}

/// Reliability of the stated confidence: the most probable hypothesis's probability, binned,
/// against how often it was the truth.
pub fn reliability_table(cases: &[(f64, bool)]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "\nreliability (the most probable hypothesis: stated probability against how often it was the truth)");
    let _ = writeln!(s, "{:<14} {:>6} {:>10} {:>10}", "stated", "cases", "mean", "right");
    for (lo, hi) in [(0.0, 0.5), (0.5, 0.7), (0.7, 0.9), (0.9, 0.99), (0.99, 1.01)] {
        let bin: Vec<&(f64, bool)> = cases.iter().filter(|(p, _)| *p >= lo && *p < hi).collect();
        if bin.is_empty() {
            let _ = writeln!(s, "{:<14} {:>6} {:>10} {:>10}", format!("{:.0}–{:.0} %", 100.0 * lo, 100.0 * hi.min(1.0)), 0, "–", "–");
            continue;
        }
        let mean = bin.iter().map(|(p, _)| p).sum::<f64>() / bin.len() as f64;
        let right = bin.iter().filter(|(_, r)| *r).count();
        let _ = writeln!(
            s,
            "{:<14} {:>6} {:>9.1} % {:>5}/{:<4} ({:.0} %)",
            format!("{:.0}–{:.0} %", 100.0 * lo, 100.0 * hi.min(1.0)),
            bin.len(),
            100.0 * mean,
            right,
            bin.len(),
            100.0 * right as f64 / bin.len() as f64
        );
    }
    let stated: Vec<&(f64, bool)> = cases.iter().filter(|(p, _)| *p >= 0.9).collect();
    let right = stated.iter().filter(|(_, r)| *r).count();
    let _ = writeln!(s, "stated ≥ 90 %: {right}/{} right", stated.len());
    s
}

/// One case as a JSON line for `--records`.
pub fn record(truth: &str, d: &ipmc_diagnose::Diagnosis) -> serde_json::Value {
    serde_json::json!({
        "truth": truth,
        "verdict": d.verdict,
        "set": d.set,
        "probabilities": d.probabilities,
        "within_none": d.within_none,
        "tempering": d.tempering,
        "overdispersion": d.overdispersion,
        "candidates": d.candidates.iter().map(|c| serde_json::json!({
            "name": c.name, "applicable": c.applicable, "delta_bic": c.delta_bic, "passes": c.passes,
            "heldout_z": c.heldout_z, "other_gates": c.other_gates, "space": c.space, "delta_chi2": c.delta_chi2,
            "delta_chi2_per_level": c.delta_chi2_per_level, "extra_params": c.extra_params,
            "heldout_per_level": c.heldout_per_level, "heldout_null_per_level": c.heldout_null_per_level,
        })).collect::<Vec<_>>(),
        "humidity_reach": d.humidity_reach,
        "levels": d.levels.iter().map(|l| serde_json::json!({"rh_pct": l.rh_pct, "time_s": l.time_s, "revisit_of": l.revisit_of})).collect::<Vec<_>>(),
    })
}

/// Every way the report of `d` (diagnosed from `inputs`) disagrees with itself
/// (`ipmc_diagnose::verdict::consistency`): its verdict, probabilities, set and request against
/// the one rule.
pub fn disagreements(d: &ipmc_diagnose::Diagnosis, inputs: &[String]) -> Vec<String> {
    let rerun = ipmc_diagnose::report::Rerun { inputs, options: &[] };
    ipmc_diagnose::verdict::consistency::check(&ipmc_diagnose::report::json(d, &rerun, "", &[]))
}

/// The most probable hypothesis and its probability (`none` when nothing is stated).
pub fn top_of(d: &ipmc_diagnose::Diagnosis) -> (String, f64) {
    d.probabilities.first().map_or(("none".into(), 1.0), |p| (p.name.clone(), p.probability))
}

/// Writes `text` to `path` atomically.
pub fn write_atomically_text(path: &std::path::Path, text: &str) -> Result<()> {
    ipmc_recording::write_atomically(path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))
}
