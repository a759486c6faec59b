//! `ipmc prove --external DIR`: recordings made elsewhere (DIR/caseNN.csv) diagnosed one at a
//! time, each timed, against DIR/truths.json; with the follow-ups, each case again with the
//! follow-up its report asks for (DIR/followups/caseNN-<protocol>.csv).

use super::cases::{Outcome, table};
use super::outcome::{Class, outcome_table, record, reliability_table, top_of, write_atomically_text};
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
pub fn external(dir: &std::path::Path, calib: Option<&str>, json: bool, records: Option<&std::path::Path>, followups: bool) -> Result<()> {
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
            truth,
            seconds,
        };
        let mark = match o.class() {
            Class::Named => String::new(),
            c => format!("  ({})", c.label()),
        };
        let probability_of = |n: &str| d.probabilities.iter().find(|p| p.name == n).map_or(0.0, |p| p.probability);
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
    let second = if followups { Some(external_second_step(dir, &calib, &outcomes)?) } else { None };
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
                "followups": second,
            })
        );
    }
    Ok(())
}

/// The second step of `--external --followups`: each case with the follow-up its own report
/// asked for (at most one), diagnosed again from both recordings.
fn external_second_step(dir: &std::path::Path, calib: &ipmc_core::Calibration, before: &[ExternalOutcome]) -> Result<serde_json::Value> {
    println!("\nsecond step: each case with the follow-up its report asks for");
    println!("{:<7} {:<24} {:<12} {:<24} {:>6}  set (probability)", "case", "truth", "follow-up", "verdict", "s");
    let mut after: Vec<(String, Class)> = Vec::new();
    let mut stated: Vec<(f64, bool)> = Vec::new();
    let mut slowest: f64 = 0.0;
    for o in before {
        let primary = dir.join(format!("{}.csv", o.case));
        let followup = o.request.map(|p| dir.join("followups").join(format!("{}-{}.csv", o.case, p)));
        let Some(followup) = followup.filter(|f| f.exists()) else {
            println!(
                "{:<7} {:<24} {:<12} {:<24} {:>6}  (no follow-up {})",
                o.case,
                o.truth,
                "–",
                o.verdict,
                "–",
                if o.request.is_some() { "file" } else { "asked for" }
            );
            after.push((o.truth.clone(), o.class()));
            stated.push((o.top.1, o.top.0 == o.truth));
            continue;
        };
        let t0 = std::time::Instant::now();
        let files = ipmc_diagnose::strip_files::read(&[primary, followup])?;
        let strip = ipmc_diagnose::strip_diagnosis::diagnose(calib, &files, &calib.humidity, &|_| {})
            .with_context(|| format!("{} with its follow-up", o.case))?;
        let seconds = t0.elapsed().as_secs_f64();
        slowest = slowest.max(seconds);
        let d = &strip.diagnosis;
        let class = Class::of(&o.truth, d.verdict.as_str(), &d.set);
        let probability_of = |n: &str| d.probabilities.iter().find(|p| p.name == n).map_or(0.0, |p| p.probability);
        let set: Vec<String> = d.set.iter().map(|n| format!("{n} ({:.0} %)", 100.0 * probability_of(n))).collect();
        let mark = if class == Class::Named { String::new() } else { format!("  ({})", class.label()) };
        println!(
            "{:<7} {:<24} {:<12} {:<24} {:>6.2}  {}{mark}",
            o.case,
            o.truth,
            o.request.map_or("–".into(), |p| p.to_string()),
            d.verdict.to_string(),
            seconds,
            set.join(", ")
        );
        let top = top_of(d);
        stated.push((top.1, top.0 == o.truth));
        after.push((o.truth.clone(), class));
    }
    let classes_before: Vec<(&str, Class)> = before.iter().map(|o| (o.truth.as_str(), o.class())).collect();
    let classes_after: Vec<(&str, Class)> = after.iter().map(|(t, c)| (t.as_str(), *c)).collect();
    print!("\nbefore the follow-ups:{}", outcome_table(&classes_before));
    print!("\nafter the follow-ups:{}", outcome_table(&classes_after));
    print!("{}", reliability_table(&stated));
    let named = classes_after.iter().filter(|(_, c)| *c == Class::Named).count();
    println!("\n{named}/{} named after the follow-ups; slowest diagnosis with its follow-up {slowest:.2} s", after.len());
    let count = |c: Class| classes_after.iter().filter(|(_, k)| *k == c).count();
    Ok(serde_json::json!({
        "named": named,
        "in_set": count(Class::InSet),
        "missed": count(Class::Missed),
        "confident_wrong": count(Class::ConfidentWrong),
        "false_alarms": count(Class::FalseAlarm),
        "slowest_s": slowest,
    }))
}
