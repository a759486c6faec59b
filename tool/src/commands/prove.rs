//! `ipmc prove [--seed N] [--per-effect N] [--clean N] [--format fr|ts] [--json]`: builds
//! sessions with one concealed effect each (`ipmc_sim::concealed`, as frequency
//! responses or time series) plus clean controls, writes each as an interchange-format
//! recording, runs the diagnosis blind on the file (cases in parallel), and prints the
//! confusion table.
//!
//! `ipmc prove --external DIR [--calib DIR/nominal.toml]`: diagnoses recordings made elsewhere
//! (DIR/caseNN.csv, one at a time, each timed) against DIR/truths.json and prints the same
//! table with each case's indistinguishable set, evidence and wall time.
//!
//! `--followups` adds the second step: each case takes the follow-up its own report asks for (the
//! simulator makes it for the own cases; DIR/followups/caseNN-<protocol>.csv for external ones)
//! and the strip is diagnosed again from both; the outcome tables before and after.

use anyhow::{Context, Result};
use ipmc_core::calibration::humidity_path::HumidityPath;
use ipmc_diagnose::data::Dataset;
use ipmc_diagnose::{Effect, engine};
use ipmc_sim::concealed::{Format, Strength, make_case};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

#[derive(clap::Args)]
pub struct Args {
    /// Seed of the whole run (effects' magnitudes, noise, session timing).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Cases with an effect per effect of the library (each with its own magnitude and noise).
    #[arg(long, default_value_t = 2)]
    per_effect: usize,
    /// Clean controls (no effect).
    #[arg(long, default_value_t = 6)]
    clean: usize,
    /// Calibration the sessions are built from and diagnosed with.
    #[arg(long)]
    calib: Option<String>,
    /// Put every effect's magnitude at this fraction of its range (log scale, 0 = smallest)
    /// instead of drawing it at random.
    #[arg(long)]
    at: Option<f64>,
    /// Keep the recordings and each case's report here (default: a temporary directory).
    #[arg(long)]
    keep: Option<PathBuf>,
    /// End with one JSON line {"cases", "correct", "false_positives", "clean_cases", …}.
    #[arg(long)]
    json: bool,
    /// Record each case as a frequency response (`fr`) or a time series of multisine bursts (`ts`).
    #[arg(long, value_enum, default_value = "fr")]
    format: Format,
    /// Diagnose the recordings of this directory (caseNN.csv) against its truths.json instead
    /// of making sessions; the calibration defaults to DIR/nominal.toml.
    #[arg(long)]
    external: Option<PathBuf>,
    /// Run this many seeds (from `--seed` on) and pool their cases: the outcome and reliability
    /// tables over ≥ 100 cases.
    #[arg(long, default_value_t = 1)]
    seeds: u64,
    /// Also write each case as one JSON line here: truth, verdict, the stated probabilities and
    /// every candidate's evidence (what the evidence scale is calibrated from).
    #[arg(long)]
    records: Option<PathBuf>,
    /// Two steps: diagnose each case, then take the follow-up its report asks for (with
    /// `--external`: DIR/followups/caseNN-<protocol>.csv) and diagnose the strip again from
    /// both; prints the outcome tables before and after.
    #[arg(long)]
    followups: bool,
}

/// How a verdict stands against the truth: the outcome table.
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
fn record(truth: &str, d: &ipmc_diagnose::Diagnosis) -> serde_json::Value {
    serde_json::json!({
        "truth": truth,
        "verdict": d.verdict,
        "set": d.set,
        "probabilities": d.probabilities,
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

/// One case's outcome.
pub struct Outcome {
    pub truth: String,
    pub magnitude: String,
    pub verdict: String,
    pub heldout_before: f64,
    pub heldout_after: f64,
    /// Naming the verdict improved the prediction of held-out data (`Diagnosis::heldout_lowered`).
    pub heldout_lowered: bool,
    /// The smallest set holding the confidence, and the most probable hypothesis's probability.
    pub set: Vec<String>,
    pub top: (String, f64),
    pub record: serde_json::Value,
    /// With `--followups`: the protocol the report asked for and the outcome with it.
    pub after: Option<AfterFollowup>,
    /// The follow-up recorded and not yet diagnosed.
    pub pending: Option<PendingFollowup>,
}

/// A case diagnosed again with the follow-up its report asked for.
pub struct AfterFollowup {
    pub protocol: ipmc_recording::Protocol,
    pub verdict: String,
    pub set: Vec<String>,
    pub top: (String, f64),
    pub seconds: f64,
}

impl Outcome {
    pub fn class(&self) -> Class {
        Class::of(&self.truth, &self.verdict, &self.set)
    }
}

fn top_of(d: &ipmc_diagnose::Diagnosis) -> (String, f64) {
    d.probabilities.first().map_or(("none".into(), 1.0), |p| (p.name.clone(), p.probability))
}

/// What a run makes: `per_effect` cases of every effect and `clean` controls, each recorded as
/// `format`, magnitudes at `strength`, all seeded from `seed`.
pub struct Plan {
    pub seed: u64,
    pub per_effect: usize,
    pub clean: usize,
    pub strength: Strength,
    pub format: Format,
    /// Take the follow-up each report asks for and diagnose the strip again from both.
    pub followups: bool,
}

/// Runs the cases of `plan`; `dir` receives the recordings. Cases are independent and each is
/// seeded by its index, so they run on every core and the outcomes (in plan order) do not
/// depend on how many there are.
pub fn run_cases(
    calib: &ipmc_core::Calibration,
    &Plan { seed, per_effect, clean, strength, format, followups }: &Plan,
    dir: &std::path::Path,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Vec<Outcome>> {
    let mut plan: Vec<Option<Effect>> = Vec::new();
    for _ in 0..per_effect {
        plan.extend(Effect::ALL.map(Some));
    }
    plan.extend(std::iter::repeat_n(None, clean));
    let one = |i: usize, effect: Option<Effect>| -> Result<Outcome> {
        let case = make_case(calib, effect, seed.wrapping_mul(10_007).wrapping_add(i as u64), strength, format)?;
        let truth = effect.map_or("none", Effect::name).to_string();
        let path = dir.join(format!("case-{i:03}-{truth}.csv"));
        let csv = case.recording.to_csv()?;
        ipmc_recording::write_atomically(&path, csv.as_bytes())?;
        // Blind: the diagnosis sees only the file.
        let data = Dataset::read(std::slice::from_ref(&path), &HumidityPath::NONE)?;
        let d = engine::diagnose(calib, &data, &|_| {}).with_context(|| format!("case {i} ({truth})"))?;
        // The follow-up is recorded here; it is diagnosed after every case, one at a time, so
        // that the time printed is a diagnosis's own, not one sharing the cores with others.
        let pending = match d.request.as_ref().filter(|_| followups) {
            None => None,
            Some(r) => {
                let name = path.file_name().expect("a file name").to_string_lossy().into_owned();
                let up =
                    ipmc_sim::followup::make_followup(calib, &case, r.protocol, &name, seed.wrapping_mul(7919).wrapping_add(i as u64))?;
                let up_path = dir.join(format!("case-{i:03}-{truth}-{}.csv", r.protocol));
                ipmc_recording::write_atomically(&up_path, up.to_csv()?.as_bytes())?;
                Some(PendingFollowup { protocol: r.protocol, files: [path.clone(), up_path] })
            }
        };
        progress(&format!("case {i}: {truth}"));
        Ok(Outcome {
            record: record(&truth, &d),
            truth,
            magnitude: case.magnitude,
            verdict: d.verdict.to_string(),
            heldout_before: d.heldout_before,
            heldout_after: d.heldout_after,
            heldout_lowered: d.heldout_lowered(),
            set: d.set.clone(),
            top: top_of(&d),
            after: None,
            pending,
        })
    };
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<Outcome>>>> = Mutex::new((0..plan.len()).map(|_| None).collect());
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get()).min(plan.len().max(1));
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&effect) = plan.get(i) else { break };
                    let outcome = one(i, effect);
                    results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(outcome);
                }
            });
        }
    });
    let mut outcomes: Vec<Outcome> = results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err(anyhow::anyhow!("a case was not run"))))
        .collect::<Result<_>>()?;
    for (i, o) in outcomes.iter_mut().enumerate() {
        let Some(PendingFollowup { protocol, files }) = o.pending.take() else { continue };
        let t0 = std::time::Instant::now();
        let read = ipmc_diagnose::strip_files::read(&files)?;
        let strip = ipmc_diagnose::strip_diagnosis::diagnose(calib, &read, &HumidityPath::NONE, &|_| {})
            .with_context(|| format!("case {i} ({}) with its {protocol} follow-up", o.truth))?;
        let d2 = &strip.diagnosis;
        o.after = Some(AfterFollowup {
            protocol,
            verdict: d2.verdict.to_string(),
            set: d2.set.clone(),
            top: top_of(d2),
            seconds: t0.elapsed().as_secs_f64(),
        });
    }
    Ok(outcomes)
}

/// A case's follow-up recording, written, waiting for its diagnosis with the primary.
pub struct PendingFollowup {
    protocol: ipmc_recording::Protocol,
    files: [std::path::PathBuf; 2],
}

pub fn run(a: Args) -> Result<()> {
    if let Some(dir) = &a.external {
        return external(dir, a.calib.as_deref(), a.json, a.records.as_deref(), a.followups);
    }
    let calib = ipmc_tool::calibration_source::load(a.calib.as_deref())?;
    let dir = match &a.keep {
        Some(d) => d.clone(),
        None => std::env::temp_dir().join(format!("ipmc-prove-{}", std::process::id())),
    };
    std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
    anyhow::ensure!(a.seeds >= 1, "--seeds must be at least 1");
    let total = a.seeds * (a.per_effect * Effect::ALL.len() + a.clean) as u64;
    let bar = ipmc_tool::progress::bar(total, "cases");
    if let Some(at) = a.at {
        anyhow::ensure!((0.0..=1.0).contains(&at), "--at must be within 0 and 1, not {at}");
    }
    let strength = a.at.map_or(Strength::Random, Strength::At);
    let started = std::time::Instant::now();
    let mut outcomes = Vec::new();
    for seed in a.seed..a.seed + a.seeds {
        let plan = Plan { seed, per_effect: a.per_effect, clean: a.clean, strength, format: a.format, followups: a.followups };
        outcomes.extend(run_cases(&calib, &plan, &dir, &|_| bar.inc(1))?);
    }
    let wall_s = started.elapsed().as_secs_f64();
    bar.finish_and_clear();
    if a.keep.is_none() {
        let _ = std::fs::remove_dir_all(&dir);
    }
    print!("{}", table(&outcomes));
    let classes: Vec<(&str, Class)> = outcomes.iter().map(|o| (o.truth.as_str(), o.class())).collect();
    print!("{}", outcome_table(&classes));
    let stated: Vec<(f64, bool)> = outcomes.iter().map(|o| (o.top.1, o.top.0 == o.truth)).collect();
    print!("{}", reliability_table(&stated));
    let second = a.followups.then(|| second_step_summary(&outcomes));
    if let Some(path) = &a.records {
        let lines: String = outcomes.iter().map(|o| format!("{}\n", o.record)).collect();
        write_atomically_text(path, &lines)?;
    }
    let correct = outcomes.iter().filter(|o| o.verdict == o.truth).count();
    let clean: Vec<&Outcome> = outcomes.iter().filter(|o| o.truth == "none").collect();
    // A clean control left undecided with `none` in its set is not an alarm: only a name is.
    let false_positives = clean.iter().filter(|o| o.class() == Class::FalseAlarm).count();
    let improved = outcomes.iter().filter(|o| o.verdict == o.truth && o.truth != "none").filter(|o| o.heldout_lowered).count();
    let named = outcomes.iter().filter(|o| o.verdict == o.truth && o.truth != "none").count();
    println!(
        "\n{correct}/{} correct ({:.0} %), {false_positives} false positive(s) on {} clean controls, held-out error reduced in {improved}/{named} correct diagnoses; wall time {wall_s:.1} s (making and diagnosing every case)",
        outcomes.len(),
        100.0 * correct as f64 / outcomes.len() as f64,
        clean.len()
    );
    if a.json {
        println!(
            "{}",
            serde_json::json!({
                "cases": outcomes.len(),
                "correct": correct,
                "false_positives": false_positives,
                "clean_cases": clean.len(),
                "heldout_reduced": improved,
                "named_correctly": named,
                "wall_time_s": wall_s,
                "confident_wrong": classes.iter().filter(|(_, c)| *c == Class::ConfidentWrong).count(),
                "false_alarms": classes.iter().filter(|(_, c)| *c == Class::FalseAlarm).count(),
                "in_set": classes.iter().filter(|(_, c)| *c == Class::InSet).count(),
                "missed": classes.iter().filter(|(_, c)| *c == Class::Missed).count(),
                "followups": second,
            })
        );
    }
    Ok(())
}

/// `--followups` on the own cases: the outcome table after each case took the follow-up its
/// report asked for (cases that asked for none keep their verdict), and the summary as JSON.
fn second_step_summary(outcomes: &[Outcome]) -> serde_json::Value {
    let after: Vec<(&str, Class)> = outcomes
        .iter()
        .map(|o| match &o.after {
            Some(a) => (o.truth.as_str(), Class::of(&o.truth, &a.verdict, &a.set)),
            None => (o.truth.as_str(), o.class()),
        })
        .collect();
    let mut asked: BTreeMap<String, usize> = BTreeMap::new();
    for a in outcomes.iter().filter_map(|o| o.after.as_ref()) {
        *asked.entry(a.protocol.to_string()).or_default() += 1;
    }
    // Every case whose outcome the follow-up changed, and every one it leaves short of a name.
    println!(
        "\ncases the follow-up changed or left short of a name (index in the run: truth (magnitude), before → after with the protocol; the diagnosis's seconds with both recordings, one diagnosis at a time)"
    );
    for (i, (o, (_, class))) in outcomes.iter().zip(&after).enumerate() {
        if o.after.is_none() && *class != Class::Named {
            println!("  {i:>4}: {} ({}): {}, no follow-up asked  [{}]", o.truth, o.magnitude, o.verdict, class.label());
        }
        if let Some(a) = &o.after
            && (*class != o.class() || *class != Class::Named)
        {
            println!(
                "  {i:>4}: {} ({}): {} → {} with {} ({}: {:.1} %; {:.1} s){}",
                o.truth,
                o.magnitude,
                o.verdict,
                a.verdict,
                a.protocol,
                a.top.0,
                100.0 * a.top.1,
                a.seconds,
                if *class == Class::Named { String::new() } else { format!("  [{}]", class.label()) }
            );
        }
    }
    print!(
        "\nafter the follow-ups (asked for: {}):{}",
        asked.iter().map(|(p, n)| format!("{p} {n}")).collect::<Vec<_>>().join(", "),
        outcome_table(&after)
    );
    let stated: Vec<(f64, bool)> =
        outcomes.iter().map(|o| (o.after.as_ref().map_or(&o.top, |a| &a.top), &o.truth)).map(|(t, truth)| (t.1, &t.0 == truth)).collect();
    print!("{}", reliability_table(&stated));
    let slowest = outcomes.iter().filter_map(|o| o.after.as_ref()).map(|a| a.seconds).fold(0.0, f64::max);
    let count = |c: Class| after.iter().filter(|(_, k)| *k == c).count();
    let over = outcomes.iter().filter_map(|o| o.after.as_ref()).filter(|a| a.seconds > 10.0).count();
    println!(
        "{}/{} named after the follow-ups; slowest diagnosis with its follow-up {slowest:.2} s ({over} over 10 s)",
        count(Class::Named),
        after.len()
    );
    serde_json::json!({
        "named": count(Class::Named),
        "in_set": count(Class::InSet),
        "missed": count(Class::Missed),
        "confident_wrong": count(Class::ConfidentWrong),
        "false_alarms": count(Class::FalseAlarm),
        "slowest_s": slowest,
    })
}

/// Per case, then the confusion table (rows: truth, columns: verdict).
pub fn table(outcomes: &[Outcome]) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(s, "{:<24} {:<26} {:<58} {:>9} {:>9}", "concealed", "verdict", "magnitude", "held-out", "after");
    for o in outcomes {
        let mark = match o.class() {
            Class::Named => "".to_string(),
            c => format!("  ({})", c.label()),
        };
        let _ =
            writeln!(s, "{:<24} {:<26} {:<58} {:>9.3} {:>9.3}{mark}", o.truth, o.verdict, o.magnitude, o.heldout_before, o.heldout_after);
    }
    let mut verdicts: Vec<&str> = outcomes.iter().map(|o| o.verdict.as_str()).collect();
    verdicts.sort();
    verdicts.dedup();
    let mut rows: BTreeMap<&str, BTreeMap<&str, usize>> = BTreeMap::new();
    for o in outcomes {
        *rows.entry(o.truth.as_str()).or_default().entry(o.verdict.as_str()).or_default() += 1;
    }
    let _ = writeln!(s, "\nconfusion (rows: concealed, columns: verdict)");
    let abbrev = |v: &str| v.chars().take(8).collect::<String>();
    let _ = write!(s, "{:<24}", "");
    for v in &verdicts {
        let _ = write!(s, " {:>8}", abbrev(v));
    }
    let _ = writeln!(s);
    for (truth, row) in &rows {
        let _ = write!(s, "{truth:<24}");
        for v in &verdicts {
            match row.get(v) {
                Some(n) => {
                    let _ = write!(s, " {n:>8}");
                }
                None => {
                    let _ = write!(s, " {:>8}", ".");
                }
            }
        }
        let _ = writeln!(s);
    }
    s
}

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

fn external(dir: &std::path::Path, calib: Option<&str>, json: bool, records: Option<&std::path::Path>, followups: bool) -> Result<()> {
    let default_calib = dir.join("nominal.toml");
    let calib_arg = calib.map(str::to_string).unwrap_or_else(|| default_calib.display().to_string());
    let calib = ipmc_tool::calibration_source::load(Some(&calib_arg))?;
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

fn write_atomically_text(path: &std::path::Path, text: &str) -> Result<()> {
    ipmc_recording::write_atomically(path, text.as_bytes()).with_context(|| format!("cannot write {}", path.display()))
}
