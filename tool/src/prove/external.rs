//! `ipmc prove --external DIR`: recordings made elsewhere (DIR/caseNN.csv) diagnosed one at a
//! time, each timed, against DIR/truths.json; with the follow-ups, each case again with the
//! follow-up its report asks for (DIR/followups/caseNN-<protocol>.csv), and again with the next
//! one the report then asks for, up to the number asked.

use super::cases::{Outcome, table};
use super::outcome::{Class, disagreements, outcome_table, record, reliability_table, top_of, write_atomically_text};
use anyhow::{Context, Result};
use ipmc_diagnose::data::Dataset;
use ipmc_diagnose::engine;

/// The tool's candidate for an effect named in an external truths.json (its README's table).
pub fn candidate_of_external(effect: &str, params: &serde_json::Value) -> String {
    match effect {
        "tia_bandwidth" => "amplifier_bandwidth".into(),
        "sorption_lag" => "hydration_lag".into(),
        "channel_skew" => match params.get("channel").and_then(|c| c.as_str()) {
            Some("tip") => "tip_timing".into(),
            _ => "current_timing".into(),
        },
        "mains" => "mains_interference".into(),
        "rh_offset" => "humidity_sensor_error".into(),
        "viscoelastic" => "viscoelastic_relaxation".into(),
        other => other.into(),
    }
}

/// One external case's outcome.
pub struct ExternalOutcome {
    pub case: String,
    pub truth: String,
    pub verdict: String,
    /// ΔBIC of the named candidate (None for `none`, `undecided` and `unexplained`).
    pub delta_bic: Option<f64>,
    /// ΔBIC of the true candidate (None for clean cases or when it was not testable).
    pub truth_delta_bic: Option<f64>,
    pub seconds: f64,
    pub set: Vec<String>,
    pub top: (String, f64),
    pub record: serde_json::Value,
    /// The follow-up the report asks for.
    pub request: Option<ipmc_recording::Protocol>,
    /// How its report disagrees with itself (empty: it agrees).
    pub disagreements: Vec<String>,
}

impl ExternalOutcome {
    pub fn correct(&self) -> bool {
        self.verdict == self.truth
    }
    pub fn truth_in_set(&self) -> bool {
        self.set.contains(&self.truth)
    }
    pub fn class(&self) -> Class {
        Class::of(&self.truth, &self.verdict, &self.set)
    }
}

/// Diagnoses the recordings of `dir` against its truths and prints the tables (`json`: ends with
/// one JSON line of the counts; `records`: each case's JSON record written there).
/// `followups`: how many follow-ups each case may take in turn (0: the recordings alone).
pub fn external(dir: &std::path::Path, calib: Option<&str>, json: bool, records: Option<&std::path::Path>, followups: usize) -> Result<()> {
    let default_calib = dir.join("nominal.toml");
    let calib_arg = calib.map(str::to_string).unwrap_or_else(|| default_calib.display().to_string());
    let calib = crate::support::calibration_source::load(Some(&calib_arg))?;
    let truths_path = dir.join("truths.json");
    let truths: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&truths_path).with_context(|| format!("cannot read {}", truths_path.display()))?)
            .with_context(|| format!("{} is not JSON", truths_path.display()))?;
    let truths = truths.as_object().ok_or_else(|| anyhow::anyhow!("{}: expected an object of cases", truths_path.display()))?;
    let mut outcomes = Vec::new();
    println!("{:<7} {:<24} {:<24} {:>9} {:>9} {:>6}  set (probability)", "case", "truth", "verdict", "ΔBIC", "truth ΔBIC", "s");
    for (case, t) in truths {
        let path = dir.join(format!("{case}.csv"));
        let effect = t.get("effect").and_then(|e| e.as_str()).unwrap_or("none");
        let truth = candidate_of_external(effect, t.get("effect_params").unwrap_or(&serde_json::Value::Null));
        let t0 = std::time::Instant::now();
        let data = Dataset::read(std::slice::from_ref(&path), &calib.humidity)?;
        let d = engine::diagnose(&calib, &data, &|_| {}).with_context(|| format!("{case} ({truth})"))?;
        let seconds = t0.elapsed().as_secs_f64();
        let bic_of = |name: &str| d.candidates.iter().find(|c| c.name == name && c.applicable).map(|c| c.delta_bic);
        let o = ExternalOutcome {
            case: case.clone(),
            verdict: d.verdict.to_string(),
            delta_bic: bic_of(d.verdict.as_str()),
            truth_delta_bic: bic_of(&truth),
            set: d.set.clone(),
            top: top_of(&d),
            record: record(&truth, &d),
            request: d.request.as_ref().map(|r| r.protocol),
            disagreements: disagreements(&d, &[path.display().to_string()]),
            truth,
            seconds,
        };
        let mark = match o.class() {
            Class::Named => String::new(),
            c => format!("  ({})", c.label()),
        };
        let probability_of = |n: &str| d.probability_of(n);
        let set: Vec<String> = o.set.iter().map(|n| format!("{n} ({:.0} %)", 100.0 * probability_of(n))).collect();
        println!(
            "{:<7} {:<24} {:<24} {:>9} {:>9} {:>6.2}  {}{mark}",
            o.case,
            o.truth,
            o.verdict,
            o.delta_bic.map_or("–".into(), |b| format!("{b:.1}")),
            o.truth_delta_bic.map_or("–".into(), |b| format!("{b:.1}")),
            o.seconds,
            set.join(", ")
        );
        for e in &o.disagreements {
            println!("        its report disagrees with itself: {e}");
        }
        outcomes.push(o);
    }
    println!(
        "ΔBIC: of the named candidate; truth ΔBIC: of the true one; – where none is named or the truth has no candidate that could be tested"
    );
    let as_outcomes: Vec<Outcome> = outcomes
        .iter()
        .map(|o| Outcome {
            truth: o.truth.clone(),
            magnitude: String::new(),
            verdict: o.verdict.clone(),
            heldout_before: 0.0,
            heldout_after: 0.0,
            heldout_lowered: false,
            set: o.set.clone(),
            top: o.top.clone(),
            record: serde_json::Value::Null,
            after: None,
            pending: None,
            disagreements: o.disagreements.clone(),
            lookalike: false,
        })
        .collect();
    let full = table(&as_outcomes);
    if let Some(at) = full.find("\nconfusion") {
        print!("{}", &full[at..]);
    }
    println!(
        "ΔBIC: of the named candidate; truth ΔBIC: of the true one; – where none is named or the truth has no candidate that could be tested"
    );
    let correct = outcomes.iter().filter(|o| o.correct()).count();
    let clean: Vec<&ExternalOutcome> = outcomes.iter().filter(|o| o.truth == "none").collect();
    let false_alarms = clean.iter().filter(|o| o.class() == Class::FalseAlarm).count();
    let wrong: Vec<&ExternalOutcome> = outcomes.iter().filter(|o| !o.correct()).collect();
    let in_set = wrong.iter().filter(|o| o.truth_in_set()).count();
    let classes: Vec<(&str, Class)> = outcomes.iter().map(|o| (o.truth.as_str(), o.class())).collect();
    print!("{}", outcome_table(&classes));
    let stated: Vec<(f64, bool)> = outcomes.iter().map(|o| (o.top.1, o.top.0 == o.truth)).collect();
    print!("{}", reliability_table(&stated));
    if let Some(path) = records {
        let lines: String = outcomes.iter().map(|o| format!("{}\n", o.record)).collect();
        write_atomically_text(path, &lines)?;
    }
    let slowest = outcomes.iter().map(|o| o.seconds).fold(0.0, f64::max);
    let total: f64 = outcomes.iter().map(|o| o.seconds).sum();
    println!(
        "\n{correct}/{} named correctly, {false_alarms} false alarm(s) on {} clean cases, true effect in the indistinguishable set in {in_set}/{} wrong verdicts; wall time {total:.1} s, slowest {slowest:.2} s",
        outcomes.len(),
        clean.len(),
        wrong.len()
    );
    let self_disagreeing = outcomes.iter().filter(|o| !o.disagreements.is_empty()).count();
    println!("{self_disagreeing} report(s) disagree with themselves");
    let second = if followups > 0 { Some(external_followups(dir, &calib, &outcomes, followups)?) } else { None };
    if json {
        println!(
            "{}",
            serde_json::json!({
                "cases": outcomes.len(),
                "correct": correct,
                "false_alarms": false_alarms,
                "clean_cases": clean.len(),
                "wrong": wrong.len(),
                "truth_in_indistinguishable": in_set,
                "slowest_s": slowest,
                "confident_wrong": classes.iter().filter(|(_, c)| *c == Class::ConfidentWrong).count(),
                "in_set": classes.iter().filter(|(_, c)| *c == Class::InSet).count(),
                "missed": classes.iter().filter(|(_, c)| *c == Class::Missed).count(),
                "self_disagreeing": self_disagreeing,
                "followups": second,
            })
        );
    }
    Ok(())
}

/// The steps of `--external --followups N`: each case with the follow-up its own report asked
/// for, diagnosed again from the recordings so far, then with the next one that report asks
/// for, up to `most` follow-ups (a case that is named, or asks for nothing, stops).
fn external_followups(
    dir: &std::path::Path,
    calib: &ipmc_core::Calibration,
    before: &[ExternalOutcome],
    most: usize,
) -> Result<serde_json::Value> {
    println!("\nfollow-ups: each case with the follow-up its report asks for, up to {most} in turn");
    println!("{:<7} {:<24} {:<22} {:<24} {:>6}  set (probability)", "case", "truth", "follow-ups", "verdict", "s");
    let mut after: Vec<(String, Class)> = Vec::new();
    let mut stated: Vec<(f64, bool)> = Vec::new();
    let mut slowest: f64 = 0.0;
    let mut self_disagreeing = 0;
    let mut taken_counts = vec![0usize; most + 1];
    for o in before {
        let primary = dir.join(format!("{}.csv", o.case));
        let mut files = vec![primary];
        let mut taken: Vec<ipmc_recording::Protocol> = Vec::new();
        let mut request = o.request;
        let mut last: Option<(ipmc_diagnose::Diagnosis, f64)> = None;
        let mut missing = None;
        while taken.len() < most {
            let Some(protocol) = request else { break };
            let file = dir.join("followups").join(format!("{}-{protocol}.csv", o.case));
            if !file.exists() {
                missing = Some(protocol);
                break;
            }
            files.push(file);
            taken.push(protocol);
            let t0 = std::time::Instant::now();
            let read = ipmc_diagnose::strip_files::read(&files)?;
            let strip = ipmc_diagnose::strip_diagnosis::diagnose(calib, &read, &calib.humidity, &|_| {})
                .with_context(|| format!("{} with {} follow-up(s)", o.case, taken.len()))?;
            let seconds = t0.elapsed().as_secs_f64();
            slowest = slowest.max(seconds);
            let inputs: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
            let disagree = disagreements(&strip.diagnosis, &inputs);
            if !disagree.is_empty() {
                self_disagreeing += 1;
                for e in &disagree {
                    println!("        {} with {} follow-up(s): its report disagrees with itself: {e}", o.case, taken.len());
                }
            }
            request = strip.diagnosis.request.as_ref().map(|r| r.protocol);
            last = Some((strip.diagnosis, seconds));
        }
        taken_counts[taken.len()] += 1;
        let Some((d, seconds)) = last else {
            println!(
                "{:<7} {:<24} {:<22} {:<24} {:>6}  (no follow-up {})",
                o.case,
                o.truth,
                "–",
                o.verdict,
                "–",
                if missing.is_some() { "file" } else { "asked for" }
            );
            after.push((o.truth.clone(), o.class()));
            stated.push((o.top.1, o.top.0 == o.truth));
            continue;
        };
        let class = Class::of(&o.truth, d.verdict.as_str(), &d.set);
        let probability_of = |n: &str| d.probability_of(n);
        let set: Vec<String> = d.set.iter().map(|n| format!("{n} ({:.0} %)", 100.0 * probability_of(n))).collect();
        let mark = if class == Class::Named { String::new() } else { format!("  ({})", class.label()) };
        let next = match (&d.request, missing) {
            (_, Some(p)) => format!("; asks for {p}, no file"),
            (Some(r), None) if d.verdict.effect().is_none() => format!("; would ask for {} next", r.protocol),
            (None, None) if d.verdict.effect().is_none() => "; no protocol left can decide".into(),
            _ => String::new(),
        };
        println!(
            "{:<7} {:<24} {:<22} {:<24} {:>6.2}  {}{mark}{next}",
            o.case,
            o.truth,
            taken.iter().map(|p| p.to_string()).collect::<Vec<_>>().join("+"),
            d.verdict.to_string(),
            seconds,
            set.join(", ")
        );
        let top = top_of(&d);
        stated.push((top.1, top.0 == o.truth));
        after.push((o.truth.clone(), class));
    }
    let classes_before: Vec<(&str, Class)> = before.iter().map(|o| (o.truth.as_str(), o.class())).collect();
    let classes_after: Vec<(&str, Class)> = after.iter().map(|(t, c)| (t.as_str(), *c)).collect();
    print!("\nbefore the follow-ups:{}", outcome_table(&classes_before));
    print!("\nafter the follow-ups (at most {most} a case):{}", outcome_table(&classes_after));
    print!("{}", reliability_table(&stated));
    let named = classes_after.iter().filter(|(_, c)| *c == Class::Named).count();
    println!(
        "\n{named}/{} named after at most {most} follow-up(s) a case ({}); {self_disagreeing} report(s) with follow-ups disagree with themselves; slowest diagnosis with its follow-ups {slowest:.2} s",
        after.len(),
        taken_counts.iter().enumerate().map(|(k, n)| format!("{n} took {k}")).collect::<Vec<_>>().join(", ")
    );
    let count = |c: Class| classes_after.iter().filter(|(_, k)| *k == c).count();
    Ok(serde_json::json!({
        "named": named,
        "in_set": count(Class::InSet),
        "missed": count(Class::Missed),
        "confident_wrong": count(Class::ConfidentWrong),
        "false_alarms": count(Class::FalseAlarm),
        "self_disagreeing": self_disagreeing,
        "slowest_s": slowest,
        "at_most": most,
    }))
}
