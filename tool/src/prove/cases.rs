//! `ipmc prove`'s own cases: sessions with one concealed effect each (`ipmc_sim::concealed`) and
//! clean controls, each written as a recording and diagnosed blind from the file, on every core;
//! with the follow-ups, each case diagnosed again with the follow-up its report asks for.

use super::outcome::{Class, outcome_table, record, reliability_table, top_of};
use anyhow::{Context, Result};
use ipmc_core::calibration::humidity_path::HumidityPath;
use ipmc_diagnose::data::Dataset;
use ipmc_diagnose::{Effect, engine};
use ipmc_sim::concealed::{Format, Strength, make_case};
use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

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

/// `--followups` on the own cases: the outcome table after each case took the follow-up its
/// report asked for (cases that asked for none keep their verdict), and the summary as JSON.
pub fn second_step_summary(outcomes: &[Outcome]) -> serde_json::Value {
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
